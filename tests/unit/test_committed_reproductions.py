"""The committed ``reproductions/<table>/`` say what their own ``results.json`` says.

A reader trusts a reproduction's README and ``results.md`` for the verdicts ("beats shuffled",
"follows its condition", orderings against the paper). Both print them from ``results.json``
through :mod:`momu.engine.table_report`; this test fails when a verdict was edited by hand, or when
the verdict logic changed and the folders were not republished (``python -m momu.engine.reproduce``).
The hand-written notes below the verdicts are not checked here.
"""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest

from momu.engine.table_report import ordering_lines, verdict_lines

ROOT = Path(__file__).resolve().parents[2] / "reproductions"
FOLDERS = sorted(p.parent for p in ROOT.glob("*/results.json"))


def _result(folder: Path) -> dict:
    return json.loads((folder / "results.json").read_text())


def _section(text: str, heading: str) -> list[str]:
    """The bullet lines of ``## heading`` up to the next ``## `` heading."""
    found = re.search(rf"^## {re.escape(heading)}\n(.*?)(?=^## |\Z)", text, re.S | re.M)
    if found is None:
        return []
    return [line for line in found.group(1).splitlines() if line.lstrip().startswith("- ")]


def test_every_published_table_is_checked() -> None:
    assert len(FOLDERS) >= 16, FOLDERS  # MoMu 2-7, 10; MoFusion 4; HarmoGAN 5


@pytest.mark.parametrize("document", ["README.md", "results.md"])
@pytest.mark.parametrize("folder", FOLDERS, ids=lambda p: p.name)
def test_verdicts_and_orderings_are_exactly_those_of_its_results(folder: Path, document: str) -> None:
    result = _result(folder)
    text = (folder / document).read_text()
    verdicts = [x for x in verdict_lines(result) if x.lstrip().startswith("- ")]
    orderings = [x for x in ordering_lines(result) if x.lstrip().startswith("- ")]
    assert verdicts, "a committed table without verdicts"
    assert _section(text, "Verdicts") == verdicts
    assert _section(text, "Ordering of rows against the paper's") == orderings
