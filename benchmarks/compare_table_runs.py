"""Does a change of *how* a table is computed change what it shows? Two runs of one table, cell by cell.

Given two ``results.json`` of the same table, seeds and evaluation clips (for instance the committed
fp32 run and a run with ``mixed_precision=bf16``), this prints for every row and column the two
means and the difference ``new − base`` with a paired t-interval over seeds (the runs share each
seed's data order, initialisation and evaluation clips; :func:`momu.engine.statistics.paired_seed_interval`),
and whether the interval excludes 0. It then sets the two runs' verdicts side by side — every
row's comparison with the shuffled calibration, another clip's condition and the ground truth — and
counts how many agree.

    python benchmarks/compare_table_runs.py reproductions/momu_table7/results.json \
        outputs/bf16/momu_table7/results.json
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

from momu.engine.statistics import paired_seed_interval


def _rows(results: dict[str, Any]) -> dict[str, dict[str, Any]]:
    return {row["id"]: row for row in results["rows"]}


def _check_comparable(base: dict[str, Any], new: dict[str, Any]) -> None:
    for field in ("table", "seeds"):
        if base.get(field) != new.get(field):
            raise SystemExit(
                f"compare_table_runs: {field} differs: {base.get(field)!r} vs {new.get(field)!r}"
            )


def cell_differences(base: dict[str, Any], new: dict[str, Any]) -> list[tuple[str, str, float, float, Any]]:
    """``(row, column, base mean, new mean, interval of new − base)`` for every shared cell."""
    out = []
    new_rows = _rows(new)
    for row_id, row in _rows(base).items():
        other = new_rows.get(row_id)
        if other is None:
            continue
        for col in base["columns"]:
            key = col["key"]
            a = [s[key] for s in row["per_seed"] if key in s]
            b = [s[key] for s in other["per_seed"] if key in s]
            if len(a) != len(b) or not a:
                continue
            out.append(
                (row_id, col["label"], row["metrics"][key], other["metrics"][key], paired_seed_interval(b, a))
            )
    return out


def verdict_pairs(base: dict[str, Any], new: dict[str, Any]) -> list[tuple[str, str, str, str, str]]:
    """``(row, column, reference, base verdict, new verdict)`` for every comparison both runs made."""
    out = []
    new_rows = _rows(new)
    for row_id, row in _rows(base).items():
        other = new_rows.get(row_id, {}).get("comparisons", {})
        for key, refs in row.get("comparisons", {}).items():
            for ref, rec in refs.items():
                if ref in other.get(key, {}):
                    out.append((row_id, key, ref, rec["verdict"], other[key][ref]["verdict"]))
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("base", type=Path, help="results.json of the reference run")
    parser.add_argument("new", type=Path, help="results.json of the changed run")
    args = parser.parse_args()
    base, new = (json.loads(p.read_text()) for p in (args.base, args.new))
    _check_comparable(base, new)
    cells = cell_differences(base, new)
    print(f"{'row':5s} {'column':16s} {'base':>9s} {'new':>9s}  new − base [95 % paired t over seeds]")
    for row_id, label, a, b, iv in cells:
        flag = "" if iv.low <= 0 <= iv.high else "  ← differs"
        diff = f"{iv.estimate:+.3g} [{iv.low:+.3g}, {iv.high:+.3g}]"
        print(f"{row_id:5s} {label:16s} {a:9.3g} {b:9.3g}  {diff}{flag}")
    differing = sum(not (iv.low <= 0 <= iv.high) for *_, iv in cells)
    print(f"\n{differing} of {len(cells)} cells differ (interval of the difference excludes 0)")
    pairs = verdict_pairs(base, new)
    print(f"\n{'row':5s} {'column':24s} {'against':16s} {'base':20s} new")
    for row_id, key, ref, a, b in pairs:
        mark = "" if a == b else "  ← changed"
        print(f"{row_id:5s} {key:24s} {ref:16s} {a:20s} {b}{mark}")
    same = sum(a == b for *_, a, b in pairs)
    print(f"\n{same} of {len(pairs)} verdicts agree")


if __name__ == "__main__":
    main()
