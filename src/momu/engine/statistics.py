"""Intervals, paired comparisons and verdicts behind every reproduced table (DESIGN.md "Statistics").

A committed table is a claim and carries its uncertainty:

* **Cells** are the mean over training seeds ± the half-width of a 95 % Student-t interval over
  seeds (:func:`t_interval`; no interval with one seed).
* **Comparisons** that a verdict rests on — a row against the shuffled calibration, against ground
  truth, against the same model given another clip's condition, or against another row — are
  *paired per clip* and pooled over seeds: a clip-level (cluster) bootstrap of the difference of
  the cell statistic (:func:`paired_bootstrap`). A bootstrap replicate draws ``N`` clip indices with
  replacement, shared by every seed and by both sides of the comparison (the same clips, the same
  pairing), recomputes each side's cell statistic per seed from the drawn clips' per-clip
  *components* (:data:`REDUCERS`: a plain mean, or LORIS's F1 of the mean BCS and mean BHS), and
  averages the per-seed differences over seeds. The point estimate is the difference of the cells
  the table prints; the interval is the percentile interval of 2000 replicates drawn from a
  generator seeded by the caller, so it is reproducible.
* **Seed-level comparisons** are used for distributional metrics that have no per-clip value
  (FID, FAD, Diversity): the per-seed differences get a t-interval over seeds
  (:func:`paired_seed_interval`), which with three seeds is wide — by design.
* A **verdict** (:func:`judge`) needs more than an interval that excludes 0. The clip bootstrap
  treats the trained models as fixed, so it says nothing about another training seed; a verdict
  therefore also needs *every* seed's own difference to share the sign of the estimate. With
  fewer than :data:`MIN_SEEDS` seeds, fewer than :data:`MIN_CLIPS` clips, or an interval of zero
  width (one value, or a comparison that does not vary) the outcome is ``"cannot tell"``. A
  comparison whose per-seed differences are all equal does not depend on the seed (a calibration
  of ground truth against ground truth): its per-clip interval alone decides, since there is no
  training to vary. docs/statistics.md says why this rule and not a two-level bootstrap.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass

import numpy as np
from scipy import stats

__all__ = [
    "CONFIDENCE",
    "BOOTSTRAP_SAMPLES",
    "MIN_CLIPS",
    "MIN_SEEDS",
    "CANNOT_TELL",
    "REDUCERS",
    "Interval",
    "Judgement",
    "t_interval",
    "paired_bootstrap",
    "paired_seed_interval",
    "verdict",
    "judge",
    "reduce_components",
]

CONFIDENCE = 0.95
BOOTSTRAP_SAMPLES = 2000
MIN_CLIPS = 8
"""Fewest clips a per-clip comparison may rest on: a bootstrap over fewer clips has so few distinct
resamples (3 clips: 10) that its percentile interval is not a 95 % interval."""
MIN_SEEDS = 2
"""Fewest training seeds a verdict may rest on: one seed says nothing about another."""
CANNOT_TELL = "cannot tell"


def _f1(means: np.ndarray) -> np.ndarray:
    """LORIS F1 of the mean coverage (BCS) and mean hit (BHS) in ``means[..., 0:2]`` (0 when both are 0)."""
    a, b = means[..., 0], means[..., 1]
    total = a + b
    return np.divide(2.0 * a * b, total, out=np.zeros_like(total, dtype=np.float64), where=total > 0)


REDUCERS: Mapping[str, Callable[[np.ndarray], np.ndarray]] = {
    "mean": lambda means: means[..., 0],
    "f1": _f1,
}
"""Cell statistic from the per-clip component means ``(..., K)``: ``mean`` (K = 1) or ``f1`` (K = 2:
BCS and BHS; LORIS ``beats_scores.py`` takes the F1 of the means, not the mean of per-clip F1s)."""


@dataclass(frozen=True)
class Interval:
    """A point estimate with its 95 % interval ``[low, high]`` and how it was computed."""

    estimate: float
    low: float
    high: float
    n: int
    method: str
    clips: int | None = None  # clips a per-clip comparison pairs (None: a seed-level comparison)

    @property
    def half_width(self) -> float:
        return 0.5 * (self.high - self.low)

    @property
    def degenerate(self) -> bool:
        """No width: one value, or a difference that is the same in every resample."""
        scale = max(1.0, abs(self.low), abs(self.high))
        return not self.high - self.low > 1e-12 * scale

    def as_dict(self) -> dict[str, float | int | str]:
        out: dict[str, float | int | str] = {
            "estimate": self.estimate,
            "low": self.low,
            "high": self.high,
            "n": self.n,
            "method": self.method,
        }
        if self.clips is not None:
            out["clips"] = self.clips
        return out


def t_interval(values: Sequence[float], confidence: float = CONFIDENCE) -> Interval:
    """Mean of ``values`` with the Student-t interval ``mean ± t_{(1+c)/2, n-1} · s / √n``.

    With one value the interval is the point (no spread can be estimated); ``s`` uses ``n - 1``.
    """
    x = np.asarray(list(values), dtype=np.float64)
    if x.size == 0:
        raise ValueError("t_interval: no values")
    mean = float(x.mean())
    if x.size == 1:
        return Interval(mean, mean, mean, 1, "single value")
    half = float(stats.t.ppf(0.5 + confidence / 2.0, x.size - 1) * x.std(ddof=1) / math.sqrt(x.size))
    return Interval(mean, mean - half, mean + half, int(x.size), f"t-interval over {x.size} seeds")


def _as_seeds(a: np.ndarray) -> np.ndarray:
    """``(N, K)`` or ``(S, N, K)`` per-clip components as ``(S, N, K)``."""
    a = np.asarray(a, dtype=np.float64)
    if a.ndim == 2:
        return a[None]
    if a.ndim != 3:
        raise ValueError(f"per-clip components must be (N, K) or (S, N, K), got shape {a.shape}")
    return a


def reduce_components(components: np.ndarray, reducer: str) -> np.ndarray:
    """The cell statistic of ``(S, N, K)`` per-clip components: one value per seed ``(S,)``."""
    if reducer not in REDUCERS:
        raise ValueError(f"unknown reducer {reducer!r}; valid: {', '.join(REDUCERS)}")
    return REDUCERS[reducer](_as_seeds(components).mean(axis=1))


def paired_bootstrap(
    row: np.ndarray,
    other: np.ndarray,
    *,
    reducer: str = "mean",
    seed: int = 0,
    samples: int = BOOTSTRAP_SAMPLES,
    confidence: float = CONFIDENCE,
    row_ids: Sequence[object] | None = None,
    other_ids: Sequence[object] | None = None,
) -> Interval:
    """Difference ``cell(row) − cell(other)`` paired per clip, pooled over seeds, with a bootstrap interval.

    ``row`` and ``other`` are per-clip components ``(S, N, K)`` (or ``(N, K)`` for one seed, or for a
    side that does not depend on the seed — a calibration on ground truth — which is then paired
    with every seed of the other side). Clip ``i`` of ``row`` is paired with clip ``i`` of
    ``other``: ``row_ids`` / ``other_ids`` (the clips' identities, per clip or per seed and clip),
    when given, must be equal, else the sides were scored on different clips and there is no
    pairing (``ValueError``). See the module docstring for the resampling scheme.
    """
    if (row_ids is None) != (other_ids is None):
        raise ValueError("paired_bootstrap: clip ids given for one side only: cannot check the pairing")
    if row_ids is not None and other_ids is not None and _plain(row_ids) != _plain(other_ids):
        raise ValueError("paired_bootstrap: the two sides were scored on different clips (clip ids differ)")
    a, b = _as_seeds(row), _as_seeds(other)
    if a.shape[1:] != b.shape[1:]:
        raise ValueError(f"paired_bootstrap: per-clip shapes differ: {a.shape} vs {b.shape}")
    if b.shape[0] not in (1, a.shape[0]) and a.shape[0] != 1:
        raise ValueError(f"paired_bootstrap: {a.shape[0]} seeds vs {b.shape[0]} seeds")
    n = a.shape[1]
    if n == 0:
        raise ValueError("paired_bootstrap: no clips")
    reduce = REDUCERS[reducer]
    estimate = float(np.mean(reduce(a.mean(axis=1)) - reduce(b.mean(axis=1))))
    rng = np.random.default_rng(seed)
    idx = rng.integers(0, n, size=(samples, n))  # (R, N): clip draws shared by seeds and sides
    diffs = reduce(a[:, idx].mean(axis=2)) - reduce(b[:, idx].mean(axis=2))  # (S, R)
    reps = np.atleast_2d(diffs).mean(axis=0)
    tail = 100.0 * (1.0 - confidence) / 2.0
    low, high = np.percentile(reps, [tail, 100.0 - tail])
    seeds = max(a.shape[0], b.shape[0])
    return Interval(
        estimate,
        float(min(low, estimate)),
        float(max(high, estimate)),
        int(n * seeds),
        f"paired clip bootstrap ({n} clips × {seeds} seeds, {samples} resamples)",
        clips=int(n),
    )


def _plain(ids: Sequence[object]) -> list[object]:
    """Clip ids as nested plain lists (tuples, lists and arrays compare alike)."""
    return np.asarray(ids, dtype=object).tolist()  # type: ignore[no-any-return]


def paired_seed_interval(
    row: Sequence[float], other: Sequence[float], confidence: float = CONFIDENCE
) -> Interval:
    """Per-seed differences ``row[s] − other[s]`` with a t-interval over seeds (distributional metrics)."""
    if len(row) != len(other):
        raise ValueError(f"paired_seed_interval: {len(row)} vs {len(other)} seeds")
    interval = t_interval([a - b for a, b in zip(row, other)], confidence)
    return Interval(interval.estimate, interval.low, interval.high, interval.n, f"paired {interval.method}")


def verdict(interval: Interval, higher_is_better: bool) -> str:
    """The direction of an interval of a difference alone: ``"better"`` / ``"worse"`` when it excludes 0.

    ``"cannot tell"`` for one value or an interval of zero width (nothing to exclude 0 with),
    ``"not distinguishable"`` when it contains 0. This looks at the interval only; the verdict a
    table prints is :func:`judge`'s, which also asks every training seed.
    """
    if interval.n < 2 or interval.degenerate:
        return CANNOT_TELL
    if interval.low > 0:
        return "better" if higher_is_better else "worse"
    if interval.high < 0:
        return "worse" if higher_is_better else "better"
    return "not distinguishable"


@dataclass(frozen=True)
class Judgement:
    """The outcome of a comparison and why.

    Attributes:
        outcome: ``"better"``, ``"worse"``, ``"not distinguishable"`` or ``"cannot tell"``.
        reason: why there is no verdict (``""`` for better / worse).
        seeds: how many per-seed differences there are.
        seeds_agreeing: how many of them share the sign of the estimate (0 when it is 0).
        seed_independent: every seed's difference is the same (nothing trained varies with it).
    """

    outcome: str
    reason: str
    seeds: int
    seeds_agreeing: int
    seed_independent: bool

    @property
    def decided(self) -> bool:
        return self.outcome in ("better", "worse")


def judge(
    interval: Interval, per_seed: Sequence[float], higher_is_better: bool, *, min_clips: int = MIN_CLIPS
) -> Judgement:
    """The verdict on a difference: its interval *and* every seed's own difference (module docstring).

    ``per_seed`` holds each training seed's difference of the cells. In order: fewer than
    :data:`MIN_SEEDS` seeds, fewer than ``min_clips`` clips (per-clip comparisons) or an interval
    of zero width give ``"cannot tell"``; an interval containing 0 gives ``"not distinguishable"``,
    and so does one that excludes 0 while a seed's difference has the other sign (or is 0): the
    seeds disagree — unless
    every seed's difference is the same, when the comparison does not depend on the seed.
    """
    diffs = np.asarray(list(per_seed), dtype=np.float64)
    seeds = int(diffs.size)
    sign = np.sign(interval.estimate)
    agreeing = int(np.sum(np.sign(diffs) == sign)) if sign != 0 else 0
    independent = seeds >= 2 and bool(np.allclose(diffs, diffs[0], rtol=1e-9, atol=1e-12))

    def result(outcome: str, reason: str = "") -> Judgement:
        return Judgement(outcome, reason, seeds, agreeing, independent)

    if seeds < MIN_SEEDS:
        return result(CANNOT_TELL, "one training seed" if seeds == 1 else "no seeds")
    if interval.clips is not None and interval.clips < min_clips:
        return result(CANNOT_TELL, f"{interval.clips} clips, fewer than {min_clips}")
    if interval.n < 2 or interval.degenerate:
        return result(CANNOT_TELL, "the same value for every seed" if independent else "no spread")
    direction = verdict(interval, higher_is_better)
    if direction == "not distinguishable":
        return result(direction, "the interval contains 0")
    if not independent and agreeing < seeds:
        return result("not distinguishable", f"{seeds - agreeing} of {seeds} seeds disagree in sign")
    return result(direction)
