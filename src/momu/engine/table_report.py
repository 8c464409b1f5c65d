"""``results.md`` and the verdict lines of a reproduction's README, from a table's ``results.json``.

Everything here reads the plain result dict the runner writes (:func:`momu.engine.table.run_table`),
so ``results.md`` and ``reproductions/<table>/README.md`` print the same cells and the same verdicts.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

from momu.engine.scores import VARIANTS
from momu.engine.statistics import CANNOT_TELL, MIN_CLIPS
from momu.engine.table_results import columns_from_json, orderings, outcome_phrase

__all__ = [
    "fmt",
    "cell",
    "render_markdown",
    "verdict_lines",
    "ordering_lines",
    "pairwise_lines",
    "baseline_lines",
    "BASELINE_HEADING",
    "another_scale",
    "cells_caption",
    "size_line",
    "stale_stage_lines",
]


def fmt(value: float | None, signed: bool = False) -> str:
    """A number as printed in tables: 3 significant digits below 1000, whole numbers above."""
    if value is None:
        return "—"
    if not math.isfinite(value):
        return str(value)
    text = f"{value:.3g}" if abs(value) < 1000 else f"{value:.0f}"
    return f"+{text}" if signed and value > 0 else text


def cell(metrics: Mapping[str, float], half: Mapping[str, float | None], key: str) -> str:
    """``mean ± half-width`` (no ``±`` when there is no interval)."""
    value = metrics.get(key)
    if value is None:
        return "—"
    width = half.get(key)
    return fmt(value) + (f" ± {fmt(width)}" if width else "")


def cells_caption(result: Mapping[str, Any]) -> str:
    seeds = list(result["seeds"])
    if len(seeds) > 1:
        return (
            f"Cells: mean over the {len(seeds)} training seeds {seeds} ± the half-width of the 95 % "
            "Student-t interval over seeds."
        )
    return (
        f"Cells: one training seed ({seeds[0]}): no interval over seeds, and no comparison gets a "
        "verdict (that needs at least 2 seeds)."
    )


def size_line(result: Mapping[str, Any]) -> str:
    """How many clips the per-clip comparisons pair (per row and seed), or ``""`` without any."""
    counts = sorted(
        {
            len(arr[0])
            for row in result["rows"]
            for d in row.get("per_clip", {}).values()
            for arr in d.values()
        }
    )
    if not counts:
        return ""
    clips = str(counts[0]) if len(counts) == 1 else f"{counts[0]}–{counts[-1]}"
    return f"Per-clip comparisons pair {clips} evaluation clips per row and seed."


def _seeds_text(rec: Mapping[str, Any]) -> str:
    """``3/3 seeds``, ``the same for every seed``, or the per-seed differences when seeds disagree."""
    per_seed = list(rec.get("per_seed", []))
    if "disagree" in rec.get("reason", ""):
        return "seeds disagree: " + ", ".join(fmt(d, True) for d in per_seed)
    if rec.get("seed_independent"):
        return "the same for every seed"
    return f"{rec['seeds_agreeing']}/{len(per_seed)} seeds" if len(per_seed) > 1 else ""


def _interval_text(rec: Mapping[str, Any]) -> str:
    """What a verdict rests on: the interval and the seeds, or for *cannot tell* why, and no interval."""
    estimate = fmt(rec["estimate"], True)
    if rec["verdict"] == CANNOT_TELL:
        return f"{rec.get('reason') or 'no spread'}; difference {estimate}"
    seeds = _seeds_text(rec)
    return f"{estimate} [{fmt(rec['low'], True)}, {fmt(rec['high'], True)}]" + (
        f"; {seeds}" if seeds.startswith("seeds disagree") else f", {seeds}" if seeds else ""
    )


RULE = (
    "A verdict (anything but *not distinguishable* or *cannot tell*) needs the interval to exclude 0 "
    "**and** every training seed's own difference to share its sign; where the seeds disagree, their "
    "differences are printed. *Cannot tell*: one training seed, fewer than "
    f"{MIN_CLIPS} clips, or an interval of zero width (one value, or a difference that never varies). "
    "A difference that is the same for every seed does not depend on training: its clip interval "
    "alone decides (`momu.engine.statistics`, docs/statistics.md)."
)


def verdict_lines(result: Mapping[str, Any]) -> list[str]:
    """Per row and column, every comparison with its interval and its verdict in words."""
    columns = {c["key"]: c for c in result["columns"]}
    lines: list[str] = []
    for row in result["rows"]:
        parts = []
        for key, by_variant in row.get("comparisons", {}).items():
            if key not in columns:
                continue
            said = [
                f"{outcome_phrase(v, rec['verdict'])} ({_interval_text(rec)})"
                for v, rec in by_variant.items()
                if v in VARIANTS
            ]
            if said:
                parts.append(f"  - {columns[key]['label']}: " + "; ".join(said))
        if parts:
            lines += [f"- {row['id']} {row['name']}:", *parts]
    if not lines:
        return []
    intro = (
        "Differences (row − comparison) with their 95 % intervals: per-clip comparisons are paired on "
        "the same clips and pooled over seeds by a clip-level bootstrap of the cell statistic; "
        "distributional metrics (FID, FAD, Diversity) are compared per seed with a t-interval. " + RULE
    )
    variants = sorted({v for r in result["rows"] for d in r.get("comparisons", {}).values() for v in d})
    legend = [f"*{v}*: {VARIANTS[v].label}" for v in variants if v in VARIANTS]
    return ["", "## Verdicts", "", intro, "Comparisons: " + "; ".join(legend) + ".", "", *lines]


BASELINE_HEADING = "Against the baseline row"
_BASELINE_WORDS = {
    "better": "better than",
    "worse": "worse than",
    "not distinguishable": "not distinguishable from",
}


def baseline_lines(result: Mapping[str, Any]) -> list[str]:
    """Per column, every row against the baseline row (``versus_baseline``) with its interval and verdict."""
    versus = result.get("versus_baseline")
    if not versus:
        return []
    base = versus["row"]
    names = {r["id"]: r["name"] for r in result["rows"]}
    lines = ["", f"## {BASELINE_HEADING}", ""]
    for col in result["columns"]:
        recs = versus["columns"].get(col["key"], [])
        if not recs:
            continue
        lines.append(f"- {col['label']}:")
        for rec in recs:
            if rec["verdict"] == CANNOT_TELL:
                said = f"cannot tell against {base}"
            else:
                said = f"{_BASELINE_WORDS.get(rec['verdict'], rec['verdict'])} {base}"
            lines.append(f"  - {rec['row']} ({names.get(rec['row'], '')}): {said} ({_interval_text(rec)})")
    lines += [
        "",
        f"Differences are row − {base}, paired on the same clips (songs) where both rows were scored on "
        "them and pooled over the training seeds by the clip bootstrap, else per seed (FID); each "
        "record's pairing and per-seed differences are in results.json (`versus_baseline`). " + RULE,
    ]
    return lines


def _pair_line(pair: Mapping[str, Any], higher_is_better: bool) -> str:
    """``#7 − #1: +9.2 [+4.1, +14], 3/3 seeds: #7 better (the paper: the same order)``."""
    a, b = pair["rows"]
    better = a if (pair["estimate"] > 0) == higher_is_better else b
    order = "the same order" if pair["agrees"] else "the other order"
    said = _interval_text({**pair, "verdict": "decided"})
    return f"  - {a} − {b}: {said}: {better} better (the paper: {order})"


def ordering_lines(result: Mapping[str, Any]) -> list[str]:
    """Per column, how many row pairs are distinguishable, which, and how many order as the paper's."""
    orders = result.get("orderings", {})
    if not orders:
        return []
    lines = ["", "## Ordering of rows against the paper's", ""]
    for col in result["columns"]:
        rec = orders.get(col["key"])
        if rec is None:
            continue
        d, agree, total = rec["distinguishable"], rec["agree"], rec["total"]
        text = f"- {col['label']}: {d} of {total} row pairs distinguishable"
        text += f"; {agree} of those {d} ordered as in the paper" if d else ""
        if rec.get("seeds_disagree"):
            text += f"; {rec['seeds_disagree']} more exclude 0 in the interval but their seeds disagree"
        if rec.get("cannot_tell"):
            text += f"; cannot tell for {rec['cannot_tell']}"
        if rec.get("other_clips"):
            text += f"; {rec['other_clips']} compared per seed only (the rows were scored on different clips)"
        lines.append(text)
        lines += [
            _pair_line(p, col["higher_is_better"]) for p in rec.get("pairs", []) if p["distinguishable"]
        ]
    lines.append("")
    lines.append(
        "A pair is distinguishable when the interval of its difference excludes 0 and every seed's own "
        "difference has the same sign; only those are counted (and listed), since an ordering read "
        "from a difference within noise, or one that another training seed reverses, says nothing. "
        "Pairs are paired per clip where both rows were scored on the same clips, else per seed; "
        "each pair's per-seed differences are in results.json (`orderings`)."
    )
    return lines


def pairwise_lines(result: Mapping[str, Any]) -> tuple[list[str], dict[str, list[dict[str, Any]]]]:
    """Every pair of our rows per column (HarmoGAN's figures, which have no paper values to order
    against): the lines of ``results.md``'s "Pairwise comparisons of our rows" and ``pairwise.json``.

    :func:`~momu.engine.table_results.orderings` over placeholder paper cells, so that every pair is
    compared; only the intervals and outcomes are used.
    """
    rows = [
        {**r, "paper": {c["key"]: float(i) for c in result["columns"]}} for i, r in enumerate(result["rows"])
    ]
    pairs = orderings(rows, columns_from_json(result))
    names = {r["id"]: r["name"] for r in result["rows"]}
    lines = ["", "## Pairwise comparisons of our rows", ""]
    lines.append(
        "Difference (first − second) with its 95 % interval (paired clip bootstrap pooled over seeds; "
        "per seed for distributional cells); *distinguishable* when the interval excludes 0 and every "
        "seed's own difference shares its sign (`momu.engine.statistics`)."
    )
    for col in result["columns"]:
        rec = pairs.get(col["key"])
        if not rec:
            continue
        lines += ["", f"- {col['label']}:"]
        for p in rec["pairs"]:
            a, b = p["rows"]
            if p["outcome"] == CANNOT_TELL:
                said = f"{p['estimate']:+.4g} (cannot tell: {p['reason']})"
            else:
                seeds = _seeds_text(p)
                outcome = "distinguishable" if p["distinguishable"] else "not distinguishable"
                said = f"{p['estimate']:+.4g} [{p['low']:+.4g}, {p['high']:+.4g}] ({outcome}, {seeds})"
            lines.append(f"  - {names[a]} − {names[b]}: {said}")
    return lines, {k: v["pairs"] for k, v in pairs.items()}


def stale_stage_lines(result: Mapping[str, Any]) -> list[str]:
    """A warning when the run reused stages trained at another commit (``provenance.stages``).

    A stage key hashes the configuration, not the code (docs/recipes.md), so such a
    stage may not be what this commit's code would train.
    """
    stages = result["provenance"].get("stages", {})  # absent from hand-made results
    stale = sorted(k for k, v in stages.items() if v.startswith("reused, trained at"))
    if not stale:
        return []
    return [
        "",
        f"**Stages from other commits:** {len(stale)} reused stage(s) were trained at another commit than "
        f"this run's ({', '.join(stale)}; see `provenance.stages` in results.json). A stage key hashes the "
        "configuration, not the code: rerun into a fresh `--out` to train every stage with this code.",
    ]


def _table(result: Mapping[str, Any]) -> list[str]:
    """Our rows, then the calibration rows: our cells only (the paper's are in :func:`_paper_table`)."""
    cols = list(result["columns"])
    lines = ["| id | row | " + " | ".join(c["label"] for c in cols) + " |", "|" + "---|" * (2 + len(cols))]
    for row in result["rows"]:
        cells = [cell(row["metrics"], row.get("interval", {}), c["key"]) for c in cols]
        lines.append(f"| {row['id']} | {row['name']} | " + " | ".join(cells) + " |")
    for row in result["calibration"]:
        cells = [cell(row["metrics"], row.get("interval", {}), c["key"]) for c in cols]
        lines.append(f"| cal | {row['name']} (calibration) | " + " | ".join(cells) + " |")
    return lines


def another_scale(result: Mapping[str, Any]) -> bool:
    """Whether the paper's numbers are on another scale than ours: every preset but ``paper``, and
    any run on the synthetic stand-in data, measures other data with smaller models."""
    return result.get("preset") != "paper" or result.get("data") == "synth"


def _paper_table(result: Mapping[str, Any]) -> list[str]:
    """The paper's printed cells of our rows and of its baselines (not re-run), labelled by scale."""
    cols = list(result["columns"])
    ours = [r for r in result["rows"] if any(r["paper"].get(c["key"]) is not None for c in cols)]
    if not ours and not result["baselines"]:
        return []
    head = "## The paper's numbers" + (" (another scale)" if another_scale(result) else "")
    caption = (
        f"As the paper prints them, on its datasets with its models: another scale than ours (data "
        f"`{result['data']}`, preset `{result['preset']}`), so compare the ordering of rows, not values."
        if another_scale(result)
        else "As the paper prints them, beside our cells above."
    )
    lines = ["", head, "", caption, "", "| id | row | " + " | ".join(c["label"] for c in cols) + " |"]
    lines.append("|" + "---|" * (2 + len(cols)))
    for row in ours:
        cells = " | ".join(fmt(row["paper"].get(c["key"])) for c in cols)
        lines.append(f"| {row['id']} | {row['name']} | {cells} |")
    for row in result["baselines"]:
        cells = " | ".join(fmt(row["paper"].get(c["key"])) for c in cols)
        lines.append(f"| paper | {row['name']} (not re-run) | {cells} |")
    return lines


def _direction(col: Mapping[str, Any]) -> str:
    if col.get("closer_to"):
        return f"closer to {col['closer_to']}"
    return "higher" if col["higher_is_better"] else "lower"


def _artifact_lines(result: Mapping[str, Any]) -> list[str]:
    out = []
    for row in result["rows"]:
        for seed, arts in zip(result["seeds"], row.get("artifacts", [])):
            for name, path in sorted(arts.items()):
                out.append(f"  - {row['id']} seed {seed}: {name} `{path}`")
    return ["- saved models (under the output folder):", *out] if out else []


def render_markdown(result: Mapping[str, Any], notes: Sequence[str] = ()) -> str:
    """``results.md``: our rows and the calibration rows, then the paper's numbers (labelled by scale),
    verdicts, orderings, notes and provenance."""
    prov = result["provenance"]
    lines = [
        f"# {result['title']}",
        "",
        f"Preset `{result['preset']}`, data `{result['data']}`, seeds {result['seeds']}, "
        f"{prov['num_processes']} process(es) on {prov['device']}, {prov['wall_time_s']:.0f} s.",
        cells_caption(result),
        size_line(result),
        "",
        "## Our rows and the calibration rows",
        "",
        *_table(result),
        "",
        "Arrows: " + ", ".join(f"{c['label']} {_direction(c)} is better" for c in result["columns"]) + ".",
        "Calibration rows use the same metric code on ground truth and on ground truth with music and "
        "motion shuffled across clips: they show what *good* and *chance* are on this data.",
        *_paper_table(result),
        *verdict_lines(result),
        *baseline_lines(result),
        *ordering_lines(result),
        *stale_stage_lines(result),
    ]
    lines += ["", "## Notes", "", *[f"- {n}" for n in notes]] if notes else []
    lines += [
        "",
        "## Provenance",
        "",
        f"- commit: `{prov['git_commit']}`",
        f"- versions: {', '.join(f'{k} {v}' for k, v in prov['versions'].items())}",
        f"- plugins: {prov['plugins'] or 'none'}",
        f"- threads per process: {prov.get('threads', '?')}",
        f"- peak memory (main process): {prov['peak_memory_mib']:.0f} MiB",
        f"- stages: {', '.join(f'{k} ({v})' for k, v in prov['stages'].items()) or 'none'}",
        *_artifact_lines(result),
        "- resolved configs: in results.json (`rows[].config`); per-seed and per-clip values: "
        "`rows[].per_seed`, `rows[].per_clip`.",
    ]
    return "\n".join(lines) + "\n"
