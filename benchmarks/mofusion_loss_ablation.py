"""Row-against-row intervals of MoFusion supp. Table 1: do the kinematic columns improve as losses are added?

The table runner compares each row with the calibration variants; this script pairs the *rows* with
each other, clip by clip on the same evaluation clips and pooled over seeds
(:func:`momu.engine.statistics.paired_bootstrap`, the statistic behind every verdict), for every
column with per-clip values. Rows #2–#4 share the generation length (the paper's 20 s), so their
differences isolate the training objective.

    python benchmarks/mofusion_loss_ablation.py OUT/mofusion_supp_table1/results.json
        [--pairs #3:#2 #4:#3 #4:#2]

Prints one line per pair and column: the difference (first − second) with its 95 % interval and
which row is better when the interval excludes 0.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np

from momu.engine.scores import ROW
from momu.engine.statistics import paired_bootstrap, verdict


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("results", type=Path)
    parser.add_argument("--pairs", nargs="+", default=["#3:#2", "#4:#3", "#4:#2"])
    args = parser.parse_args()
    result = json.loads(args.results.read_text())
    rows = {r["id"]: r for r in result["rows"]}
    for pair in args.pairs:
        a, b = pair.split(":")
        for col in result["columns"]:
            key = col["key"]
            ca = rows[a]["per_clip"].get(key, {}).get(ROW)
            cb = rows[b]["per_clip"].get(key, {}).get(ROW)
            if ca is None or cb is None or np.shape(ca) != np.shape(cb):
                continue
            iv = paired_bootstrap(np.asarray(ca), np.asarray(cb), reducer=col["reducer"])
            outcome = verdict(iv, col["higher_is_better"])
            reading = {"better": f"{a} better", "worse": f"{b} better"}.get(outcome, "not distinguishable")
            print(
                f"{a} − {b}  {col['label']}: {iv.estimate:+.4g} [{iv.low:+.4g}, {iv.high:+.4g}] "
                f"({iv.method}): {reading}"
            )


if __name__ == "__main__":
    main()
