"""Properties of keypoint filling, even frame dropping and normalisation."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from momu.features.preprocess import Normalizer, even_frame_indices, interpolate_missing

values = st.floats(-100, 100, allow_nan=False, width=64)


@st.composite
def keypoints_with_holes(draw: st.DrawFn) -> tuple[np.ndarray, np.ndarray]:
    t, j, d = draw(st.integers(1, 12)), draw(st.integers(1, 4)), draw(st.sampled_from([2, 3]))
    x = draw(arrays(np.float64, (t, j, d), elements=values))
    holes = draw(arrays(np.bool_, (t, j)))
    # At least one observed frame per joint: every missing keypoint has a neighbour to fill from.
    for jj in range(j):
        if holes[:, jj].all():
            holes[draw(st.integers(0, t - 1)), jj] = False
    holed = x.copy()
    holed[holes] = np.nan
    return holed, holes


@settings(deadline=None)
@given(keypoints_with_holes())
def test_interpolation_never_leaves_nan_where_a_neighbour_exists(case: tuple[np.ndarray, np.ndarray]) -> None:
    holed, holes = case
    out = interpolate_missing(holed)
    assert np.all(np.isfinite(out))
    np.testing.assert_array_equal(out[~holes], holed[~holes])  # observed keypoints untouched
    # Filled values stay within the range of the joint's observed values (linear / held).
    for j in range(holed.shape[1]):
        seen = holed[~holes[:, j], j]
        assert np.all(out[:, j] >= seen.min(axis=0) - 1e-9) and np.all(out[:, j] <= seen.max(axis=0) + 1e-9)


@settings(deadline=None)
@given(st.integers(1, 500), st.integers(1, 500))
def test_even_frame_indices_are_evenly_spread(num_frames: int, target: int) -> None:
    idx = even_frame_indices(num_frames, target)
    assert len(idx) == target and idx[0] == 0 and idx[-1] <= num_frames - 1
    steps = np.diff(idx)
    assert np.all(steps >= 0)
    if target <= num_frames:
        assert np.all(steps >= 1)  # frames are dropped, never repeated
    # Output frame i sits within half an input frame of its time i·T/target (clipped at the end).
    ideal = np.arange(target) * num_frames / target
    assert np.all(np.abs(idx - np.minimum(ideal, num_frames - 1)) <= 0.5 + 1e-9)


@settings(deadline=None)
@given(arrays(np.float64, st.tuples(st.integers(1, 20), st.integers(1, 5)), elements=values))
def test_normalizer_round_trips_and_standardises(data: np.ndarray) -> None:
    norm = Normalizer.fit(data)
    z = norm.transform(data)
    np.testing.assert_allclose(norm.inverse(z), data, atol=1e-7 * (1 + np.abs(data).max()))
    assert np.all(np.abs(z.mean(axis=0)) < 1e-6 * (1 + np.abs(data).max() / norm.std))
