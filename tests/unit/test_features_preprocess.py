"""Keypoint subsets, filling missing keypoints (MoMu App. B.2), frame dropping (MoMu §3.2), Normalizer."""

from __future__ import annotations

import json
import zipfile
from pathlib import Path

import numpy as np
import pytest
import torch

from momu.features.preprocess import (
    BODY25_JOINT_NAMES,
    MissingKeypointsError,
    Normalizer,
    confidence_mask,
    drop_frames_evenly,
    even_frame_indices,
    interpolate_missing,
    joint_indices,
    openpose14_from_body25,
    openpose14_from_coco17,
    select_joints,
)
from momu.features.skeletons import get_skeleton


# ------------------------------------------------------------------------------------ subsets
def test_openpose14_from_body25_keeps_the_momu_keypoints_in_skeleton_order() -> None:
    body25 = np.arange(25, dtype=np.float64)[None, :, None].repeat(2, axis=-1)  # value = BODY-25 index
    out = openpose14_from_body25(body25)
    names = get_skeleton("openpose14").joint_names
    assert out.shape == (1, 14, 2)
    assert [BODY25_JOINT_NAMES[int(v)] for v in out[0, :, 0]] == list(names)
    assert 8 not in out[0, :, 0]  # mid-hip is dropped


def test_openpose14_from_coco17_builds_the_neck_from_the_shoulders() -> None:
    coco = get_skeleton("coco17").joint_names
    kp = np.zeros((2, 17, 3))
    kp[:, coco.index("l_shoulder")] = [2.0, 0.0, 1.0]
    kp[:, coco.index("r_shoulder")] = [0.0, 2.0, 1.0]
    kp[:, coco.index("r_knee")] = [7.0, 7.0, 7.0]
    out = openpose14_from_coco17(kp)
    op = get_skeleton("openpose14").joint_names
    np.testing.assert_allclose(out[:, op.index("neck")], [[1.0, 1.0, 1.0]] * 2)
    np.testing.assert_allclose(out[:, op.index("r_knee")], [[7.0, 7.0, 7.0]] * 2)
    assert isinstance(openpose14_from_coco17(torch.tensor(kp)), torch.Tensor)


def test_joint_subsets_name_missing_joints() -> None:
    assert joint_indices(["a", "b", "c"], ["c", "a"]) == [2, 0]
    with pytest.raises(ValueError, match="'z'"):
        joint_indices(["a", "b"], ["a", "z"])
    m = np.arange(12.0).reshape(1, 6, 2)
    np.testing.assert_array_equal(select_joints(m, [5, 0]), m[:, [5, 0]])
    with pytest.raises(ValueError, match="out of range"):
        select_joints(m, [6])
    with pytest.raises(ValueError, match="BODY-25"):
        openpose14_from_body25(np.zeros((1, 18, 2)))


# ------------------------------------------------------------------------------------ interpolation
def test_interpolation_is_linear_between_neighbours_and_holds_at_the_ends() -> None:
    x = np.zeros((6, 2, 2))
    x[:, 0, 0] = [np.nan, 1.0, np.nan, np.nan, 4.0, np.nan]
    x[:, 0, 1] = [np.nan, 10.0, np.nan, np.nan, 40.0, np.nan]
    out = interpolate_missing(x)
    np.testing.assert_allclose(out[:, 0, 0], [1, 1, 2, 3, 4, 4])
    np.testing.assert_allclose(out[:, 0, 1], [10, 10, 20, 30, 40, 40])
    np.testing.assert_array_equal(out[:, 1], x[:, 1])  # untouched joint
    assert np.isnan(x[0, 0, 0])  # input not modified


def test_interpolation_uses_the_mask_and_confidence() -> None:
    raw = np.zeros((3, 1, 3))
    raw[:, 0, :2] = [[0, 0], [99, 99], [2, 2]]
    raw[:, 0, 2] = [0.9, 0.0, 0.8]  # OpenPose writes confidence 0 for a missed keypoint
    pos, valid = confidence_mask(raw)
    np.testing.assert_array_equal(valid[:, 0], [True, False, True])
    np.testing.assert_allclose(interpolate_missing(pos, valid)[1, 0], [1, 1])
    with pytest.raises(ValueError, match="mask"):
        interpolate_missing(pos, np.ones((2, 1), bool))


def test_interpolation_errors_name_the_joint_and_frames() -> None:
    x = np.zeros((10, 3, 2))
    x[:, 2] = np.nan
    with pytest.raises(MissingKeypointsError, match=r"joint 2 \(c\) is missing in all 10 frames"):
        interpolate_missing(x, joint_names=["a", "b", "c"])
    y = np.zeros((10, 3, 2))
    y[2:7, 1] = np.nan  # a 5-frame gap
    np.testing.assert_allclose(interpolate_missing(y, max_gap=5), 0.0)
    with pytest.raises(
        MissingKeypointsError, match=r"joint 1 is missing for 5 consecutive frames \(2\.\.6\)"
    ) as e:
        interpolate_missing(y, max_gap=4)
    assert e.value.joint == 1 and e.value.frames == (2, 6)
    left = interpolate_missing(y, max_gap=4, on_long_gap="leave")
    assert np.isnan(left[2:7, 1]).all() and np.isfinite(left[:2]).all() and np.isfinite(left[7:]).all()


# ------------------------------------------------------------------------------------ frame dropping
def test_even_frame_indices_hand_computed() -> None:
    np.testing.assert_array_equal(even_frame_indices(10, 5), [0, 2, 4, 6, 8])
    np.testing.assert_array_equal(even_frame_indices(10, 4), [0, 3, 5, 8])  # 0, 2.5, 5, 7.5 rounded half up
    np.testing.assert_array_equal(even_frame_indices(7, 7), np.arange(7))
    np.testing.assert_array_equal(even_frame_indices(3, 6), [0, 1, 1, 2, 2, 2])  # upsampling repeats
    # 60 fps motion to 31.25 latent frames/s over 10 s: strictly increasing, every index valid.
    idx = even_frame_indices(600, 313)
    assert np.all(np.diff(idx) >= 1) and idx[-1] <= 599 and idx[0] == 0


def test_drop_frames_evenly_numpy_torch_and_axis() -> None:
    m = np.arange(10.0)[:, None, None] * np.ones((1, 2, 2))
    out = drop_frames_evenly(m, 5)
    np.testing.assert_array_equal(out[:, 0, 0], [0, 2, 4, 6, 8])
    t = torch.arange(20.0).reshape(2, 10)
    torch.testing.assert_close(drop_frames_evenly(t, 5, axis=1)[1], torch.tensor([10.0, 12, 14, 16, 18]))
    with pytest.raises(ValueError, match="exceeds"):
        drop_frames_evenly(m, 11)
    with pytest.raises(ValueError, match="positive"):
        drop_frames_evenly(m, 0)


# ------------------------------------------------------------------------------------ normaliser
def test_normalizer_fit_transform_inverse() -> None:
    clips = [np.array([[1.0, 10.0], [3.0, 10.0]]), np.array([[5.0, 10.0]])]
    norm = Normalizer.fit(clips)
    np.testing.assert_allclose(norm.mean, [3.0, 10.0])
    np.testing.assert_allclose(norm.std, [np.sqrt(8 / 3), 1.0])  # constant channel -> std 1
    z = norm.transform(np.array([[3.0, 10.0], [5.0, 12.0]]))
    np.testing.assert_allclose(z, [[0.0, 0.0], [2 / np.sqrt(8 / 3), 2.0]])
    np.testing.assert_allclose(norm.inverse(z), [[3.0, 10.0], [5.0, 12.0]])
    assert norm.transform(np.zeros((4, 2), np.float32)).dtype == np.float32


def test_normalizer_motion_stats_and_torch() -> None:
    rng = np.random.default_rng(0)
    clips = [rng.standard_normal((n, 4, 3)) * 2 + 1 for n in (5, 9)]
    norm = Normalizer.fit(clips, feature_ndim=2)
    assert norm.feature_shape == (4, 3)
    x = torch.tensor(clips[0], dtype=torch.float32)
    z = norm.transform(x)
    assert z.dtype == torch.float32
    np.testing.assert_allclose(z.numpy(), norm.transform(clips[0]), atol=1e-5)
    torch.testing.assert_close(norm.inverse(z), x, atol=1e-5, rtol=1e-5)
    with pytest.raises(ValueError, match="feature shape"):
        norm.transform(np.zeros((2, 3, 3)))


@pytest.mark.parametrize("suffix", [".json", ".npz"])
def test_normalizer_save_load_round_trip_without_pickle(tmp_path: Path, suffix: str) -> None:
    norm = Normalizer.fit(np.random.default_rng(1).standard_normal((50, 3, 2)), feature_ndim=2)
    path = norm.save(tmp_path / f"stats{suffix}")
    assert Normalizer.load(path) == norm
    if suffix == ".json":
        assert json.loads(path.read_text())["kind"] == "momu.Normalizer"
    else:
        with zipfile.ZipFile(path) as z:  # plain .npy members, loadable with allow_pickle=False
            assert sorted(z.namelist()) == ["eps.npy", "mean.npy", "std.npy"]
    assert [p.name for p in tmp_path.iterdir()] == [f"stats{suffix}"]  # no temporary left behind


def test_normalizer_load_errors_name_the_file(tmp_path: Path) -> None:
    with pytest.raises(FileNotFoundError, match="missing.json"):
        Normalizer.load(tmp_path / "missing.json")
    bad = tmp_path / "bad.json"
    bad.write_text('{"mean": [1, 2]}')
    with pytest.raises(ValueError, match="bad.json"):
        Normalizer.load(bad)
    with pytest.raises(ValueError, match="suffix"):
        Normalizer(np.zeros(2), np.ones(2)).save(tmp_path / "stats.pkl")
    with pytest.raises(ValueError, match="NaN"):
        Normalizer.fit([np.array([[np.nan]])])
