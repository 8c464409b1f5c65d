"""The protocol every registered metric follows.

A metric factory registered in ``momu.registry.METRICS`` takes its config dataclass and
returns a :class:`Metric`: a callable over two sequences of :class:`~momu.data.types.Clip` —
the generated clips and the reference (ground-truth) clips — returning named scalar scores.
Each clip carries whatever the metric reads: motion (and its fps) for motion metrics, audio
(and its sample rate) for music metrics, both for alignment metrics.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any, Protocol, runtime_checkable

from momu.data.types import Clip

__all__ = ["Metric", "MetricResult"]

MetricResult = dict[str, float]


@runtime_checkable
class Metric(Protocol):
    """A built metric.

    Attributes:
        name: the registry name; result keys start with it (``fid_k``, ``beat_scores.bcs`` ...).
        needs_reference: whether ``reference`` must be given (FID does; BAS does not).
    """

    name: str
    needs_reference: bool

    def __call__(
        self, generated: Sequence[Clip], reference: Sequence[Clip] | None = None
    ) -> MetricResult: ...

    def provenance(self) -> dict[str, Any]:
        """What a reader needs to trust the number: variant, extractor name and checkpoint hash ..."""
        ...
