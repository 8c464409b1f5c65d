"""``results.md`` and the verdict lines of a reproduction's README, from a table's ``results.json``.

Everything here reads the plain result dict the runner writes (:func:`momu.engine.table.run_table`),
so ``results.md`` and ``reproductions/<table>/README.md`` print the same cells and the same verdicts.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from typing import Any

from momu.engine.scores import VARIANTS
from momu.engine.table_results import outcome_phrase

__all__ = [
    "fmt",
    "cell",
    "render_markdown",
    "verdict_lines",
    "ordering_lines",
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
    return f"Cells: one training seed ({seeds[0]}); no interval can be given."


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


def _interval_text(rec: Mapping[str, Any]) -> str:
    seeds = len(rec.get("per_seed", []))
    agree = f", {rec['seeds_agreeing']}/{seeds} seeds" if seeds > 1 else ""
    return f"{fmt(rec['estimate'], True)} [{fmt(rec['low'], True)}, {fmt(rec['high'], True)}]{agree}"


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
        "distributional metrics (FID, FAD, Diversity) are compared per seed with a t-interval. "
        "A verdict other than *not distinguishable* means the interval excludes 0 "
        "(`momu.engine.statistics`)."
    )
    variants = sorted({v for r in result["rows"] for d in r.get("comparisons", {}).values() for v in d})
    legend = [f"*{v}*: {VARIANTS[v].label}" for v in variants if v in VARIANTS]
    return ["", "## Verdicts", "", intro, "Comparisons: " + "; ".join(legend) + ".", "", *lines]


def ordering_lines(result: Mapping[str, Any]) -> list[str]:
    """Per column, how many row pairs are distinguishable and how many of those order as the paper's."""
    orders = result.get("orderings", {})
    if not orders:
        return []
    lines = ["", "## Ordering of rows against the paper's", ""]
    for col in result["columns"]:
        rec = orders.get(col["key"])
        if rec is None:
            continue
        d, agree, total = rec["distinguishable"], rec["agree"], rec["total"]
        tail = f"; {agree} of those {d} ordered as in the paper" if d else ""
        lines.append(f"- {col['label']}: {d} of {total} row pairs distinguishable{tail}")
    lines.append("")
    lines.append(
        "A pair is distinguishable when the interval of its difference excludes 0; only those are "
        "counted, since an ordering read from a difference within noise says nothing."
    )
    return lines


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
    cols = list(result["columns"])
    header = "| id | row | " + " | ".join(f"{c['label']} ours | {c['label']} paper" for c in cols) + " |"
    lines = [header, "|" + "---|" * (2 + 2 * len(cols))]
    for row in result["rows"]:
        cells = []
        for c in cols:
            cells += [
                cell(row["metrics"], row.get("interval", {}), c["key"]),
                fmt(row["paper"].get(c["key"])),
            ]
        lines.append(f"| {row['id']} | {row['name']} | " + " | ".join(cells) + " |")
    for row in result["calibration"]:
        cells = []
        for c in cols:
            cells += [cell(row["metrics"], row.get("interval", {}), c["key"]), "—"]
        lines.append(f"| cal | {row['name']} (calibration) | " + " | ".join(cells) + " |")
    for row in result["baselines"]:
        cells = []
        for c in cols:
            cells += ["not re-run", fmt(row["paper"].get(c["key"]))]
        lines.append(f"| paper | {row['name']} | " + " | ".join(cells) + " |")
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
    """``results.md``: cells with intervals beside the paper's, calibration rows, verdicts, provenance."""
    prov = result["provenance"]
    lines = [
        f"# {result['title']}",
        "",
        f"Preset `{result['preset']}`, data `{result['data']}`, seeds {result['seeds']}, "
        f"{prov['num_processes']} process(es) on {prov['device']}, {prov['wall_time_s']:.0f} s.",
        cells_caption(result),
        size_line(result),
        "",
        *_table(result),
        "",
        "Arrows: " + ", ".join(f"{c['label']} {_direction(c)} is better" for c in result["columns"]) + ".",
        "Baseline rows marked *not re-run* are the paper's numbers, reported for reference.",
        "Calibration rows use the same metric code on ground truth and on ground truth with music and "
        "motion shuffled across clips: they show what *good* and *chance* are on this data.",
        *verdict_lines(result),
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
