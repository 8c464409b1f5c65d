"""Hypothesis properties of the synth_dance building blocks and of skeleton forward kinematics."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from momu.data.synth import STYLE_NAMES, SynthConfig, generate_clip
from momu.data.synth.motion import beat_phase, ease_keys
from momu.features.skeletons import SKELETON_NAMES, forward_kinematics, get_skeleton

finite = st.floats(-3.0, 3.0, allow_nan=False, allow_infinity=False)


def _random_rotations(rng: np.random.Generator, shape: tuple[int, ...]) -> np.ndarray:
    q, r = np.linalg.qr(rng.standard_normal(shape + (3, 3)))
    q = q * np.sign(np.diagonal(r, axis1=-2, axis2=-1))[..., None, :]
    det = np.linalg.det(q)
    q[..., :, 0] *= det[..., None]  # proper rotations (det +1)
    return q


@given(name=st.sampled_from(SKELETON_NAMES), seed=st.integers(0, 2**31 - 1), frames=st.integers(1, 6))
@settings(deadline=None)
def test_fk_bone_lengths_equal_rest_lengths(name: str, seed: int, frames: int) -> None:
    sk = get_skeleton(name)
    rng = np.random.default_rng(seed)
    pos = forward_kinematics(
        sk, _random_rotations(rng, (frames, sk.num_joints)), rng.normal(size=(frames, 3))
    )
    lengths = np.stack([np.linalg.norm(pos[:, c] - pos[:, p], axis=-1) for p, c in sk.bones], axis=1)
    np.testing.assert_allclose(lengths, np.broadcast_to(sk.bone_lengths, lengths.shape), rtol=1e-9)


@given(name=st.sampled_from(SKELETON_NAMES), seed=st.integers(0, 2**31 - 1))
@settings(deadline=None)
def test_fk_is_equivariant_to_a_global_rotation_and_translation(name: str, seed: int) -> None:
    sk = get_skeleton(name)
    rng = np.random.default_rng(seed)
    rots = _random_rotations(rng, (2, sk.num_joints))
    root = rng.normal(size=(2, 3))
    g = _random_rotations(rng, ())
    shift = rng.normal(size=3)
    moved = forward_kinematics(sk, g @ rots, root @ g.T + shift)
    expected = forward_kinematics(sk, rots, root) @ g.T + shift
    np.testing.assert_allclose(moved, expected, atol=1e-9)


@given(
    keys=arrays(np.float64, st.tuples(st.integers(2, 6), st.integers(1, 4)), elements=finite),
    k=st.integers(0, 5),
    attack=st.floats(0.2, 3.0),
    release=st.floats(0.2, 3.0),
)
@settings(deadline=None)
def test_ease_hits_keys_and_stops_on_them(keys: np.ndarray, k: int, attack: float, release: float) -> None:
    k = min(k, keys.shape[0] - 1)
    eps = 1e-9
    at, before, after = ease_keys(keys, np.array([k, k - eps, k + eps]), attack=attack, release=release)
    np.testing.assert_allclose(at, keys[k], atol=1e-12)
    # the speed vanishes at every key: over eps the value moves far less than eps * the key step
    step = np.abs(np.diff(keys, axis=0)).max() + 1e-12
    assert np.all(np.abs(before - at) <= 0.2 * eps * step + 1e-15)
    assert np.all(np.abs(after - at) <= 0.2 * eps * step + 1e-15)
    # between keys the value stays between the two key values (no overshoot)
    mid = ease_keys(keys, np.linspace(0, keys.shape[0] - 1, 50), attack=attack, release=release)
    seg = np.minimum(np.floor(np.linspace(0, keys.shape[0] - 1, 50)).astype(int), keys.shape[0] - 2)
    lo = np.minimum(keys[seg], keys[seg + 1]) - 1e-12
    hi = np.maximum(keys[seg], keys[seg + 1]) + 1e-12
    assert np.all((mid >= lo) & (mid <= hi))


@given(
    gaps=st.lists(st.floats(0.2, 1.5), min_size=2, max_size=8),
    start=st.floats(-1.0, 1.0),
    probe=st.floats(-3.0, 12.0),
)
@settings(deadline=None)
def test_beat_phase_is_integer_on_beats_and_increasing(gaps: list[float], start: float, probe: float) -> None:
    beats = start + np.concatenate([[0.0], np.cumsum(gaps)])
    np.testing.assert_allclose(beat_phase(beats, beats), np.arange(beats.size), atol=1e-9)
    t = np.sort(np.array([probe, probe + 0.01, probe + 0.5]))
    assert np.all(np.diff(beat_phase(t, beats)) > 0)


@given(
    seed=st.integers(0, 1000),
    index=st.integers(0, 50),
    skeleton=st.sampled_from(["smpl24", "dwm21", "openpose14"]),
    fps=st.sampled_from([20.0, 25.0, 30.0]),
)
@settings(deadline=None, max_examples=10)
def test_clips_are_rigid_finite_and_deterministic(seed: int, index: int, skeleton: str, fps: float) -> None:
    cfg = SynthConfig(
        num_clips=index + 1,
        min_seconds=1.0,
        max_seconds=2.0,
        seed=seed,
        skeleton=skeleton,
        fps=fps,
        styles=list(STYLE_NAMES),
    )
    clip = generate_clip(cfg, index)
    again = generate_clip(replace(cfg, num_clips=index + 7), index)
    assert clip.motion is not None and again.motion is not None and clip.audio is not None
    assert np.array_equal(clip.motion, again.motion)
    assert np.isfinite(clip.motion).all() and np.isfinite(clip.audio).all()
    assert abs(len(clip.audio) / clip.sample_rate - clip.num_frames / fps) < 1 / clip.sample_rate
    sk = get_skeleton(skeleton)
    if sk.dims == 3:
        m = clip.motion.astype(np.float64)
        lengths = np.stack([np.linalg.norm(m[:, c] - m[:, p], axis=-1) for p, c in sk.bones], axis=1)
        np.testing.assert_allclose(lengths, np.broadcast_to(sk.bone_lengths, lengths.shape), atol=2e-6)
