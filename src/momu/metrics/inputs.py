"""What each registered metric scores, what clip length it needs, and which values are distances.

``momu eval`` fills a generated clip's missing modality from its reference (the conditioning
input: a generated dance is scored against its music). That is right for the modality a metric
*conditions on* and wrong for the one it *scores*: ``beat_scores`` of a motion-only folder would
compare the reference music with itself (F1 = 1). :class:`MetricNeeds` says, per metric,

* ``scores`` — the modalities of which at least one must come from the generated folder;
* ``min_seconds`` — the shortest clip for which the metric's bins or windows are informative
  (a 1-s clip has one 1-s beat bin: it scores F1 0 or 1, nothing between);
* ``frechet`` — the value is a Fréchet distance (≥ 0 in exact arithmetic; the references'
  round-off can make two near-identical sets print a tiny negative number).

Plugins declare the same with a ``needs`` attribute on their metric (a :class:`MetricNeeds`);
a metric that declares nothing is not checked.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

__all__ = ["MetricNeeds", "NEEDS", "needs_of", "FRECHET_ROUNDOFF", "within_roundoff", "MIN_BINS"]

MIN_BINS = 4
"""Beat bins a clip must span for the bin-based beat scores (fewer saturate at 0 or 1)."""

MIN_BEATS_SECONDS = 4.0
"""Clip length (s) for the beat-alignment scores: about 8 beats at 120 BPM."""

FRECHET_ROUNDOFF = 1e-4
"""|FID| at or below this is printed with an "≈ 0, within round-off" flag."""


@dataclass(frozen=True)
class MetricNeeds:
    """What one metric needs from ``momu eval``'s clips (module docstring)."""

    scores: tuple[str, ...] = ()
    min_seconds: Callable[[Any], float] | float = 0.0
    frechet: bool = False

    def shortest(self, metric: Any) -> float:
        """The minimum clip length in seconds for the built ``metric`` (its config may set bins)."""
        return float(self.min_seconds(metric) if callable(self.min_seconds) else self.min_seconds)


def _bins(metric: Any) -> float:
    return MIN_BINS * float(getattr(getattr(metric, "cfg", None), "bin_seconds", 1.0))


def _learned(metric: Any) -> tuple[str, ...]:
    return (
        ("audio",) if getattr(getattr(metric, "cfg", None), "modality", "motion") == "music" else ("motion",)
    )


NEEDS: dict[str, MetricNeeds] = {
    "beat_scores": MetricNeeds(("audio",), _bins),
    "kinematic_beat_scores": MetricNeeds(("motion",), _bins),
    "bas": MetricNeeds(("motion", "audio"), MIN_BEATS_SECONDS),
    "harmony": MetricNeeds(("motion", "audio"), MIN_BEATS_SECONDS),
    "hit_rate": MetricNeeds(("motion", "audio"), MIN_BEATS_SECONDS),
    "pfc": MetricNeeds(("motion",)),
    "fid_k": MetricNeeds(("motion",), frechet=True),
    "fid_g": MetricNeeds(("motion",), frechet=True),
    "div_k": MetricNeeds(("motion",)),
    "div_g": MetricNeeds(("motion",)),
    "multimodality": MetricNeeds(("motion",)),
    "fid_learned": MetricNeeds(("motion",), frechet=True),
    "mean_kld": MetricNeeds(("motion",)),
    "fad": MetricNeeds(("audio",), frechet=True),
}
"""The built-in metrics' needs, by registry name."""


def needs_of(name: str, metric: Any) -> MetricNeeds | None:
    """``metric.needs`` if it declares one, else the built-in entry for ``name``, else ``None``."""
    declared = getattr(metric, "needs", None)
    if isinstance(declared, MetricNeeds):
        return declared
    if name == "diversity":
        return MetricNeeds(_learned(metric))
    return NEEDS.get(name)


def within_roundoff(value: float) -> bool:
    """A Fréchet distance indistinguishable from 0 (|value| ≤ :data:`FRECHET_ROUNDOFF`)."""
    return abs(float(value)) <= FRECHET_ROUNDOFF
