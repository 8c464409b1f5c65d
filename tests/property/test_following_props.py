"""Hypothesis properties of the music-following benchmark's math: octave folding, tempo matching,
BAS in seconds, the song × seed bootstrap, time scaling."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from momu.following.beat_align import bas_seconds, half_beat_shift
from momu.following.signals import time_scale_motion
from momu.following.stats import song_seed_bootstrap
from momu.following.tempo import OCTAVE_RATIOS, fold_ratio, tempo_matches

ratios = st.floats(0.05, 20.0, allow_nan=False)
tempi = st.floats(20.0, 300.0, allow_nan=False)
beat_times = st.lists(st.floats(0.0, 30.0, allow_nan=False), min_size=1, max_size=30)


@given(ratios, st.integers(-3, 3))
def test_fold_is_invariant_to_octaves_and_lands_near_one(r: float, k: int) -> None:
    folded = fold_ratio(r)
    assert 2**-0.5 - 1e-9 <= folded < 2**0.5 + 1e-9
    assert np.isclose(fold_ratio(r * 2.0**k), folded)


@given(st.floats(2**-0.5 + 1e-6, 2**0.5 - 1e-6))
def test_fold_keeps_every_ratio_it_could_be_asked_about(r: float) -> None:
    assert np.isclose(fold_ratio(r), r)


@given(tempi, st.sampled_from(OCTAVE_RATIOS), st.floats(-0.04, 0.04))
def test_tempo_matches_up_to_the_octave_ratios(a: float, ratio: float, err: float) -> None:
    assert tempo_matches(a * ratio * (1 + err), a)


@given(beat_times, beat_times, st.floats(1.0, 40.0), st.sampled_from(["bailando", "mint"]))
@settings(deadline=None)
def test_bas_seconds_in_unit_interval_and_one_on_itself(
    music: list[float], dance: list[float], dur: float, variant: str
) -> None:
    s = bas_seconds(np.array(music), np.array(dance), dur, variant)  # type: ignore[arg-type]
    assert 0.0 <= s <= 1.0
    inside = np.array([t for t in music if t < dur])
    if inside.size:
        assert bas_seconds(inside, inside, dur, variant) == 1.0  # type: ignore[arg-type]


@given(st.floats(0.3, 1.5), st.integers(4, 30))
def test_half_beat_shift_of_a_grid_falls_midway(period: float, n: int) -> None:
    grid = np.arange(n) * period
    moved = half_beat_shift(grid)
    assert np.allclose(moved - grid, period / 2)


@given(st.lists(st.lists(st.floats(-5, 5, allow_nan=False), min_size=3, max_size=3), min_size=2, max_size=12))
@settings(deadline=None, max_examples=30)
def test_bootstrap_interval_holds_the_estimate_within_the_data_range(rows: list[list[float]]) -> None:
    v = np.array(rows)
    est = song_seed_bootstrap(v, samples=200)
    assert v.min() - 1e-9 <= est.low <= est.estimate <= est.high <= v.max() + 1e-9
    assert np.isclose(est.estimate, v.mean())


@given(st.floats(0.8, 1.25), st.integers(20, 200))
@settings(deadline=None, max_examples=30)
def test_time_scaling_keeps_the_first_pose_and_scales_the_length(factor: float, frames: int) -> None:
    rng = np.random.default_rng(frames)
    motion = np.cumsum(rng.standard_normal((frames, 2, 3)), axis=0)
    scaled = time_scale_motion(motion, 25.0, factor)
    assert np.allclose(scaled[0], motion[0])
    assert abs(len(scaled) - (frames - 1) / factor - 1) <= 1
    assert np.allclose(time_scale_motion(motion, 25.0, 1.0), motion)
