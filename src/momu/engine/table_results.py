"""From per-seed :class:`~momu.engine.scores.Scores` to a table's cells, comparisons and orderings.

Pure functions over plain data, shared by the table runner (``results.json`` / ``results.md``), the
publishing step (``reproductions/<table>/README.md``) and the republishing step
(:mod:`momu.engine.republish`, which recomputes every verdict from a ``results.json``), so a verdict
is computed in one place. The statistics and the rule of a verdict are :mod:`momu.engine.statistics`'.

Every comparison record holds the interval, the outcome (``verdict``) and why there is none
(``reason``), each seed's own difference (``per_seed``), how many seeds share the estimate's sign
(``seeds_agreeing``), whether the difference depends on the seed at all (``seed_independent``) and
the t-interval over the per-seed differences (``per_seed_interval``, for information).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any, Protocol

import numpy as np

from momu.engine.scores import ROW, VARIANTS, Scores
from momu.engine.statistics import (
    CANNOT_TELL,
    Interval,
    judge,
    paired_bootstrap,
    paired_seed_interval,
    reduce_components,
    t_interval,
)

__all__ = [
    "ColumnLike",
    "StoredColumn",
    "columns_from_json",
    "summarise_seeds",
    "compare_row",
    "orderings",
    "versus_baseline",
    "outcome_phrase",
    "REFERENCE_VARIANTS",
]

REFERENCE_VARIANTS = ("ground truth", "shuffled")
"""Variants that depend on the clips only: where two rows without clip ids both carry one, its
per-clip values must agree clip by clip before the rows are paired by index (:func:`orderings`)."""


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


@dataclass(frozen=True)
class StoredColumn:
    """A column as ``results.json`` stores it (``columns[]``), for recomputing comparisons."""

    key: str
    label: str
    higher_is_better: bool
    reducer: str = "mean"
    closer_to: str | None = None


def columns_from_json(result: Mapping[str, Any]) -> list[StoredColumn]:
    """The columns of a ``results.json``."""
    return [
        StoredColumn(
            str(c["key"]),
            str(c["label"]),
            bool(c["higher_is_better"]),
            str(c.get("reducer") or "mean"),
            c.get("closer_to"),
        )
        for c in result["columns"]
    ]


def summarise_seeds(per_seed: Sequence[Scores]) -> dict[str, Any]:
    """Cells (mean over seeds), their 95 % half-widths, the per-seed cells and the per-clip arrays.

    ``per_clip[key][variant]`` is ``(S, N, K)`` when every seed recorded it with the same shape;
    ``seed_values[key][variant]`` is a list over seeds; ``clip_ids[key]`` the ``(S, N)`` clip ids
    when every seed recorded them (a seed may crop other windows of the same clips).
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
    clip_ids = {
        key: [list(s.clip_ids[key]) for s in per_seed]
        for key in sorted(per_clip)
        if all(key in s.clip_ids for s in per_seed)
    }
    out = {
        "metrics": metrics,
        "interval": half,
        "per_seed": [s.metrics for s in per_seed],
        "per_clip": per_clip,
        "seed_values": seed_values,
        "artifacts": [dict(s.artifacts) for s in per_seed],
    }
    if clip_ids:
        out["clip_ids"] = clip_ids
    return out


def _record(interval: Interval, higher_is_better: bool, per_seed_diffs: Sequence[float]) -> dict[str, Any]:
    """A comparison as ``results.json`` stores it (module docstring)."""
    diffs = [float(d) for d in per_seed_diffs]
    judgement = judge(interval, diffs, higher_is_better)
    rec: dict[str, Any] = {
        **interval.as_dict(),
        "verdict": judgement.outcome,
        "reason": judgement.reason,
        "per_seed": diffs,
        "seeds_agreeing": judgement.seeds_agreeing,
        "seed_independent": judgement.seed_independent,
    }
    if len(diffs) > 1:
        seeds = t_interval(diffs)
        rec["per_seed_interval"] = [seeds.low, seeds.high]
    return rec


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
    if rec["verdict"] in ("better", "worse"):
        rec["verdict"] = "worse"  # any distinguishable distance from the reference
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
    if outcome == CANNOT_TELL:
        return f"cannot tell against {variant}"
    return {"better": v.better, "worse": v.worse}.get(outcome, v.same)


def orderings(
    rows: Sequence[Mapping[str, Any]], columns: Sequence[ColumnLike], *, bootstrap_seed: int = 0
) -> dict[str, dict[str, Any]]:
    """Per column: which pairs of our rows differ distinguishably, and whether they order as in the paper.

    Only pairs where both rows have a paper cell (and the paper's cells differ) count; columns with
    ``closer_to`` have no ordering (it would need the paper's reference value for the pair). A pair's
    difference ``first − second`` is paired per clip when both rows were scored on the same clips
    (:func:`_same_clips`), else per seed; it is *distinguishable* when :func:`~momu.engine.statistics.judge`
    gives a verdict (the interval excludes 0 and every seed agrees in sign). Each pair records its
    per-seed differences, how many seeds agree, its ``outcome`` (``"first higher"``, ``"second
    higher"``, ``"not distinguishable"`` or ``"cannot tell"``, with its ``reason``) and how it was
    paired (``pairing``); the agreement count is over distinguishable pairs only.
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
                found = _pair_interval(a, b, col, bootstrap_seed)
                if found is None:
                    continue
                interval, diffs, pairing = found
                rec = _record(interval, True, diffs)
                verdict = rec.pop("verdict")
                decided = verdict in ("better", "worse")
                outcome = {"better": "first higher", "worse": "second higher"}.get(verdict, verdict)
                pairs.append(
                    {
                        "rows": [a["id"], b["id"]],
                        **rec,
                        "outcome": outcome,
                        "pairing": pairing,
                        "distinguishable": decided,
                        "agrees": decided and (interval.estimate > 0) == (pa > pb),
                    }
                )
        if pairs:
            out[col.key] = {
                "pairs": pairs,
                "total": len(pairs),
                "distinguishable": sum(p["distinguishable"] for p in pairs),
                "agree": sum(p["agrees"] for p in pairs),
                "seeds_disagree": sum("disagree" in p["reason"] for p in pairs),
                "cannot_tell": sum(p["outcome"] == CANNOT_TELL for p in pairs),
                "other_clips": sum(p["pairing"].startswith("per seed (the rows") for p in pairs),
            }
    return out


def _same_clips(a: Mapping[str, Any], b: Mapping[str, Any], key: str) -> tuple[bool, str]:
    """Whether rows ``a`` and ``b`` were scored on the same clips in column ``key``, and how that is known.

    With clip ids (``clip_ids[key]``, :class:`~momu.engine.scores.Scores`): the ids must be equal.
    Without (results written before clip ids were recorded): the rows' per-clip arrays must have the
    same shape, and where both carry a :data:`REFERENCE_VARIANTS` variant — values that depend on
    the clips only — its values must agree clip by clip; with no such variant the rows are paired
    in index order, as the recipe lists its evaluation clips, and the pairing says so.

    Raises:
        ValueError: one row has clip ids and the other has none (the pairing cannot be checked).
    """
    ia, ib = a.get("clip_ids", {}).get(key), b.get("clip_ids", {}).get(key)
    if (ia is None) != (ib is None):
        raise ValueError(
            f"column {key!r}: row {a['id']} has clip ids and row {b['id']} has none: "
            "cannot pair them per clip"
        )
    if ia is not None:
        return (True, "per clip (clip ids)") if ia == ib else (False, "per seed (the rows' clip ids differ)")
    ca, cb = a["per_clip"][key][ROW], b["per_clip"][key][ROW]
    if np.shape(ca) != np.shape(cb):
        return False, "per seed (the rows were scored on different numbers of clips)"
    for variant in REFERENCE_VARIANTS:
        ra, rb = a["per_clip"][key].get(variant), b["per_clip"][key].get(variant)
        if ra is None or rb is None:
            continue
        if np.shape(ra) == np.shape(rb) and np.array_equal(np.asarray(ra), np.asarray(rb)):
            return True, f"per clip (index order; the rows' {variant} values agree clip by clip)"
        return False, f"per seed (the rows' {variant} values differ: not the same clips)"
    return True, "per clip (index order; no clip ids recorded)"


def _pair_interval(
    a: Mapping[str, Any], b: Mapping[str, Any], col: ColumnLike, bootstrap_seed: int
) -> tuple[Interval, list[float], str] | None:
    """The interval of ``a − b`` in ``col``, the per-seed differences and how the rows were paired."""
    ca, cb = a["per_clip"].get(col.key, {}).get(ROW), b["per_clip"].get(col.key, {}).get(ROW)
    how = "per seed (no per-clip values)"
    if ca is not None and cb is not None:
        same, how = _same_clips(a, b, col.key)
        if same:
            xa, xb = np.asarray(ca), np.asarray(cb)
            ids_a, ids_b = a.get("clip_ids", {}).get(col.key), b.get("clip_ids", {}).get(col.key)
            interval = paired_bootstrap(
                xa, xb, reducer=col.reducer, seed=bootstrap_seed, row_ids=ids_a, other_ids=ids_b
            )
            diffs = reduce_components(xa, col.reducer) - reduce_components(xb, col.reducer)
            return interval, diffs.tolist(), how
    sa = [s.get(col.key) for s in a["per_seed"]]
    sb = [s.get(col.key) for s in b["per_seed"]]
    if len(sa) != len(sb) or any(v is None for v in (*sa, *sb)):
        return None
    interval = paired_seed_interval(sa, sb)  # type: ignore[arg-type]
    return interval, [float(x - y) for x, y in zip(sa, sb)], how  # type: ignore[operator]


def versus_baseline(
    rows: Sequence[Mapping[str, Any]],
    columns: Sequence[ColumnLike],
    baseline: str,
    *,
    bootstrap_seed: int = 0,
) -> dict[str, Any]:
    """Every other row against the ``baseline`` row, per column: ``row − baseline`` with its interval.

    Paired as :func:`orderings` pairs rows (per clip where both were scored on the same clips, else
    per seed) and judged by the same rule (:func:`~momu.engine.statistics.judge`): ``verdict`` is
    ``better`` / ``worse`` in the column's direction, ``not distinguishable`` or ``cannot tell``.
    Columns with ``closer_to`` are skipped (their "better" needs the reference per pair).

    Returns:
        ``{"row": baseline, "columns": {key: [record per other row]}}``; each record holds ``row``,
        the interval, ``verdict``, ``reason``, ``per_seed``, ``seeds_agreeing`` and ``pairing``.

    Raises:
        ValueError: ``baseline`` is not one of ``rows``.
    """
    base = next((r for r in rows if r["id"] == baseline), None)
    if base is None:
        raise ValueError(f"versus_baseline: no row {baseline!r} among {[r['id'] for r in rows]}")
    out: dict[str, list[dict[str, Any]]] = {}
    for col in columns:
        if col.closer_to:
            continue
        for row in rows:
            if row["id"] == baseline or col.key not in row["metrics"] or col.key not in base["metrics"]:
                continue
            found = _pair_interval(row, base, col, bootstrap_seed)
            if found is None:
                continue
            interval, diffs, pairing = found
            out.setdefault(col.key, []).append(
                {"row": row["id"], **_record(interval, col.higher_is_better, diffs), "pairing": pairing}
            )
    return {"row": baseline, "columns": out}
