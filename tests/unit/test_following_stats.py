"""Intervals over songs × seeds and the verdict rules of the music-following benchmark."""

from __future__ import annotations

import numpy as np
import pytest

from momu.following.stats import (
    CANNOT_TELL,
    FAILS,
    NO_VERDICT_GT,
    PASSES,
    Estimate,
    gate,
    song_seed_bootstrap,
    verdict,
)


def test_bootstrap_mean_and_interval() -> None:
    rng = np.random.default_rng(0)
    values = 1.0 + rng.standard_normal((40, 3))
    est = song_seed_bootstrap(values)
    assert est.estimate == pytest.approx(values.mean())
    assert est.low < 1.0 < est.high
    assert est.high - est.low < 0.8
    assert (est.songs, est.seeds) == (40, 3)


def test_bootstrap_ignores_missing_values_and_needs_two_songs() -> None:
    v = np.array([[1.0, np.nan], [3.0, 3.0], [np.nan, np.nan]])
    est = song_seed_bootstrap(v)
    assert est.estimate == pytest.approx(2.0) and est.songs == 2
    one = song_seed_bootstrap(np.array([[1.0, 2.0]]))
    assert np.isnan(one.low) and verdict(one, "above") == CANNOT_TELL


def test_bootstrap_of_identical_seeds_is_the_song_bootstrap() -> None:
    songs = np.arange(10.0)
    a = song_seed_bootstrap(np.repeat(songs[:, None], 3, axis=1))
    b = song_seed_bootstrap(songs[:, None])
    assert (a.low, a.high) == pytest.approx((b.low, b.high), abs=1e-9)


def _e(low: float, high: float) -> Estimate:
    return Estimate(0.5 * (low + high), low, high, 10, 3)


def test_verdict_rules() -> None:
    assert verdict(_e(0.1, 0.3), "above") == PASSES
    assert verdict(_e(-0.3, -0.1), "above") == FAILS
    assert verdict(_e(-0.1, 0.1), "above") == CANNOT_TELL
    assert verdict(_e(0.4, 0.6), "not_below", 0.5) == PASSES
    assert verdict(_e(0.1, 0.3), "not_below", 0.5) == FAILS
    gt = (0.9, 1.05)
    assert verdict(_e(0.5, 1.1), "slope", 0.0, gt) == PASSES
    assert verdict(_e(0.5, 0.92), "slope", 0.0, gt) == PASSES  # overlaps ground truth's interval
    assert verdict(_e(0.5, 0.8), "slope", 0.0, gt) == FAILS  # disjoint from ground truth's interval
    assert verdict(_e(-0.2, 1.1), "slope", 0.0, gt) == CANNOT_TELL
    assert verdict(_e(-0.2, 0.1), "slope", 0.0, gt) == FAILS
    assert verdict(_e(-0.2, -0.1), "slope", 0.0, gt) == FAILS
    assert verdict(Estimate(0.2, 0.1, 0.3, 5, 3), "within", 0.1, 0.5) == PASSES
    assert verdict(Estimate(0.05, 0.0, 0.1, 5, 3), "within", 0.1, 0.5) == FAILS


def test_gate_withholds_uncalibrated_tests() -> None:
    assert gate(PASSES, FAILS, []) == NO_VERDICT_GT
    assert gate(FAILS, CANNOT_TELL, []) == NO_VERDICT_GT
    assert gate(PASSES, PASSES, ["shuffled"]) == "no verdict: shuffled passes too"
    assert gate(FAILS, PASSES, []) == FAILS
