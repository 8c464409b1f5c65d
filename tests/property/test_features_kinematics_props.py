"""Properties of MoMu Eq. 1–2: translation invariance, rotation equivariance (bins roll), Q ∈ [0, 1]."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import assume, given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from momu.features.kinematics import directogram, kinematic_amplitude, motion_kinematic_amplitude

coords = st.floats(-10, 10, allow_nan=False, allow_infinity=False, width=64)


@st.composite
def motions(draw: st.DrawFn, dims: int = 2) -> np.ndarray:
    t = draw(st.integers(2, 8))
    j = draw(st.integers(1, 5))
    return draw(arrays(np.float64, (t, j, dims), elements=coords))


def far_from_bin_edges(motion: np.ndarray, bins: int, tol: float = 1e-6) -> bool:
    """True when no displacement angle lies within ``tol`` rad of a bin edge or window boundary.

    Edges of the hard bins are at multiples of 2π/K and the paper window's boundaries at centre ± 2π/K,
    i.e. odd multiples of π/K; angles there flip bins under float rounding of a rotation.
    """
    f = np.diff(motion, axis=0).reshape(-1, 2)
    f = f[np.linalg.norm(f, axis=-1) > 1e-9]
    if f.size == 0:
        return True
    angle = np.mod(np.arctan2(f[:, 1], f[:, 0]), 2 * math.pi)
    half = math.pi / bins
    rem = np.mod(angle, half)
    return bool(np.all(np.minimum(rem, half - rem) > tol))


@settings(deadline=None)
@given(motions(2), arrays(np.float64, (2,), elements=coords), st.sampled_from(["paper", "hard"]))
def test_directogram_is_translation_invariant(motion: np.ndarray, shift: np.ndarray, window: str) -> None:
    assume(far_from_bin_edges(motion, 8))
    moved = motion + shift
    assume(far_from_bin_edges(moved, 8))
    np.testing.assert_allclose(
        directogram(moved, 8, window=window), directogram(motion, 8, window=window), atol=1e-6
    )


@settings(deadline=None)
@given(motions(3), arrays(np.float64, (3,), elements=coords))
def test_3d_directogram_is_translation_invariant(motion: np.ndarray, shift: np.ndarray) -> None:
    assume(far_from_bin_edges(motion[..., :2], 8) and far_from_bin_edges(motion[..., :2] + shift[:2], 8))
    np.testing.assert_allclose(directogram(motion + shift), directogram(motion), atol=1e-6)


@settings(deadline=None)
@given(
    motions(2),
    st.sampled_from([4, 6, 8, 12]),
    st.integers(0, 11),
    st.sampled_from(["paper", "hard"]),
)
def test_rotating_by_multiples_of_the_bin_width_rolls_the_bins(
    motion: np.ndarray, bins: int, m: int, window: str
) -> None:
    assume(far_from_bin_edges(motion, bins))
    phi = 2 * math.pi * m / bins
    rot = np.array([[math.cos(phi), -math.sin(phi)], [math.sin(phi), math.cos(phi)]])
    rotated = motion @ rot.T
    assume(far_from_bin_edges(rotated, bins))
    expected = np.roll(directogram(motion, bins, window=window), m, axis=1)
    np.testing.assert_allclose(directogram(rotated, bins, window=window), expected, atol=1e-6)


@settings(deadline=None)
@given(motions(2), st.sampled_from(["paper", "hard"]))
def test_hard_bins_preserve_total_motion(motion: np.ndarray, window: str) -> None:
    d = directogram(motion, 8, window=window)
    total = np.linalg.norm(np.diff(motion, axis=0), axis=-1).sum(-1)
    assert np.all(d >= 0)
    if window == "hard":
        np.testing.assert_allclose(d.sum(-1), total, atol=1e-9)
    else:  # every displacement lands in 2 or 3 bins of the paper's two-bin-wide window
        assert np.all(d.sum(-1) >= 2 * total - 1e-9) and np.all(d.sum(-1) <= 3 * total + 1e-9)


@settings(deadline=None)
@given(st.one_of(motions(2), motions(3)), st.integers(1, 16))
def test_kinematic_amplitude_is_in_unit_interval(motion: np.ndarray, bins: int) -> None:
    q = motion_kinematic_amplitude(motion, bins)
    assert q.shape == (motion.shape[0] - 1,)
    assert np.all(q >= 0) and np.all(q <= 1)
    assert q[0] == 0
    assert q.max() == 1.0 or np.all(q == 0)


@settings(deadline=None)
@given(arrays(np.float64, st.tuples(st.integers(1, 6), st.integers(1, 8)), elements=st.floats(0, 100)))
def test_kinematic_amplitude_of_any_directogram_is_in_unit_interval(d: np.ndarray) -> None:
    q = kinematic_amplitude(d)
    assert np.all((q >= 0) & (q <= 1))
    # Scaling the directogram does not change the normalised amplitude.
    np.testing.assert_allclose(kinematic_amplitude(3.0 * d), q, atol=1e-12)
