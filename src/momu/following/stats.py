"""Intervals over songs × seeds and the verdict rules of the music-following benchmark.

**Interval.** Every test yields one value per (song, seed) — a matrix ``(songs, seeds)``. Its statistic
is the mean; its 95 % interval is a two-level percentile bootstrap (:func:`song_seed_bootstrap`): a
replicate draws the songs with replacement and, within each drawn song, its seeds with replacement, and
takes the mean. Resampling songs carries the song-to-song spread (the claim is about songs, not about
the ones drawn); resampling seeds within songs adds the generator's own randomness. A generator that
ignores the seed (a calibration row) has identical seeds and the interval is the songs' bootstrap.
Missing values (NaN: e.g. no tempo in a silent output) are left out of the means. 2000 replicates from
a fixed generator: reproducible. With fewer than 2 songs there is no interval (the verdict is "cannot
tell").

**Verdicts** (:func:`verdict`), for a test with a threshold ``t``:

* ``above`` — ``passes`` when the whole interval lies above ``t``, ``fails`` when it lies at or below it,
  ``cannot tell`` otherwise;
* ``not_below`` (input sensitivity: "not distinguishable from, or above") — ``fails`` only when the
  whole interval lies below ``t``, else ``passes``;
* ``slope`` (tempo following) — ``passes`` when the interval excludes 0 (above it) *and* is consistent
  with the slope of an exact follower on the same data (the intervals overlap: its value is an estimate
  too; the reference interval is ground truth's, for a generator widened to the ``input_tempo``
  calibration row's); ``fails`` when it lies at or below 0 or is disjoint from the reference interval;
* ``within`` (realism) — ``passes`` when the estimate lies inside the real data's 5th-95th percentile.

:func:`gate` then withholds a generator's verdict on a test that ground truth does not pass on the same
data ("no verdict: ground truth does not pass here"), or that a calibration row built to fail passes
("no verdict: <row> passes too").
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from typing import Any

import numpy as np

__all__ = [
    "CONFIDENCE",
    "BOOTSTRAP_SAMPLES",
    "Estimate",
    "song_seed_bootstrap",
    "verdict",
    "gate",
    "PASSES",
    "FAILS",
    "CANNOT_TELL",
]

CONFIDENCE = 0.95
BOOTSTRAP_SAMPLES = 2000
PASSES, FAILS, CANNOT_TELL = "passes", "fails", "cannot tell"
NO_VERDICT_GT = "no verdict: ground truth does not pass here"


@dataclass(frozen=True)
class Estimate:
    """Mean over songs × seeds with its 95 % interval; ``songs`` / ``seeds`` count the finite values' axes."""

    estimate: float
    low: float
    high: float
    songs: int
    seeds: int

    def as_dict(self) -> dict[str, float | int]:
        return {
            "estimate": self.estimate,
            "low": self.low,
            "high": self.high,
            "songs": self.songs,
            "seeds": self.seeds,
        }


def song_seed_bootstrap(
    values: np.ndarray, *, samples: int = BOOTSTRAP_SAMPLES, seed: int = 0, confidence: float = CONFIDENCE
) -> Estimate:
    """Mean of ``values`` ``(songs, seeds)`` and its two-level bootstrap interval (module docstring)."""
    v = np.asarray(values, dtype=np.float64)
    if v.ndim == 1:
        v = v[:, None]
    if v.ndim != 2:
        raise ValueError(f"values: expected (songs, seeds), got shape {v.shape}")
    rows = np.flatnonzero(np.isfinite(v).any(axis=1))
    v = v[rows]
    if v.size == 0:
        return Estimate(float("nan"), float("nan"), float("nan"), 0, 0)
    seeds = int(v.shape[1])
    estimate = float(np.nanmean(np.nanmean(v, axis=1)))
    n = v.shape[0]
    if n < 2:
        return Estimate(estimate, float("nan"), float("nan"), n, seeds)
    rng = np.random.default_rng(seed)
    songs = rng.integers(0, n, size=(samples, n))  # (R, N)
    within = rng.integers(0, seeds, size=(samples, n, seeds))  # (R, N, S)
    drawn = v[songs[..., None], within]  # (R, N, S)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # a replicate may draw only NaN seeds of a song
        reps = np.nanmean(np.nanmean(drawn, axis=2), axis=1)
    reps = reps[np.isfinite(reps)]
    tail = 100.0 * (1.0 - confidence) / 2.0
    low, high = np.percentile(reps, [tail, 100.0 - tail])
    return Estimate(estimate, float(min(low, estimate)), float(max(high, estimate)), n, seeds)


def verdict(est: Estimate, rule: str, threshold: float = 0.0, reference: Any = None) -> str:
    """The verdict of ``est`` under ``rule`` (``above``, ``not_below``, ``slope``, ``within``).

    ``reference``: for ``slope`` the reference interval ``(low, high)`` (ground truth's, or its hull
    with ``input_tempo``'s); for ``within`` the upper bound (``threshold`` is the lower one).
    """
    if not np.isfinite(est.estimate):
        return CANNOT_TELL  # nothing measured (e.g. input sensitivity with one seed)
    if rule == "within":
        assert reference is not None
        return PASSES if threshold <= est.estimate <= reference else FAILS
    if not (np.isfinite(est.low) and np.isfinite(est.high)):
        return CANNOT_TELL
    if rule == "above":
        return PASSES if est.low > threshold else FAILS if est.high <= threshold else CANNOT_TELL
    if rule == "not_below":
        return FAILS if est.high < threshold else PASSES
    if rule == "slope":
        if est.high <= 0.0:
            return FAILS
        if reference is not None:
            ref_low, ref_high = reference
            if np.isfinite(ref_low) and np.isfinite(ref_high) and (est.high < ref_low or est.low > ref_high):
                return FAILS
        return PASSES if est.low > 0.0 else CANNOT_TELL
    raise ValueError(f"rule: expected above, not_below, slope or within, got {rule!r}")


def gate(own: str, ground_truth: str | None, must_fail_passes: list[str]) -> str:
    """A generator's verdict, withheld where the test is not calibrated on this data (module docstring)."""
    if ground_truth is not None and ground_truth != PASSES:
        return NO_VERDICT_GT
    if must_fail_passes:
        return f"no verdict: {', '.join(must_fail_passes)} passes too"
    return own
