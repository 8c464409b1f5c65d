"""Publish a recipe's results as a committed reproduction (``reproductions/<table>/``).

``nox -s reproduce`` runs every MoMu recipe at the ``cpu`` preset into one work folder and then calls
this module once per table::

    python -m momu.engine.reproduce WORK/TABLE reproductions/TABLE --command "python recipes/..."

It copies ``results.json`` / ``results.md`` / ``config.yaml`` and the plots, and writes a README
saying how the numbers were produced (command, wall time, peak memory, commit), how every row
compares with the calibration rows and with its own model given another clip's condition (with
95 % intervals and how many training seeds agree; :mod:`momu.engine.table_report`), and how many
distinguishable row pairs order as the paper's. A README without :data:`MARKER` on its first line
is hand-written: it is kept and the summary goes to ``REPRODUCE.md`` beside it. To bring a
published folder up to a changed verdict rule without retraining, use :mod:`momu.engine.republish`.
"""

from __future__ import annotations

import argparse
import json
import logging
import shutil
from pathlib import Path
from typing import Any

from momu.engine.table_report import (
    cells_caption,
    ordering_lines,
    size_line,
    stale_stage_lines,
    verdict_lines,
)
from momu.io import atomic_write_text

__all__ = ["MARKER", "publish", "readme_text"]

log = logging.getLogger(__name__)

MARKER = "<!-- written by `nox -s reproduce`; a README without this line is kept -->"
_COPIED = {".json", ".md", ".yaml", ".png"}


def readme_text(result: dict[str, Any], command: str) -> str:
    """The README of one reproduction (starts with :data:`MARKER`)."""
    prov = result["provenance"]
    lines = [
        MARKER,
        f"# {result['title']}",
        "",
        f"Produced by `nox -s reproduce` with `{command}`",
        f"(preset `{result['preset']}`, data `{result['data']}`, seeds {result['seeds']}).",
        "",
        f"- wall time: {prov['wall_time_s']:.0f} s on {prov['num_processes']} process(es), "
        f"device {prov['device']}",
        f"- peak memory (main process): {prov['peak_memory_mib']:.0f} MiB",
        f"- commit: `{prov['git_commit']}`",
        "",
        "`results.md` holds our rows and the calibration rows, then the paper's numbers in a table of",
        "their own; `results.json` the same with the resolved config, provenance, per-seed and per-clip",
        "values. The synthetic",
        "data stand in for the paper's datasets, so compare our rows with the calibration rows and",
        "with each other, not the absolute values with the paper's.",
        cells_caption(result),
        size_line(result),
        *verdict_lines(result),
        *ordering_lines(result),
        *stale_stage_lines(result),
    ]
    return "\n".join(lines) + "\n"


def publish(src: Path, dst: Path, command: str) -> Path:
    """Copy ``src``'s results and plots to ``dst`` and write its README; returns the README written."""
    results = src / "results.json"
    if not results.is_file():
        raise FileNotFoundError(f"{results}: no results.json (did the recipe finish?)")
    result = json.loads(results.read_text())
    dst.mkdir(parents=True, exist_ok=True)
    for path in src.iterdir():
        if path.is_file() and path.suffix in _COPIED:
            shutil.copy2(path, dst / path.name)
    plots = {f"beats-{plot.parent.name}.png": plot for plot in sorted((src / "models").glob("*/beats.png"))}
    for stale in dst.glob("beats-*.png"):  # plots of models an earlier run published
        if stale.name not in plots:
            stale.unlink()
    for name, plot in plots.items():
        shutil.copy2(plot, dst / name)
    readme = dst / "README.md"
    if readme.is_file() and not readme.read_text().startswith(MARKER):
        readme = dst / "REPRODUCE.md"  # keep a hand-written README; put the summary beside it
        log.warning("%s is hand-written: kept; summary in %s, check its numbers", dst / "README.md", readme)
    atomic_write_text(readme, readme_text(result, command))
    return readme


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description="Publish a recipe's results as reproductions/<table>/.")
    parser.add_argument("src", type=Path, help="the recipe's output folder (<out>/<table>)")
    parser.add_argument("dst", type=Path, help="reproductions/<table>")
    parser.add_argument("--command", required=True, help="the command that produced src (for the README)")
    args = parser.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(levelname)s %(message)s")
    log.info("wrote %s", publish(args.src, args.dst, args.command))


if __name__ == "__main__":
    main()
