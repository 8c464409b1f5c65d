"""Recompute a committed reproduction's verdicts from its stored values, without retraining.

``results.json`` keeps every row's per-seed cells (``rows[].per_seed``), per-clip components
(``rows[].per_clip``) and seed-level comparison values (``rows[].seed_values``). When the rule of a
verdict changes (:mod:`momu.engine.statistics`), this module brings a published folder up to it::

    python -m momu.engine.republish reproductions/momu_table7 [reproductions/... ...]

For each folder it recomputes every row's comparisons and the orderings
(:func:`~momu.engine.table_results.compare_row`, :func:`~momu.engine.table_results.orderings`) and
rewrites

* ``results.json`` — the same values with the new ``comparisons`` and ``orderings``;
* ``results.md`` — rendered again (:func:`~momu.engine.table_report.render_markdown`) with the notes
  of the one it replaces, plus HarmoGAN's pairwise section and ``pairwise.json`` where the folder
  has one (:func:`~momu.engine.table_report.pairwise_lines`);
* ``README.md`` (and ``REPRODUCE.md`` where present) — only the generated parts: the ``Cells:``
  caption and the "Verdicts" and "Ordering of rows against the paper's" sections. Hand-written
  reading around them is kept as it is, and has to be checked by hand against the new verdicts.

Cells and per-seed values are not touched: nothing is retrained or re-evaluated.
"""

from __future__ import annotations

import json
import logging
import re
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from momu.engine.table_report import (
    BASELINE_HEADING,
    baseline_lines,
    cells_caption,
    ordering_lines,
    pairwise_lines,
    render_markdown,
    verdict_lines,
)
from momu.engine.table_results import columns_from_json, compare_row, orderings, versus_baseline
from momu.errors import UsageParser, fail
from momu.io import atomic_write_text, write_json

__all__ = ["recompute", "replace_section", "notes_of", "republish", "main"]

log = logging.getLogger(__name__)

VERDICTS = "Verdicts"
ORDERING = "Ordering of rows against the paper's"
PAIRWISE = "Pairwise comparisons of our rows"


def recompute(result: dict[str, Any], bootstrap_seed: int = 0) -> dict[str, Any]:
    """``result`` with every row's ``comparisons`` and the ``orderings`` recomputed from its stored values."""
    columns = columns_from_json(result)
    seed = int(result.get("bootstrap_seed", bootstrap_seed))
    rows = [{**row, "comparisons": compare_row(row, columns, bootstrap_seed=seed)} for row in result["rows"]]
    out = {**result, "rows": rows, "orderings": orderings(rows, columns, bootstrap_seed=seed)}
    if "versus_baseline" in result:
        base = str(result["versus_baseline"]["row"])
        out["versus_baseline"] = versus_baseline(rows, columns, base, bootstrap_seed=seed)
    return out


def _section_span(lines: Sequence[str], heading: str) -> tuple[int, int] | None:
    """``[start, end)`` of the ``## heading`` section: its heading to the next ``## `` heading."""
    try:
        start = lines.index(f"## {heading}")
    except ValueError:
        return None
    end = next((i for i in range(start + 1, len(lines)) if lines[i].startswith("## ")), len(lines))
    return start, end


def replace_section(text: str, heading: str, new: Sequence[str], after: str | None = None) -> str:
    """``text`` with its ``## heading`` section replaced by ``new`` (lines starting at that heading).

    An empty ``new`` removes the section; a section ``text`` lacks is inserted after the ``## after``
    section (or appended).
    """
    lines = text.rstrip("\n").split("\n")
    block = [*new, ""] if new else []
    span = _section_span(lines, heading)
    if span is None:
        if not new:
            return text
        anchor = _section_span(lines, after) if after else None
        at = anchor[1] if anchor else len(lines)
        if at == len(lines) and lines[-1] != "":
            block = ["", *block]
        lines[at:at] = block
    else:
        lines[span[0] : span[1]] = block
    return "\n".join(lines).rstrip("\n") + "\n"


def _generated(lines: list[str]) -> list[str]:
    """Generated section lines without their leading blank line."""
    return lines[1:] if lines and lines[0] == "" else lines


def notes_of(markdown: str) -> list[str]:
    """The bullet lines of a ``results.md``'s "Notes" section, without their ``- ``."""
    lines = markdown.split("\n")
    span = _section_span(lines, "Notes")
    if span is None:
        return []
    return [line[2:] for line in lines[span[0] + 1 : span[1]] if line.startswith("- ")]


def _readme(text: str, result: dict[str, Any]) -> str:
    """A README with its generated parts (caption, verdicts, ordering) brought up to ``result``."""
    caption = cells_caption(result)
    text = re.sub(r"^Cells: .*$", lambda _: caption, text, count=1, flags=re.M)
    text = replace_section(text, VERDICTS, _generated(verdict_lines(result)))
    text = replace_section(text, BASELINE_HEADING, _generated(baseline_lines(result)), after=VERDICTS)
    return replace_section(text, ORDERING, _generated(ordering_lines(result)), after=VERDICTS)


def republish(folder: Path) -> list[Path]:
    """Recompute ``folder``'s verdicts from its ``results.json`` and rewrite its files; returns them."""
    path = folder / "results.json"
    result = recompute(json.loads(path.read_text(encoding="utf-8")))
    written = [write_json(path, result)]
    md_path = folder / "results.md"
    notes = notes_of(md_path.read_text(encoding="utf-8")) if md_path.is_file() else []
    markdown = render_markdown(result, notes)
    if (folder / "pairwise.json").is_file():
        lines, pairs = pairwise_lines(result)
        written.append(write_json(folder / "pairwise.json", pairs))
        markdown = markdown.rstrip("\n") + "\n" + "\n".join(lines) + "\n"
    written.append(atomic_write_text(md_path, markdown))
    for name in ("README.md", "REPRODUCE.md"):
        readme = folder / name
        if readme.is_file():
            written.append(atomic_write_text(readme, _readme(readme.read_text(encoding="utf-8"), result)))
    return written


def main(argv: list[str] | None = None) -> int:
    parser = UsageParser(
        prog="python -m momu.engine.republish",
        description="Recompute the verdicts of published reproductions from their stored values.",
    )
    parser.add_argument("folders", type=Path, nargs="+", help="reproductions/<table> folders")
    args = parser.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(levelname)s %(message)s")
    missing = [f for f in args.folders if not (f / "results.json").is_file()]
    if missing:  # every folder is checked before any is rewritten
        return fail(parser.prog, f"{missing[0] / 'results.json'}: no such file (not a published table)")
    for folder in args.folders:
        for path in republish(folder):
            log.info("wrote %s", path)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
