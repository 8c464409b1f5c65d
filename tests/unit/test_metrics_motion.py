"""Kinetic / geometric features, FID, Div and Multimodality (METRICS.md §1.1–1.4, §3.2)."""

from __future__ import annotations

import logging
import warnings

import numpy as np
import pytest
from tests.helpers.motion_reference import (
    reference_avg_distance,
    reference_calc_fid,
    reference_kinetic,
    reference_manual,
    reference_mint_fid,
    reference_normalize,
)

from momu.data.types import Clip
from momu.features.skeletons import get_skeleton
from momu.metrics import diversity, fid, geometric_features, kinetic_features, multimodality
from momu.metrics.diversity import average_pairwise_distance
from momu.metrics.frechet import (
    frechet_distance,
    frechet_distance_from_stats,
    matrix_sqrt,
    normalize_by_reference,
)
from momu.metrics.geometric import GEOMETRIC_FEATURE_TABLE, HIP_WIDTH, HUMERUS_LENGTH, SHOULDER_WIDTH
from momu.metrics.motion_metrics import clip_features, prepare_motion
from momu.registry import METRICS

REST = get_skeleton("smpl24").rest_pose()  # (24, 3) T-pose, y up, metres


def dance(seed: int, frames: int = 40, dtype: type = np.float32) -> np.ndarray:
    """A smooth SMPL-24-shaped motion: rest pose + per-joint sinusoids + root drift, (T, 24, 3)."""
    rng = np.random.default_rng(seed)
    t = np.arange(frames)[:, None, None] / 60.0
    amp = rng.uniform(0.02, 0.15, size=(1, 24, 3))
    freq = rng.uniform(0.5, 3.0, size=(1, 24, 3))
    phase = rng.uniform(0, 2 * np.pi, size=(1, 24, 3))
    drift = rng.normal(0, 0.3, size=(1, 1, 3)) * t
    return (
        REST[None] + amp * np.sin(2 * np.pi * freq * t + phase) + drift + rng.normal(0, 0.5, (1, 1, 3))
    ).astype(dtype)


# ----------------------------------------------------------------------------- kinetic features
def test_kinetic_static_motion_is_hand_computable() -> None:
    # Static joints at p: KE = 0; the reference's EE = ‖p‖·(1/ft − 1)/ft = 3540‖p‖ at 60 fps;
    # the corrected EE = 0.
    p = REST + np.array([0.5, 0.0, -0.25])
    motion = np.repeat(p[None], 10, axis=0)
    feats = kinetic_features(motion).reshape(24, 3)
    np.testing.assert_array_equal(feats[:, :2], 0.0)
    np.testing.assert_allclose(feats[:, 2], 3540.0 * np.linalg.norm(p, axis=1), rtol=1e-6)
    corrected = kinetic_features(motion, variant="corrected").reshape(24, 3)
    np.testing.assert_allclose(corrected, 0.0, atol=1e-9)


def test_kinetic_constant_velocity() -> None:
    # Each joint moves u metres per frame: V = u/ft everywhere → KE_h = (ux²+uz²)/ft², KE_v = uy²/ft².
    u = np.array([0.01, -0.02, 0.005])
    frames = np.arange(12)[:, None, None]
    motion = REST[None] + frames * u
    feats = kinetic_features(motion).reshape(24, 3)
    np.testing.assert_allclose(feats[:, 0], (0.01**2 + 0.005**2) * 3600, rtol=1e-6)
    np.testing.assert_allclose(feats[:, 1], 0.02**2 * 3600, rtol=1e-6)
    # corrected EE of a constant-velocity motion is 0 (no acceleration)
    corrected = kinetic_features(motion, variant="corrected").reshape(24, 3)
    np.testing.assert_allclose(corrected[:, 2], 0.0, atol=1e-6)
    np.testing.assert_allclose(corrected[:, :2], feats[:, :2], rtol=1e-7)
    # frame_time scales KE by 1/ft²
    slow = kinetic_features(motion, frame_time=1 / 30).reshape(24, 3)
    np.testing.assert_allclose(slow[:, :2], feats[:, :2] / 4, rtol=1e-6)


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
@pytest.mark.parametrize("frames", [3, 4, 7, 33])
def test_kinetic_equals_reference_loops(dtype: type, frames: int) -> None:
    motion = dance(frames, frames, dtype)
    np.testing.assert_array_equal(kinetic_features(motion), reference_kinetic(motion))
    np.testing.assert_array_equal(
        kinetic_features(motion, variant="corrected"), reference_kinetic(motion, buggy=False)
    )


def test_kinetic_up_axis_z_and_window() -> None:
    motion = dance(1, 20, np.float64)
    zup = motion[..., [0, 2, 1]]  # y-up → z-up (x, z, y)
    np.testing.assert_allclose(kinetic_features(zup, up_axis="z"), reference_kinetic(zup, up="z"), rtol=1e-6)
    np.testing.assert_allclose(
        kinetic_features(zup, up_axis="z").reshape(24, 3)[:, :2],
        kinetic_features(motion).reshape(24, 3)[:, :2],
        rtol=1e-6,
    )
    np.testing.assert_array_equal(kinetic_features(motion, sliding_window=1), reference_kinetic(motion, w=1))


def test_kinetic_batches_and_lists() -> None:
    a, b, c = dance(1, 30), dance(2, 30), dance(3, 17)
    batch = kinetic_features(np.stack([a, b]))
    assert batch.shape == (2, 72) and batch.dtype == np.float32
    np.testing.assert_array_equal(batch[1], kinetic_features(b))
    listed = kinetic_features([a, c])
    np.testing.assert_array_equal(listed[1], kinetic_features(c))


def test_kinetic_bad_input() -> None:
    with pytest.raises(ValueError, match="at least 3 frames"):
        kinetic_features(np.zeros((2, 24, 3)))
    with pytest.raises(ValueError, match="shape"):
        kinetic_features(np.zeros((10, 3, 24)))
    bad = dance(0, 10)
    bad[3, 4, 1] = np.nan
    with pytest.raises(ValueError, match="NaN"):
        kinetic_features(bad)
    with pytest.raises(ValueError, match="variant"):
        kinetic_features(dance(0, 10), variant="fixed")  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="sliding_window"):
        kinetic_features(dance(0, 10), sliding_window=0)


# ----------------------------------------------------------------------------- geometric features
def test_geometric_constants_match_spec() -> None:
    assert HUMERUS_LENGTH == pytest.approx(0.2568381092115207, abs=1e-15)
    assert SHOULDER_WIDTH == pytest.approx(0.39084835854945527, abs=1e-15)
    assert HIP_WIDTH == pytest.approx(0.11924706586886204, abs=1e-15)
    assert len(GEOMETRIC_FEATURE_TABLE) == 32


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
@pytest.mark.parametrize("frames", [2, 3, 25])
def test_geometric_equals_reference_loops(dtype: type, frames: int) -> None:
    rng = np.random.default_rng(frames)
    noisy = (dance(frames, frames, np.float64) + rng.normal(0, 0.05, (frames, 24, 3))).astype(dtype)
    np.testing.assert_array_equal(geometric_features(noisy), reference_manual(noisy))
    scrambled = (rng.normal(size=(frames, 24, 3)) * 0.4).astype(dtype)  # arbitrary poses: every branch fires
    np.testing.assert_array_equal(geometric_features(scrambled), reference_manual(scrambled))


def test_geometric_static_upright_pose() -> None:
    motion = np.repeat(REST[None], 6, axis=0)
    feats = geometric_features(motion)
    velocity_features = [0, 1, 4, 5, 9, 10, 11, 12, 13, 21, 22, 31]
    np.testing.assert_array_equal(feats[velocity_features], 0.0)  # nothing moves
    assert feats[28] == 0.0  # neck→root is straight down: 180°, not "lying" (70°, 110°)
    np.testing.assert_array_equal(feats[[6, 7]], 0.0)  # straight arms: elbow angle 180° ∉ (0, 110)
    # Lying on the back: the spine becomes horizontal → feature 28 holds on every frame.
    rot = np.array([[1.0, 0, 0], [0, 0, -1], [0, 1, 0]])  # +90° about x: y → z
    lying = np.repeat((REST @ rot.T)[None], 6, axis=0)
    assert geometric_features(lying)[28] == 1.0


def test_geometric_fast_uses_reference_time_per_frame() -> None:
    # Whole body translates 1 cm per frame. Reference: speed = 0.01·120 = 1.2 m/s > 2.3hl (0.59) and
    # > 2.5hl (0.64)
    # → root, wrist and ankle "fast" features all 1. Corrected (60 fps): 0.6 m/s → root only (0.6 > 0.5907).
    motion = REST[None] + np.arange(8)[:, None, None] * np.array([0.01, 0.0, 0.0])
    compat = geometric_features(motion)
    np.testing.assert_array_equal(compat[[12, 13, 21, 22, 31]], 1.0)
    corrected = geometric_features(motion, variant="corrected", fps=60)
    np.testing.assert_array_equal(corrected[[12, 13, 21, 22]], 0.0)
    assert corrected[31] == 1.0


def test_geometric_ignored_fourth_joint_quirk() -> None:
    rng = np.random.default_rng(5)
    motion = dance(9, 50, np.float64) + rng.normal(0, 0.05, (50, 24, 3))
    compat = geometric_features(motion)
    assert compat[4] == compat[5]  # both measure the chest, not the wrists
    # the corrected variant moves the wrist: raise the right wrist fast, keep the left one still
    up = np.repeat(REST[None], 20, axis=0)
    up[:, 21, 1] += np.arange(20) * 0.05  # right wrist rises at 3 m/s, the body stays still
    assert geometric_features(up)[4] == 0.0  # the reference never looks at the wrist
    corrected = geometric_features(up, variant="corrected")
    assert corrected[4] == 1.0 and corrected[5] == 0.0


def test_geometric_bad_input() -> None:
    with pytest.raises(ValueError, match="SMPL-24"):
        geometric_features(np.zeros((10, 22, 3)))
    with pytest.raises(ValueError, match="at least 2 frames"):
        geometric_features(np.zeros((1, 24, 3)))


# ----------------------------------------------------------------------------- Fréchet distance
def test_frechet_1d_hand_computed() -> None:
    x = np.array([[0.0], [2.0]])  # mean 1, var (ddof 1) 2
    y = np.array([[1.0], [5.0]])  # mean 3, var 8
    assert frechet_distance(x, y) == pytest.approx(4 + 2 + 8 - 2 * 4)
    # fid normalises with the reference: y → [-1, 1], x → [-1.5, -0.5]; FID = 1 + 0.5 + 2 - 2·1
    assert fid(x, y) == pytest.approx(1.5)
    assert fid(x, y, variant="mint") == pytest.approx(1.5)


def test_frechet_two_gaussians_closed_form() -> None:
    # Independent dims add up; closed form per dim: (μ1−μ2)² + (σ1−σ2)² with sample moments.
    rng = np.random.default_rng(0)
    a = rng.normal([0.0, 1.0], [1.0, 2.0], size=(400, 2))
    b = rng.normal([1.0, -1.0], [3.0, 0.5], size=(300, 2))
    # decorrelate exactly so the closed form applies: whiten off-diagonals away
    a = a - a.mean(0)
    b = b - b.mean(0)
    qa = np.linalg.cholesky(np.cov(a, rowvar=False))
    qb = np.linalg.cholesky(np.cov(b, rowvar=False))
    a = a @ np.linalg.inv(qa).T * np.array([1.0, 2.0]) + np.array([0.0, 1.0])
    b = b @ np.linalg.inv(qb).T * np.array([3.0, 0.5]) + np.array([1.0, -1.0])
    expected = (0 - 1) ** 2 + (1 + 1) ** 2 + (1 - 3) ** 2 + (2 - 0.5) ** 2
    assert frechet_distance(a, b) == pytest.approx(expected, rel=1e-9)


def test_fid_identical_sets_zero_and_matches_bailando() -> None:
    rng = np.random.default_rng(1)
    gt = rng.normal(size=(40, 6)).astype(np.float32) * np.array([1, 2, 3, 4, 5, 6], dtype=np.float32)
    pred = (rng.normal(size=(25, 6)) + 0.3).astype(np.float32)
    assert abs(fid(gt, gt)) < 1e-9
    gt_n, pred_n = reference_normalize(gt, pred)
    ours = normalize_by_reference(gt, pred)
    np.testing.assert_array_equal(ours[0], gt_n)
    np.testing.assert_array_equal(ours[1], pred_n)
    assert fid(pred, gt) == pytest.approx(
        float(np.real(reference_calc_fid(pred_n, gt_n))), rel=1e-12, abs=1e-12
    )
    assert fid(pred, gt, variant="mint") == pytest.approx(float(reference_mint_fid(gt, pred)), rel=1e-12)
    assert fid(pred, gt, variant="mint") == pytest.approx(fid(pred, gt), rel=1e-8)


def test_fid_complex_square_root_handling(caplog: pytest.LogCaptureFixture) -> None:
    # Σ1Σ2 = diag(1, -4) → sqrtm = diag(1, 2i): Bailando keeps the real part (tr C = 1), mint raises.
    mu = np.zeros(2)
    s1, s2 = np.diag([1.0, -4.0]), np.eye(2)
    with caplog.at_level(logging.WARNING):
        value = frechet_distance_from_stats(mu, s1, mu, s2)
    assert value == pytest.approx(0 + (1 - 4) + 2 - 2 * 1)
    assert "imaginary" in caplog.text
    with pytest.raises(ValueError, match="[Ii]maginary"):
        frechet_distance_from_stats(mu, s1, mu, s2, variant="mint")


def test_fid_singular_product_uses_eps_fallback() -> None:
    nilpotent = np.array([[0.0, 1.0], [0.0, 0.0]])  # sqrtm does not exist → inf entries
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        assert not np.isfinite(matrix_sqrt(nilpotent)).all()
    eps = 1e-5
    value = frechet_distance_from_stats(np.zeros(2), nilpotent, np.zeros(2), np.eye(2))
    c = matrix_sqrt((nilpotent + eps * np.eye(2)) @ ((1 + eps) * np.eye(2)))
    assert value == pytest.approx(0 + 0 + 2 - 2 * float(np.trace(c).real))


def test_fid_bad_input() -> None:
    good = np.random.default_rng(0).normal(size=(5, 3))
    with pytest.raises(ValueError, match="at least 2 samples"):
        fid(good[:1], good)
    with pytest.raises(ValueError, match="dims differ"):
        fid(good, good[:, :2])
    bad = good.copy()
    bad[2, 1] = np.nan
    with pytest.raises(ValueError, match="non-finite"):
        fid(bad, good)
    with pytest.raises(ValueError, match="2-D"):
        fid(good[0], good)


def test_fid_constant_reference_dimension(caplog: pytest.LogCaptureFixture) -> None:
    rng = np.random.default_rng(2)
    gt = rng.normal(size=(20, 3)).astype(np.float32)
    gt[:, 1] = 0.5
    pred = rng.normal(size=(20, 3)).astype(np.float32)
    with caplog.at_level(logging.WARNING):
        value = fid(pred, gt)
    assert value > 1e12  # the references' documented blow-up (÷1e-10)
    assert "zero variance in dims [1]" in caplog.text
    with pytest.raises(ValueError, match=r"zero variance in dims \[1\]"):
        fid(pred, gt, constant="raise")


# ----------------------------------------------------------------------------- diversity
def test_average_pairwise_distance_hand_computed() -> None:
    pts = np.array([[0.0, 0.0], [3.0, 4.0], [0.0, 4.0]])  # distances 5, 3, 4
    assert average_pairwise_distance(pts) == pytest.approx(4.0)
    assert diversity(pts, normalize=False) == pytest.approx(4.0)


def test_diversity_equals_reference_loop() -> None:
    rng = np.random.default_rng(3)
    feats = rng.normal(size=(60, 72)).astype(np.float32)
    # float32 running sum in the loop's order; per-pair norms may differ from np.linalg.norm by an ulp
    assert average_pairwise_distance(feats) == pytest.approx(
        float(reference_avg_distance(list(feats))), rel=1e-6
    )
    assert average_pairwise_distance(feats, accumulate="float64") == pytest.approx(
        float(reference_avg_distance(list(feats.astype(np.float64)))), rel=1e-12
    )
    gt = rng.normal(size=(30, 72)).astype(np.float32) * 3
    _, pred_n = reference_normalize(gt, feats)
    assert diversity(feats, gt) == pytest.approx(float(reference_avg_distance(list(pred_n))), rel=1e-6)


def test_diversity_and_multimodality_errors() -> None:
    with pytest.raises(ValueError, match="at least 2"):
        average_pairwise_distance(np.zeros((1, 4)))
    with pytest.raises(ValueError, match="reference"):
        diversity(np.zeros((3, 4)))
    with pytest.raises(ValueError, match="K ≥ 2"):
        multimodality([np.zeros((1, 4))], normalize=False)


def test_multimodality_hand_computed() -> None:
    group_a = np.array([[0.0, 0.0], [3.0, 4.0], [0.0, 4.0]])  # mean distance 4
    group_b = np.array([[1.0, 1.0], [1.0, 3.0]])  # distance 2
    assert multimodality([group_a, group_b], normalize=False) == pytest.approx(3.0)


# ----------------------------------------------------------------------------- clip-level metrics
def clips(seeds: list[int], frames: int = 40, **meta: object) -> list[Clip]:
    return [
        Clip(id=f"c{s}", motion=dance(s, frames), fps=60.0, skeleton="smpl24", meta=dict(meta)) for s in seeds
    ]


def test_prepare_motion_root_shift_and_truncation() -> None:
    motion = dance(4, 50)
    out = prepare_motion(motion, max_frames=30)
    assert out.shape == (30, 24, 3)
    np.testing.assert_array_equal(out[0, 0], 0.0)
    np.testing.assert_array_equal(out, motion[:30] - motion[0, 0])
    shifted = Clip(id="s", motion=motion + np.float32(2.0), fps=60.0, skeleton="smpl24")
    base = Clip(id="b", motion=motion, fps=60.0, skeleton="smpl24")
    np.testing.assert_allclose(
        clip_features([shifted], "kinetic")[0], clip_features([base], "kinetic")[0], rtol=1e-4, atol=1e-3
    )
    long = Clip(id="l", motion=np.concatenate([motion] * 30), fps=60.0, skeleton="smpl24")  # 1500 frames
    np.testing.assert_array_equal(
        clip_features([long], "geometric")[0], geometric_features(prepare_motion(long.motion[:1200]))
    )


def test_root_centred_clips_use_their_trajectory() -> None:
    motion = dance(6, 30)
    root = motion[:, :1, :].copy()
    centred = Clip(id="c", motion=motion - root, fps=60.0, skeleton="smpl24", trajectory=root[:, 0, :])
    glob = Clip(id="g", motion=motion, fps=60.0, skeleton="smpl24")
    for kind in ("kinetic", "geometric"):
        np.testing.assert_allclose(
            clip_features([centred], kind), clip_features([glob], kind), rtol=1e-5, atol=1e-5
        )
    bad = Clip(id="b", motion=motion, fps=60.0, skeleton="smpl24", trajectory=np.zeros((29, 3)))
    with pytest.raises(ValueError, match="'b' trajectory"):
        clip_features([bad], "kinetic")


def test_registered_fid_and_div_metrics() -> None:
    gen, ref = clips([1, 2, 3, 4, 5]), clips([6, 7, 8, 9, 10, 11])
    fid_k = METRICS.build("fid_k")
    assert fid_k.needs_reference
    # 6 samples in 72 dims: singular covariances, sqrtm is accurate to ~1e-7 of the trace (≈ 86) only
    assert fid_k(ref, ref)["fid_k"] == pytest.approx(0.0, abs=1e-4)
    gen_k = clip_features(gen, "kinetic")
    ref_k = clip_features(ref, "kinetic")
    assert fid_k(gen, ref)["fid_k"] == pytest.approx(fid(gen_k, ref_k))
    fid_g = METRICS.build("fid_g", {"variant": "mint"})
    gen_g, ref_g = clip_features(gen, "geometric"), clip_features(ref, "geometric")
    assert fid_g(gen, ref)["fid_g"] == pytest.approx(fid(gen_g, ref_g, variant="mint"))
    div = METRICS.build("div_k")(gen, ref)
    assert set(div) == {"div_k", "div_k.reference"}
    assert div["div_k"] == pytest.approx(diversity(gen_k, ref_k))
    assert div["div_k.reference"] == pytest.approx(diversity(ref_k, ref_k))
    raw = METRICS.build("div_g", {"normalize": False})
    assert not raw.needs_reference
    assert raw(gen)["div_g"] == pytest.approx(average_pairwise_distance(gen_g))
    assert fid_k.provenance()["config"]["variant"] == "bailando"


def test_fid_k_and_fid_g_match_the_bailando_pipeline_end_to_end() -> None:
    gen, ref = clips([21, 22, 23, 24, 25], frames=30), clips([31, 32, 33, 34, 35, 36, 37], frames=30)

    def bailando_features(cs: list[Clip], extract: object) -> np.ndarray:
        out = []
        for c in cs:
            joint3d = c.motion.reshape(-1, 72)[:1200, :]
            joint3d = joint3d - np.tile(joint3d[:1, :3], (1, 24))
            out.append(extract(joint3d.reshape(-1, 24, 3)))  # type: ignore[operator]
        return np.stack(out)

    for name, extract in (("fid_k", reference_kinetic), ("fid_g", reference_manual)):
        gt_n, pred_n = reference_normalize(bailando_features(ref, extract), bailando_features(gen, extract))
        expected = float(np.real(reference_calc_fid(pred_n, gt_n)))
        assert METRICS.build(name)(gen, ref)[name] == pytest.approx(expected, rel=1e-9, abs=1e-9)


def test_registered_multimodality() -> None:
    gen = clips([1, 2, 3], condition_id="song_a") + clips([4, 5], condition_id="song_b")
    ref = clips([6, 7, 8, 9])
    value = METRICS.build("multimodality")(gen, ref)
    feats = clip_features(gen, "kinetic")
    ref_k = clip_features(ref, "kinetic")
    assert value["multimodality"] == pytest.approx(multimodality([feats[:3], feats[3:]], ref_k))
    assert value["multimodality.num_conditions"] == 2.0
    with pytest.raises(ValueError, match="condition_id"):
        METRICS.build("multimodality")(clips([1, 2]), ref)
    with pytest.raises(ValueError, match="at least 2 generations"):
        METRICS.build("multimodality")(clips([1], condition_id="x") + clips([2, 3], condition_id="y"), ref)


def test_clip_metric_errors() -> None:
    fid_k = METRICS.build("fid_k")
    with pytest.raises(ValueError, match="reference"):
        fid_k(clips([1, 2]))
    wrong_skeleton = [Clip(id="w", motion=dance(1, 10), fps=60.0, skeleton="humanml22")]
    with pytest.raises(ValueError, match="'w'.*humanml22"):
        fid_k(wrong_skeleton, clips([1, 2]))
    wrong_joints = [Clip(id="j", motion=np.zeros((10, 17, 3), np.float32), fps=60.0)]
    with pytest.raises(ValueError, match=r"'j'.*\(T, 24, 3\)"):
        fid_k(wrong_joints, clips([1, 2]))
    with pytest.raises(ValueError, match="at least 2 generated"):
        fid_k(clips([1]), clips([1, 2]))
    with pytest.raises(ValueError, match="variant"):
        METRICS.build("fid_k", {"variant": "torch"})
