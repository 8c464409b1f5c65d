"""The committed ``reproductions/<table>/`` say what their own ``results.json`` says.

A reader trusts a reproduction's README and ``results.md`` for the verdicts ("beats shuffled",
"follows its condition", orderings against the paper). Both print them from ``results.json``
through :mod:`momu.engine.table_report`; these tests fail when a verdict was edited by hand, when
the verdict logic changed and the folders were not republished (``python -m momu.engine.republish
reproductions/<table>``), or when any committed verdict rests on a comparison a training seed
disagrees with, a single value, too few clips or an interval of zero width (issue 33). The
hand-written notes below the verdicts are not checked here.
"""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest

from momu.engine.republish import recompute
from momu.engine.statistics import MIN_CLIPS, MIN_SEEDS
from momu.engine.table_report import ordering_lines, pairwise_lines, verdict_lines

ROOT = Path(__file__).resolve().parents[2] / "reproductions"
# the tables' results (rows × columns); the music-following collections (reproductions/which_models_follow,
# music_following_*) have their own layout, checked in tests/unit/test_following_table.py
FOLDERS = sorted(p.parent for p in ROOT.glob("*/results.json") if "columns" in json.loads(p.read_text()))


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


def _decided(result: dict) -> list[tuple[str, dict]]:
    """Every committed comparison and ordering pair that carries a verdict, with where it is."""
    out = []
    for row in result["rows"]:
        for key, by_variant in row.get("comparisons", {}).items():
            out += [
                (f"{row['id']} {key} vs {v}", rec)
                for v, rec in by_variant.items()
                if rec["verdict"] in ("better", "worse")
            ]
    for key, rec in result.get("orderings", {}).items():
        out += [(f"{key} {' − '.join(p['rows'])}", p) for p in rec["pairs"] if p["distinguishable"]]
    return out


@pytest.mark.parametrize("folder", FOLDERS, ids=lambda p: p.name)
def test_no_verdict_rests_on_a_disagreeing_seed_or_a_degenerate_interval(folder: Path) -> None:
    for where, rec in _decided(_result(folder)):
        seeds = len(rec["per_seed"])
        assert seeds >= MIN_SEEDS, f"{where}: a verdict on {seeds} seed(s)"
        assert rec["high"] > rec["low"], f"{where}: a verdict on a zero-width interval"
        assert rec["low"] > 0 or rec["high"] < 0, f"{where}: a verdict on an interval containing 0"
        assert rec.get("clips", MIN_CLIPS) >= MIN_CLIPS, f"{where}: a verdict on {rec['clips']} clips"
        if not rec.get("seed_independent", False):
            assert rec["seeds_agreeing"] == seeds, f"{where}: seeds disagree: {rec['per_seed']}"


@pytest.mark.parametrize("folder", FOLDERS, ids=lambda p: p.name)
def test_stored_verdicts_are_those_the_current_rule_gives(folder: Path) -> None:
    """``results.json`` was republished with the current statistics (no retraining needed)."""
    result = _result(folder)
    again = json.loads(json.dumps(recompute(result)))  # floats as stored
    for row, new in zip(result["rows"], again["rows"]):
        assert row["comparisons"] == new["comparisons"], f"{row['id']}: republish {folder}"
    assert result["orderings"] == again["orderings"], f"orderings: republish {folder}"


@pytest.mark.parametrize(
    "folder", [f for f in FOLDERS if (f / "pairwise.json").is_file()], ids=lambda p: p.name
)
def test_pairwise_comparisons_are_those_of_its_results(folder: Path) -> None:
    lines, pairs = pairwise_lines(_result(folder))
    assert json.loads((folder / "pairwise.json").read_text()) == json.loads(json.dumps(pairs))
    text = (folder / "results.md").read_text()
    assert text.rstrip("\n").endswith("\n".join(lines).rstrip("\n"))
