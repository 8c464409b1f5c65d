"""What a table's ``evaluate`` / ``calibrate`` returns for one seed: cells plus per-clip evidence.

A recipe's ``evaluate(ctx, row_config, seed)`` returns a :class:`Scores` (a plain ``{key: value}``
dict is accepted too: cells without per-clip evidence, which then get seed-level intervals only):

* ``metrics`` — the cells of this seed, keyed like the table's columns (plus any diagnostic keys);
* ``clips`` — per column key, the per-clip *components* of the cell (``(N, K)``, see
  :data:`momu.engine.statistics.REDUCERS`) for the row itself (:data:`ROW`) and for each comparison
  *variant* measured on the very same clips (:data:`VARIANTS`): the shuffled calibration, ground
  truth, the same model given another clip's condition, ...;
* ``seed_values`` — per column key, a variant's value for this seed where the metric is
  distributional and has no per-clip value (the real-vs-real FID floor measured with this seed's
  feature extractor, say);
* ``clip_ids`` — per column key, the identities of the clips behind its per-clip values, in their
  order (``add_clips(..., ids=[clip.id for clip in clips])``). Every variant of a column is measured
  on the same clips, so a column has one list; two rows are paired per clip only when their lists
  are equal (:func:`momu.engine.table_results.orderings`).

The table runner pools these over seeds into intervals and verdicts
(:mod:`momu.engine.table_results`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

__all__ = ["ROW", "VARIANTS", "Variant", "Scores", "as_scores", "components"]

ROW = "row"
"""The key of a row's own per-clip components in :attr:`Scores.clips`."""


@dataclass(frozen=True)
class Variant:
    """A comparison the verdicts rest on: its label and the phrases of its three outcomes."""

    label: str
    better: str
    worse: str
    same: str


VARIANTS: Mapping[str, Variant] = {
    "shuffled": Variant(
        "ground truth with music and motion shuffled across clips",
        "beats shuffled",
        "worse than shuffled",
        "not distinguishable from shuffled",
    ),
    "ground truth": Variant(
        "ground truth",
        "better than ground truth",
        "worse than ground truth",
        "not distinguishable from ground truth",
    ),
    "other condition": Variant(
        "the same model given another clip's condition",
        "follows its condition",
        "scores higher with another clip's condition",
        "does not follow its condition (not distinguishable)",
    ),
    "other pair": Variant(
        "one modality of another jointly generated pair",
        "its jointly generated pairs agree",
        "agrees better with another pair",
        "its pairs are no more aligned than mismatched ones (not distinguishable)",
    ),
}
"""Every comparison variant a recipe may report (``Scores.clips[column][variant]``)."""


@dataclass
class Scores:
    """One row's (or one calibration row's) result for one seed; see the module docstring."""

    metrics: dict[str, float]
    clips: dict[str, dict[str, np.ndarray]] = field(default_factory=dict)
    seed_values: dict[str, dict[str, float]] = field(default_factory=dict)
    artifacts: dict[str, str] = field(default_factory=dict)  # e.g. {"model": "models/momu-<hash>"}
    clip_ids: dict[str, list[str]] = field(default_factory=dict)

    def add_clips(
        self,
        key: str,
        variant: str,
        values: np.ndarray | Sequence[Sequence[float]],
        ids: Sequence[str] | None = None,
    ) -> None:
        """Record ``(N, K)`` per-clip components of column ``key`` for ``variant`` (:data:`ROW` or a
        :data:`VARIANTS` name), and optionally the ``N`` clips' ids.

        Raises:
            ValueError: an unknown variant, a bad shape, ids of another length than the values, or
                ids other than those already recorded for ``key`` (every variant of a column is
                measured on the same clips).
        """
        if variant != ROW and variant not in VARIANTS:
            raise ValueError(f"unknown comparison variant {variant!r}; valid: {ROW}, {', '.join(VARIANTS)}")
        arr = np.asarray(values, dtype=np.float64)
        if arr.ndim == 1:
            arr = arr[:, None]
        if arr.ndim != 2:
            raise ValueError(f"per-clip values of {key!r} must be (N, K), got shape {arr.shape}")
        if ids is not None:
            names = [str(i) for i in ids]
            if len(names) != len(arr):
                raise ValueError(f"clip ids of {key!r}: {len(names)} ids for {len(arr)} clips")
            if key in self.clip_ids and self.clip_ids[key] != names:
                raise ValueError(f"clip ids of {key!r}: {variant!r} was measured on other clips than before")
            self.clip_ids[key] = names
        self.clips.setdefault(key, {})[variant] = arr

    def add_seed_value(self, key: str, variant: str, value: float) -> None:
        """Record a variant's seed-level value of column ``key`` (distributional metrics)."""
        if variant not in VARIANTS:
            raise ValueError(f"unknown comparison variant {variant!r}; valid: {', '.join(VARIANTS)}")
        self.seed_values.setdefault(key, {})[variant] = float(value)

    def to_json(self) -> dict[str, Any]:
        return {
            "metrics": dict(self.metrics),
            "clips": {k: {v: a.tolist() for v, a in d.items()} for k, d in self.clips.items()},
            "seed_values": {k: dict(d) for k, d in self.seed_values.items()},
            "artifacts": dict(self.artifacts),
            "clip_ids": {k: list(v) for k, v in self.clip_ids.items()},
        }

    @classmethod
    def from_json(cls, data: Mapping[str, Any]) -> Scores:
        return cls(
            metrics={str(k): float(v) for k, v in data["metrics"].items()},
            clips={
                str(k): {str(v): np.asarray(a, dtype=np.float64) for v, a in d.items()}
                for k, d in data.get("clips", {}).items()
            },
            seed_values={
                str(k): {str(v): float(x) for v, x in d.items()}
                for k, d in data.get("seed_values", {}).items()
            },
            artifacts={str(k): str(v) for k, v in data.get("artifacts", {}).items()},
            clip_ids={str(k): [str(i) for i in v] for k, v in data.get("clip_ids", {}).items()},
        )


def as_scores(value: Scores | Mapping[str, float]) -> Scores:
    """A :class:`Scores` from what ``evaluate`` returned (a plain dict means cells only)."""
    if isinstance(value, Scores):
        return value
    if isinstance(value, Mapping):
        return Scores(metrics={str(k): float(v) for k, v in value.items()})
    raise TypeError(f"evaluate must return Scores or a dict of floats, got {type(value).__name__}")


def components(covers: Sequence[float], hits: Sequence[float], scale: float = 100.0) -> np.ndarray:
    """``(N, 2)`` per-clip (BCS, BHS) components of a LORIS beat F1 cell (reducer ``f1``), in percent."""
    c = np.asarray(covers, dtype=np.float64)
    h = np.asarray(hits, dtype=np.float64)
    if c.shape != h.shape or c.ndim != 1:
        raise ValueError(f"components: covers {c.shape} and hits {h.shape} must be equal 1-D shapes")
    return scale * np.stack([c, h], axis=1)
