"""One "which models follow" table from several music-following ``results.json`` files.

    python -m momu.following.table RESULTS.json [RESULTS.json ...] --out DIR [--label ID=NAME ...]

Each ``results.json`` is one run of ``recipes/music_following.py`` (one model, one data set, one or both
directions). The table has one row per model × direction × data: per test its estimate, 95 % interval
and verdict **as the run gave it** (the gated verdict, never recomputed here), preceded by ground truth's
row on the same data (its own raw verdicts) and a column naming the tests ground truth passes there — a
model's verdict on any other test is "no verdict". Music → dance rows also get a realism table.

``--training-seeds NAME=ID,ID,...`` declares generator rows to be one recipe trained at several seeds; the
table then adds, per recipe × direction × data, each seed's verdict side by side and whether the verdict
holds at every seed (a verdict about one trained model says nothing about the next training run).

Writes ``DIR/results.json`` (every cell, with the source file, command, commit and wall time of each run)
and ``DIR/results.md``. A missing or malformed file, a bad ``--label`` or an unwritable ``--out`` prints
one line ``which_models_follow: error: ...`` and exits with status 2, writing nothing.
"""

from __future__ import annotations

import argparse
import json
import logging
import sys
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

from momu.errors import UsageParser, fail
from momu.following.checks import TESTS
from momu.following.realism import REALISM_KEYS
from momu.following.report import DIRECTION_TITLES, format_cell
from momu.io import atomic_write_text, check_output_dir, write_json

__all__ = ["SHORT_TITLES", "across_training_seeds", "collect", "markdown", "load_results", "main"]

log = logging.getLogger("which_models_follow")
PROG = "which_models_follow"

SHORT_TITLES = {
    "input_sensitivity": "input sensitivity",
    "tempo_following": "tempo following",
    "tempo_match": "tempo match",
    "beat_phase_bailando": "beat phase (BAS Bailando)",
    "beat_phase_mint": "beat phase (BAS mint)",
    "matched_bailando": "matched (BAS Bailando)",
    "matched_mint": "matched (BAS mint)",
}
"""Column titles of the tests (definitions: docs/following.md)."""
REALISM_TITLES = {
    "root_travel_m_per_min": "root travel (m/min)",
    "foot_speed": "foot speed (m/s)",
    "joint_speed": "joint speed (m/s)",
    "bone_length_cv": "bone-length variation",
}
_CELL_KEYS = ("estimate", "low", "high", "verdict")


class TableInputError(ValueError):
    """A bad input of the collector (one line, exit status 2)."""


def load_results(path: Path) -> dict[str, Any]:
    """A music-following ``results.json``; raises :class:`TableInputError` naming the file otherwise."""
    try:
        data = json.loads(Path(path).read_text())
    except FileNotFoundError:
        raise TableInputError(f"{path}: file not found") from None
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise TableInputError(f"{path}: not readable JSON ({str(exc).splitlines()[0]})") from None
    if not isinstance(data, dict) or data.get("benchmark") != "music_following":
        raise TableInputError(f"{path}: not a results.json of recipes/music_following.py")
    directions = data.get("directions")
    if not isinstance(directions, dict) or not directions:
        raise TableInputError(f"{path}: no 'directions' in the results")
    for name, res in directions.items():
        rows = res.get("rows") if isinstance(res, dict) else None
        if not isinstance(rows, list) or not any(r.get("id") == "ground_truth" for r in rows):
            raise TableInputError(f"{path}: direction {name!r} has no ground_truth row")
    return data


def _data_label(results: Mapping[str, Any]) -> str:
    """``synth_dance (val split), openpose14, 7 songs × 10 s, seeds 0 1 2``."""
    node, settings = results.get("dataset", {}), results.get("settings", {})
    parts = [str(results.get("data", node.get("name", "?")))]
    if node.get("skeleton"):
        parts.append(str(node["skeleton"]))
    parts.append(f"{settings.get('songs', '?')} songs × {settings.get('seconds', '?'):g} s")
    parts.append(f"seeds {settings.get('seeds', '?')}")
    return ", ".join(parts)


def _cells(tests: Mapping[str, Any], keys: Sequence[str]) -> dict[str, dict[str, Any]]:
    return {t: {k: tests[t][k] for k in _CELL_KEYS if k in tests[t]} for t in keys if t in tests}


def collect(
    sources: Sequence[tuple[str, Mapping[str, Any]]],
    labels: Mapping[str, str] | None = None,
    training_seeds: Mapping[str, Sequence[str]] | None = None,
) -> dict[str, Any]:
    """The table of ``sources`` (``(name, results)`` pairs, in order): one group per data × direction.

    A group holds ground truth's row (its verdicts are its raw ones: calibration rows are not gated) and every
    generator row run on the same data, in source order. Runs on identical data share one group (their
    ground-truth rows are the same; the first one's is kept). ``labels`` renames generator rows by id;
    ``training_seeds`` maps a recipe's name to the row ids of its training seeds
    (:func:`across_training_seeds`); an id that no source holds raises :class:`TableInputError`.
    """
    labels = dict(labels or {})
    groups: dict[tuple[str, str], dict[str, Any]] = {}
    runs = []
    for name, results in sources:
        data = _data_label(results)
        prov = results.get("provenance", {})
        runs.append(
            {
                "source": name,
                "data": data,
                "generator": results.get("settings", {}).get("generator"),
                "command": prov.get("command"),
                "git_commit": prov.get("git_commit"),
                "wall_time_s": prov.get("wall_time_s"),
            }
        )
        for direction, res in results["directions"].items():
            key = (json.dumps(results.get("dataset", {}), sort_keys=True) + data, direction)
            if key not in groups:
                gt = next(r for r in res["rows"] if r["id"] == "ground_truth")
                groups[key] = {
                    "data": data,
                    "direction": direction,
                    "ground_truth_passes": list(res["ground_truth_passes"]),
                    "reference_realism": res.get("reference_realism", {}),
                    "rows": [_row(gt, "ground truth", "calibration", name)],
                }
            for r in res["rows"]:
                if r.get("kind") == "generator":
                    groups[key]["rows"].append(_row(r, labels.get(r["id"], r["id"]), "generator", name))
    table: dict[str, Any] = {
        "table": "which_models_follow",
        "tests": list(TESTS),
        "groups": list(groups.values()),
        "runs": runs,
    }
    if training_seeds:
        table["across_training_seeds"] = across_training_seeds(table["groups"], training_seeds)
    return table


def across_training_seeds(
    groups: Sequence[Mapping[str, Any]], recipes: Mapping[str, Sequence[str]]
) -> list[dict[str, Any]]:
    """Per recipe × data × direction: each training seed's verdicts, and whether they agree.

    ``recipes`` maps a name to the generator row ids of one recipe trained at several seeds. A record holds
    the members found in that group (``models``), per test the list of their verdicts, ``follows`` (per
    member: every test ground truth passes there passes) and ``holds`` (every member gives the same verdict
    on every test and the same ``follows``; None when only one member ran on that data).
    """
    present = {r["id"] for g in groups for r in g["rows"] if r["kind"] == "generator"}
    seen: set[str] = set()
    for name, ids in recipes.items():
        for row_id in ids:
            if row_id not in present:
                raise TableInputError(f"--training-seeds {name}: no generator row {row_id!r} in the results")
            if row_id in seen:
                raise TableInputError(f"--training-seeds: row {row_id!r} named in two recipes")
            seen.add(row_id)
    records = []
    for name, ids in recipes.items():
        for g in groups:
            members = [r for i in ids for r in g["rows"] if r["id"] == i and r["kind"] == "generator"]
            if not members:
                continue
            tests = {t: [r["tests"].get(t, {}).get("verdict", "—") for r in members] for t in TESTS}
            gt_passes = g["ground_truth_passes"]
            follows = [
                bool(gt_passes) and all(tests[t][k] == "passes" for t in gt_passes)
                for k in range(len(members))
            ]
            records.append(
                {
                    "recipe": name,
                    "direction": g["direction"],
                    "data": g["data"],
                    "ground_truth_passes": list(g["ground_truth_passes"]),
                    "models": [r["label"] for r in members],
                    "tests": tests,
                    "follows": follows,
                    "holds": (
                        len(set(follows)) == 1 and all(len(set(v)) == 1 for v in tests.values())
                        if len(members) > 1
                        else None
                    ),
                }
            )
    return records


def _row(row: Mapping[str, Any], label: str, kind: str, source: str) -> dict[str, Any]:
    tests = _cells(row["tests"], TESTS)  # a calibration row's verdict is its raw one (nothing gates it)
    out = {"id": row["id"], "label": label, "kind": kind, "source": source, "tests": tests}
    if row.get("realism"):
        out["realism"] = _cells(row["realism"], REALISM_KEYS)
    return out


def _passes_text(passes: Sequence[str]) -> str:
    if len(passes) == len(TESTS):
        return "every test"
    return ", ".join(SHORT_TITLES[t] for t in passes) if passes else "none"


def markdown(table: Mapping[str, Any]) -> str:
    """The Markdown of :func:`collect`'s table: the tests, then realism (music → dance), then the runs."""
    lines = [
        "# Which models follow their input",
        "",
        "Cells: mean over songs × seeds [95 % two-level bootstrap interval] and the run's verdict. A model's "
        "verdict is given only on a test ground truth passes on the same data (last column); elsewhere "
        "it reads *no verdict*. Test definitions and verdict rules: docs/following.md.",
        "",
        *_test_header(["model", "direction", "data"], ["ground truth passes here"]),
    ]
    for g in table["groups"]:
        passes = _passes_text(g["ground_truth_passes"])
        for r in g["rows"]:
            name = f"*{r['label']}*" if r["kind"] == "calibration" else r["label"]
            cells = [format_cell(r["tests"].get(t)) for t in TESTS]
            lines.append(
                f"| {name} | {DIRECTION_TITLES[g['direction']]} | {g['data']} | "
                + " | ".join(cells)
                + f" | {passes} |"
            )
    lines.append("")
    dance = [g for g in table["groups"] if g["direction"] == "dance" and g["reference_realism"]]
    if dance:
        lines += [
            "## Realism (music → dance)",
            "",
            "Passes = inside the real data's 5th–95th percentile over every excerpt-long window of the "
            "benchmark songs' dances (bone-length variation: up to that 95th percentile or 1 %). A 2-D "
            "skeleton (openpose14) is in pixels: px/s, and no root travel.",
            "",
            "| model | data | " + " | ".join(REALISM_TITLES.values()) + " |",
            "|---" * (len(REALISM_KEYS) + 2) + "|",
        ]
        for g in dance:
            ref = g["reference_realism"]
            real = [f"{ref[k]['p5']:.3f} – {ref[k]['p95']:.3f}" if k in ref else "—" for k in REALISM_KEYS]
            lines.append(f"| *real 5th–95th pct* | {g['data']} | " + " | ".join(real) + " |")
            for r in g["rows"]:
                if r["kind"] == "generator":
                    cells = [format_cell(r.get("realism", {}).get(k)) for k in REALISM_KEYS]
                    lines.append(f"| {r['label']} | {g['data']} | " + " | ".join(cells) + " |")
        lines.append("")
    if table.get("across_training_seeds"):
        lines += _seeds_markdown(table["across_training_seeds"])
    lines += [
        "## Runs",
        "",
        "| source | generator | data | commit | wall time (s) |",
        "|---|---|---|---|---|",
    ]
    for run in table["runs"]:
        commit = str(run.get("git_commit") or "?")[:12]
        lines.append(
            f"| {run['source']} | {run['generator']} | {run['data']} | {commit} | {run.get('wall_time_s')} |"
        )
    return "\n".join(lines) + "\n"


def _test_header(lead: Sequence[str], tail: Sequence[str]) -> list[str]:
    """A Markdown table's header and rule: ``lead`` columns, one per test, then ``tail``."""
    titles = [*lead, *(SHORT_TITLES[t] for t in TESTS), *tail]
    return ["| " + " | ".join(titles) + " |", "|---" * len(titles) + "|"]


def _seeds_markdown(records: Sequence[Mapping[str, Any]]) -> list[str]:
    lines = [
        "## Across training seeds",
        "",
        "One recipe trained at several seeds: each seed's verdict, in the order of the models column. "
        "*follows* = passes every test ground truth passes on that data. **holds** = every training seed "
        "gives the same verdicts.",
        "",
        *_test_header(["recipe", "direction", "data", "models"], ["follows", "holds across seeds"]),
    ]
    for rec in records:
        cells = [" / ".join(_short_verdict(v) for v in rec["tests"][t]) for t in TESTS]
        follows = " / ".join("yes" if f else "no" for f in rec["follows"])
        lines.append(
            f"| {rec['recipe']} | {DIRECTION_TITLES[rec['direction']]} | {rec['data']} | "
            f"{'; '.join(rec['models'])} | " + " | ".join(cells) + f" | {follows} | "
            f"{_HOLDS_TEXT[rec['holds']]} |"
        )
    return [*lines, ""]


_HOLDS_TEXT = {True: "**yes**", False: "**no**", None: "one seed only"}


def _short_verdict(verdict: str) -> str:
    return "no verdict" if verdict.startswith("no verdict") else verdict


def _parse_training_seeds(items: Sequence[str]) -> dict[str, list[str]]:
    recipes: dict[str, list[str]] = {}
    for item in items:
        name, sep, value = item.partition("=")
        ids = [i for i in value.split(",") if i]
        if not sep or not name or len(ids) < 2:
            raise TableInputError(f"--training-seeds {item!r}: expected NAME=ROW_ID,ROW_ID[,...]")
        if name in recipes:
            raise TableInputError(f"--training-seeds {item!r}: recipe {name!r} given twice")
        recipes[name] = ids
    return recipes


def _parse_labels(items: Sequence[str]) -> dict[str, str]:
    labels = {}
    for item in items:
        key, sep, value = item.partition("=")
        if not sep or not key or not value:
            raise TableInputError(f"--label {item!r}: expected ROW_ID=NAME")
        labels[key] = value
    return labels


def build_parser() -> argparse.ArgumentParser:
    p = UsageParser(
        prog=PROG, description="Collect music-following results.json files into one table (docs/following.md)"
    )
    p.add_argument("results", type=Path, nargs="+", help="results.json files of recipes/music_following.py")
    p.add_argument("--out", type=Path, required=True, help="folder for results.json and results.md")
    p.add_argument(
        "--label",
        action="append",
        default=[],
        metavar="ROW_ID=NAME",
        help="show generator row ROW_ID (e.g. momu:momu-ab00d4f89fef) as NAME; repeatable",
    )
    p.add_argument(
        "--training-seeds",
        action="append",
        default=[],
        metavar="NAME=ROW_ID,ROW_ID",
        help="the rows are one recipe trained at several seeds: compare their verdicts; repeatable",
    )
    return p


def main(argv: list[str] | None = None) -> int:
    logging.basicConfig(level=logging.INFO, format="%(levelname)s %(name)s: %(message)s")
    args = build_parser().parse_args(argv)
    try:
        labels = _parse_labels(args.label)
        recipes = _parse_training_seeds(args.training_seeds)
        try:
            check_output_dir(args.out)
        except ValueError as exc:
            raise TableInputError(str(exc)) from None
        sources = [(str(p), load_results(p)) for p in args.results]
        table = collect(sources, labels, recipes)
    except TableInputError as exc:
        return fail(PROG, exc)
    args.out.mkdir(parents=True, exist_ok=True)
    write_json(args.out / "results.json", table)
    atomic_write_text(args.out / "results.md", markdown(table))
    log.info("wrote %s and %s", args.out / "results.json", args.out / "results.md")
    return 0


if __name__ == "__main__":
    sys.exit(main())
