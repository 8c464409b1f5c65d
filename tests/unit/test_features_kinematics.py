"""Directogram and kinematic amplitude (MoMu Eq. 1–2), velocity sum and visual beats (HarmoGAN Eq. 2–3)."""

from __future__ import annotations

import math

import numpy as np
import pytest
import torch

from momu.features.kinematics import (
    directogram,
    directogram_torch,
    kinematic_amplitude,
    kinematic_amplitude_torch,
    motion_kinematic_amplitude,
    velocity_sum,
    visual_beats,
)


def walk(displacements: list[tuple[float, float]], joints: int = 1) -> np.ndarray:
    """(T, joints, 2) motion whose every joint moves by the given per-frame displacements."""
    steps = np.asarray([(0.0, 0.0), *displacements])
    path = np.cumsum(steps, axis=0)
    return np.repeat(path[:, None, :], joints, axis=1)


def at_angle(deg: float, r: float = 1.0) -> tuple[float, float]:
    return (r * math.cos(math.radians(deg)), r * math.sin(math.radians(deg)))


def test_directogram_hard_bins_by_angle() -> None:
    # K = 8 bins of 45°: bin k covers [45k°, 45(k+1)°).
    motion = walk([at_angle(10), at_angle(100, 2.0), at_angle(350, 3.0)])
    d = directogram(motion, 8, window="hard")
    expected = np.zeros((3, 8))
    expected[0, 0] = 1.0
    expected[1, 2] = 2.0
    expected[2, 7] = 3.0
    np.testing.assert_allclose(d, expected, atol=1e-12)


def test_directogram_paper_window_covers_two_bins() -> None:
    # Eq. 1: 1 if |θ_k − φ| <= 2π/K. Centres at 22.5° + 45°k: 10° is within 45° of 22.5° and 337.5°.
    d = directogram(walk([at_angle(10), at_angle(100, 2.0)]), 8)
    np.testing.assert_allclose(d[0], [1, 0, 0, 0, 0, 0, 0, 1], atol=1e-12)
    np.testing.assert_allclose(d[1], [0, 2, 2, 0, 0, 0, 0, 0], atol=1e-12)


def test_directogram_sums_magnitudes_over_joints() -> None:
    motion = walk([(3.0, 4.0)], joints=3)  # |F| = 5 per joint, angle 53.1° -> hard bin 1
    d = directogram(motion, 8, window="hard")
    assert d[0, 1] == pytest.approx(15.0)
    assert d.sum() == pytest.approx(15.0)


def test_directogram_3d_projects_on_the_chosen_plane() -> None:
    motion = np.zeros((3, 2, 3))
    motion[:, :, 2] = np.arange(3)[:, None]  # moves along z only
    assert np.all(directogram(motion) == 0)  # default plane x–y sees nothing
    side = directogram(motion, 4, plane=(0, 2), window="hard")
    np.testing.assert_allclose(side[:, 1], [2.0, 2.0])  # +z is 90° in the (x, z) plane: bin 1 of 4
    with pytest.raises(ValueError, match="plane"):
        directogram(motion, plane=(1, 1))


def test_kinematic_amplitude_hand_computed() -> None:
    d = np.zeros((4, 3))
    d[0] = [1, 0, 0]
    d[1] = [3, 1, 0]  # increase 2 + 1 = 3
    d[2] = [2, 1, 5]  # increase 5
    d[3] = [0, 0, 0]  # decrease only: 0
    np.testing.assert_allclose(kinematic_amplitude(d, normalize=False), [0, 3, 5, 0])
    np.testing.assert_allclose(kinematic_amplitude(d), [0, 0.6, 1.0, 0])
    assert np.all(kinematic_amplitude(np.ones((5, 8))) == 0)  # constant motion never speeds up


def test_kinematic_amplitude_peaks_where_motion_starts() -> None:
    # Rest, then a sudden move to the right: Q is 1 at the onset and 0 elsewhere.
    motion = walk([(0, 0), (0, 0), (1, 0), (1, 0), (0, 0)], joints=2)
    q = motion_kinematic_amplitude(motion)
    assert q.shape == (5,)
    np.testing.assert_allclose(q, [0, 0, 1, 0, 0])


def test_torch_versions_match_numpy_and_have_gradients() -> None:
    rng = np.random.default_rng(0)
    motion = rng.standard_normal((2, 12, 5, 3))
    x = torch.tensor(motion, requires_grad=True)
    for window in ("paper", "hard"):
        d = directogram_torch(x, 8, window=window)
        for b in range(2):
            np.testing.assert_allclose(
                d[b].detach().numpy(), directogram(motion[b], 8, window=window), atol=1e-5
            )
    q = kinematic_amplitude_torch(x)
    assert q.shape == (2, 11)
    for b in range(2):
        np.testing.assert_allclose(q[b].detach().numpy(), motion_kinematic_amplitude(motion[b]), atol=1e-5)
    q.sum().backward()
    assert x.grad is not None and torch.isfinite(x.grad).all() and x.grad.abs().sum() > 0
    assert directogram_torch(torch.tensor(motion[0]), 4).shape == (11, 4)


def test_velocity_sum_is_harmogan_eq2_in_units_per_second() -> None:
    motion = np.zeros((3, 2, 3))
    motion[1, 0] = [3, 4, 0]  # joint 0 moves 5, joint 1 stays
    motion[2, 0] = [3, 4, 0]
    motion[2, 1] = [0, 0, 2]  # joint 1 moves 2
    np.testing.assert_allclose(velocity_sum(motion, fps=25), [5 * 25, 2 * 25])


def test_visual_beats_are_local_extrema_of_the_velocity_sum() -> None:
    speeds = [1, 2, 3, 2, 1, 2, 3, 3, 1]  # j[i] for frame i + 1
    motion = walk([(s, 0.0) for s in speeds])
    frames, saliency = visual_beats(motion, fps=10)
    # j maximum at index 2 (frame 3), minimum at index 4 (frame 5); the plateau 3, 3 is no beat.
    np.testing.assert_array_equal(frames, [3, 5])
    np.testing.assert_allclose(saliency, [30.0, 10.0])
    np.testing.assert_array_equal(visual_beats(motion, 10, kind="max")[0], [3])
    np.testing.assert_array_equal(visual_beats(motion, 10, kind="min")[0], [5])
    frames_s, _ = visual_beats(motion, 10, smooth_sigma=1.0)
    assert frames_s.dtype == np.int64


def test_visual_beats_on_a_periodic_motion_fall_on_its_rhythm() -> None:
    fps, bpm = 30.0, 120.0
    t = np.arange(int(4 * fps)) / fps
    # A joint swinging with the beat: one swing per beat (period 2 beats = 1 s), speed smallest at the
    # turning points, i.e. on the beats at t = 0.25 + 0.5 k s. (A phase of 1/3 frame keeps the samples
    # asymmetric around the extrema: exactly symmetric samples give two equal j values, a plateau that
    # Eq. 3's strict inequalities do not count.)
    x = np.sin(2 * np.pi * (bpm / 60 / 2) * (t + 1 / (3 * fps)))
    motion = np.stack([x, np.zeros_like(x)], axis=-1)[:, None, :]
    frames, _ = visual_beats(motion, fps, kind="min")
    np.testing.assert_allclose(frames / fps, 0.25 + 0.5 * np.arange(8) - 1 / (3 * fps), atol=1.5 / fps)
    peaks, _ = visual_beats(motion, fps, kind="max")  # fastest between beats, at t = 0.5 k s
    np.testing.assert_allclose(peaks / fps, 0.5 * np.arange(1, 8) - 1 / (3 * fps), atol=1.5 / fps)


def test_bad_motion_is_rejected_with_a_clear_message() -> None:
    with pytest.raises(ValueError, match="shape"):
        directogram(np.zeros((5, 3)))
    with pytest.raises(ValueError, match="at least 2 frames"):
        directogram(np.zeros((1, 3, 2)))
    bad = np.zeros((5, 3, 2))
    bad[2, 1, 0] = np.nan
    with pytest.raises(ValueError, match="frame 2, joint 1"):
        velocity_sum(bad, 30)
    with pytest.raises(ValueError, match="fps"):
        velocity_sum(np.zeros((5, 3, 2)), 0)
    with pytest.raises(ValueError, match="window"):
        directogram(np.zeros((5, 3, 2)), window="soft")
    with pytest.raises(ValueError, match="D in"):
        directogram(np.zeros((5, 3, 4)))
