"""From per-seed :class:`~momu.engine.scores.Scores` to a table's cells, comparisons and orderings.

Pure functions over plain data, shared by the table runner (``results.json`` / ``results.md``) and
the publishing step (``reproductions/<table>/README.md``), so a verdict is computed in one place.
The statistics are :mod:`momu.engine.statistics`'.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any, Protocol

import numpy as np

from momu.engine.scores import ROW, VARIANTS, Scores
from momu.engine.statistics import (
    Interval,
    paired_bootstrap,
    paired_seed_interval,
    reduce_components,
    t_interval,
    verdict,
)

__all__ = ["ColumnLike", "summarise_seeds", "compare_row", "orderings", "outcome_phrase"]


class ColumnLike(Protocol):
    """What the comparisons need of a column (:class:`momu.engine.table.Column`)."""

    @property
    def key(self) -> str: ...
    @property
    def higher_is_better(self) -> bool: ...
    @property
    def reducer(self) -> str: ...
    @property
    def closer_to(self) -> str | None: ...


def summarise_seeds(per_seed: Sequence[Scores]) -> dict[str, Any]:
    """Cells (mean over seeds), their 95 % half-widths, the per-seed cells and the per-clip arrays.

    ``per_clip[key][variant]`` is ``(S, N, K)`` when every seed recorded it with the same shape;
    ``seed_values[key][variant]`` is a list over seeds.
    """
    keys = sorted({k for s in per_seed for k in s.metrics})
    metrics, half = {}, {}
    for key in keys:
        interval = t_interval([s.metrics[key] for s in per_seed if key in s.metrics])
        metrics[key] = interval.estimate
        half[key] = interval.half_width if interval.n > 1 else None
    per_clip: dict[str, dict[str, list[Any]]] = {}
    for key in sorted({k for s in per_seed for k in s.clips}):
        for variant in sorted({v for s in per_seed for v in s.clips.get(key, {})}):
            arrays = [s.clips.get(key, {}).get(variant) for s in per_seed]
            if any(a is None for a in arrays) or len({a.shape for a in arrays if a is not None}) != 1:
                continue
            per_clip.setdefault(key, {})[variant] = np.stack(arrays).tolist()  # type: ignore[arg-type]
    seed_values: dict[str, dict[str, list[float]]] = {}
    for key in sorted({k for s in per_seed for k in s.seed_values}):
        for variant in sorted({v for s in per_seed for v in s.seed_values.get(key, {})}):
            values = [s.seed_values.get(key, {}).get(variant) for s in per_seed]
            if all(v is not None for v in values):
                seed_values.setdefault(key, {})[variant] = [float(v) for v in values]  # type: ignore[arg-type]
    return {
        "metrics": metrics,
        "interval": half,
        "per_seed": [s.metrics for s in per_seed],
        "per_clip": per_clip,
        "seed_values": seed_values,
        "artifacts": [dict(s.artifacts) for s in per_seed],
    }


def _record(interval: Interval, higher_is_better: bool, per_seed_diffs: Sequence[float]) -> dict[str, Any]:
    outcome = verdict(interval, higher_is_better)
    sign = np.sign(interval.estimate)
    agreeing = int(sum(np.sign(d) == sign for d in per_seed_diffs)) if sign != 0 else 0
    return {
        **interval.as_dict(),
        "verdict": outcome,
        "per_seed": [float(d) for d in per_seed_diffs],
        "seeds_agreeing": agreeing,
    }


def compare_row(
    summary: Mapping[str, Any], columns: Sequence[ColumnLike], *, bootstrap_seed: int = 0
) -> dict[str, dict[str, dict[str, Any]]]:
    """``{column key: {variant: interval + verdict}}`` of one row (:func:`summarise_seeds` output).

    Per-clip variants: the row's ``(S, N, K)`` components against the variant's on the same clips
    (:func:`~momu.engine.statistics.paired_bootstrap`). Seed-level variants: per-seed cells against
    the variant's per-seed values (:func:`~momu.engine.statistics.paired_seed_interval`). A column
    with ``closer_to`` is compared by distances to that reference (:func:`_compare_closer`).
    """
    out: dict[str, dict[str, dict[str, Any]]] = {}
    for col in columns:
        if col.closer_to:
            closer = _compare_closer(summary, col.key, col.closer_to)
            if closer:
                out[col.key] = closer
            continue
        clips = summary["per_clip"].get(col.key, {})
        row = clips.get(ROW)
        for variant, values in clips.items():
            if variant == ROW or row is None or variant not in VARIANTS:
                continue
            a, b = np.asarray(row), np.asarray(values)
            interval = paired_bootstrap(a, b, reducer=col.reducer, seed=bootstrap_seed)
            diffs = reduce_components(a, col.reducer) - reduce_components(b, col.reducer)
            out.setdefault(col.key, {})[variant] = _record(interval, col.higher_is_better, diffs.tolist())
        cells = [s.get(col.key) for s in summary["per_seed"]]
        for variant, values in summary["seed_values"].get(col.key, {}).items():
            if variant in out.get(col.key, {}) or any(c is None for c in cells) or len(values) != len(cells):
                continue
            interval = paired_seed_interval(cells, values)  # type: ignore[arg-type]
            diffs = [c - v for c, v in zip(cells, values)]  # type: ignore[operator]
            out.setdefault(col.key, {})[variant] = _record(interval, col.higher_is_better, diffs)
    return out


def _compare_closer(summary: Mapping[str, Any], key: str, reference: str) -> dict[str, dict[str, Any]]:
    """Comparisons of a "closer to ``reference`` is better" column (seed-level values only).

    Against the reference itself: the per-seed difference ``cell − reference`` ("worse" when its
    interval excludes 0, i.e. distinguishably away from the reference). Against another variant
    ``v``: the per-seed ``|cell − ref| − |v − ref|``, lower is better.
    """
    values = summary["seed_values"].get(key, {})
    ref = values.get(reference)
    cells = [s.get(key) for s in summary["per_seed"]]
    if ref is None or any(c is None for c in cells) or len(ref) != len(cells):
        return {}
    out: dict[str, dict[str, Any]] = {}
    diffs = [c - r for c, r in zip(cells, ref)]  # type: ignore[operator]
    interval = t_interval(diffs)
    rec = _record(interval, True, diffs)
    rec["verdict"] = "worse" if verdict(interval, True) != "not distinguishable" else "not distinguishable"
    out[reference] = {**rec, "method": f"paired {interval.method}"}
    for variant, other in values.items():
        if variant == reference or len(other) != len(cells):
            continue
        d = [abs(c - r) - abs(o - r) for c, r, o in zip(cells, ref, other)]  # type: ignore[operator]
        iv = t_interval(d)
        out[variant] = {
            **_record(iv, False, d),
            "method": f"|cell − {reference}| − |{variant} − {reference}|, {iv.method}",
        }
    return out


def outcome_phrase(variant: str, outcome: str) -> str:
    """The words of a verdict: ``"beats shuffled"``, ``"follows its condition"``, …"""
    v = VARIANTS[variant]
    return {"better": v.better, "worse": v.worse}.get(outcome, v.same)


def orderings(
    rows: Sequence[Mapping[str, Any]], columns: Sequence[ColumnLike], *, bootstrap_seed: int = 0
) -> dict[str, dict[str, Any]]:
    """Per column: which pairs of our rows differ distinguishably, and whether they order as in the paper.

    Only pairs where both rows have a paper cell (and the paper's cells differ) count; columns with
    ``closer_to`` have no ordering (it would need the paper's reference value for the pair). A pair is
    *distinguishable* when the interval of the difference of our cells excludes 0 (paired per clip
    when both rows have per-clip components on the same clips, else per seed); the agreement count
    is over distinguishable pairs only.
    """
    out: dict[str, dict[str, Any]] = {}
    for col in columns:
        if col.closer_to:
            continue  # the paper's reference value per pair is not known here: no ordering
        cand = [r for r in rows if r["paper"].get(col.key) is not None and col.key in r["metrics"]]
        pairs = []
        for i, a in enumerate(cand):
            for b in cand[i + 1 :]:
                pa, pb = float(a["paper"][col.key]), float(b["paper"][col.key])
                if pa == pb:
                    continue
                interval = _pair_interval(a, b, col, bootstrap_seed)
                if interval is None:
                    continue
                distinct = verdict(interval, True) != "not distinguishable"
                pairs.append(
                    {
                        "rows": [a["id"], b["id"]],
                        **interval.as_dict(),
                        "distinguishable": distinct,
                        "agrees": distinct and (interval.estimate > 0) == (pa > pb),
                    }
                )
        if pairs:
            out[col.key] = {
                "pairs": pairs,
                "total": len(pairs),
                "distinguishable": sum(p["distinguishable"] for p in pairs),
                "agree": sum(p["agrees"] for p in pairs),
            }
    return out


def _pair_interval(
    a: Mapping[str, Any], b: Mapping[str, Any], col: ColumnLike, bootstrap_seed: int
) -> Interval | None:
    ca, cb = a["per_clip"].get(col.key, {}).get(ROW), b["per_clip"].get(col.key, {}).get(ROW)
    if ca is not None and cb is not None and np.shape(ca) == np.shape(cb):
        return paired_bootstrap(np.asarray(ca), np.asarray(cb), reducer=col.reducer, seed=bootstrap_seed)
    sa = [s.get(col.key) for s in a["per_seed"]]
    sb = [s.get(col.key) for s in b["per_seed"]]
    if len(sa) != len(sb) or any(v is None for v in (*sa, *sb)):
        return None
    return paired_seed_interval(sa, sb)  # type: ignore[arg-type]
