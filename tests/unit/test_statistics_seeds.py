"""A verdict must survive another training seed (issue 33): constructed cases for the rule of
:func:`momu.engine.statistics.judge`, clip-identity pairing, the report and the republishing step."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from momu.engine.republish import main as republish_main
from momu.engine.republish import notes_of, recompute, replace_section, republish
from momu.engine.scores import ROW, Scores
from momu.engine.statistics import (
    MIN_CLIPS,
    judge,
    paired_bootstrap,
    paired_seed_interval,
    reduce_components,
)
from momu.engine.table import Column
from momu.engine.table_report import render_markdown, verdict_lines
from momu.engine.table_results import compare_row, orderings, summarise_seeds


def _seeds(
    effects: list[float], clips: int = 24, noise: float = 0.5, seed: int = 0, clip_seed: int = 0
) -> list[Scores]:
    """One Scores per training seed: the row scores ``effect`` above its shuffled calibration, on
    the clips ``clip_seed`` draws (the same for every seed), with noise drawn from ``seed``."""
    base = np.random.default_rng([clip_seed, 99]).uniform(20, 40, size=(clips, 1))
    rng = np.random.default_rng(seed)
    out = []
    for effect in effects:
        s = Scores(metrics={"x": float(base.mean() + effect)})
        s.add_clips("x", ROW, base + effect + rng.normal(0, noise, size=(clips, 1)))
        s.add_clips("x", "shuffled", base)
        out.append(s)
    return out


COLUMN = Column("x", "X↑", True)


def test_one_reversing_seed_gives_no_verdict_although_the_clip_interval_excludes_0() -> None:
    summary = summarise_seeds(_seeds([6.0, 5.0, -1.0]))
    row, other = np.asarray(summary["per_clip"]["x"][ROW]), np.asarray(summary["per_clip"]["x"]["shuffled"])
    interval = paired_bootstrap(row, other)
    assert interval.low > 0  # what the clip-level bootstrap alone would call "beats shuffled"
    per_seed = reduce_components(row, "mean") - reduce_components(other, "mean")
    said = judge(interval, per_seed, True)
    assert said.outcome == "not distinguishable" and said.seeds_agreeing == 2
    assert said.reason == "1 of 3 seeds disagree in sign"
    rec = compare_row(summary, [COLUMN])["x"]["shuffled"]
    assert rec["verdict"] == "not distinguishable" and rec["seeds_agreeing"] == 2
    assert rec["per_seed"] == pytest.approx(per_seed.tolist())
    line = next(x for x in verdict_lines(_result(summary)) if x.startswith("  - X↑"))
    assert "not distinguishable from shuffled" in line and "seeds disagree: +" in line


def test_every_seed_agreeing_and_an_interval_excluding_0_give_a_verdict() -> None:
    rec = compare_row(summarise_seeds(_seeds([6.0, 5.0, 4.0])), [COLUMN])["x"]["shuffled"]
    assert rec["verdict"] == "better" and rec["seeds_agreeing"] == 3 and rec["reason"] == ""
    assert rec["low"] > 0 and rec["clips"] == 24 and len(rec["per_seed_interval"]) == 2


def test_a_zero_width_interval_cannot_tell() -> None:
    # a seed-level comparison whose two sides do not depend on the seed: one value, three times
    interval = paired_seed_interval([1.7e-12] * 3, [0.164] * 3)
    said = judge(interval, [1.7e-12 - 0.164] * 3, False)
    assert said.outcome == "cannot tell" and said.reason == "the same value for every seed"
    assert said.seed_independent


def test_a_single_value_cannot_tell() -> None:
    interval = paired_seed_interval([0.5225], [0.5])  # n = 1
    assert judge(interval, [0.0225], True).outcome == "cannot tell"
    rec = compare_row(summarise_seeds(_seeds([9.0])), [COLUMN])["x"]["shuffled"]
    assert rec["verdict"] == "cannot tell" and rec["reason"] == "one training seed"


def test_fewer_clips_than_the_minimum_cannot_tell() -> None:
    few = compare_row(summarise_seeds(_seeds([6.0, 5.0, 4.0], clips=MIN_CLIPS - 1)), [COLUMN])["x"]
    assert few["shuffled"]["verdict"] == "cannot tell"
    assert few["shuffled"]["reason"] == f"{MIN_CLIPS - 1} clips, fewer than {MIN_CLIPS}"
    enough = compare_row(summarise_seeds(_seeds([6.0, 5.0, 4.0], clips=MIN_CLIPS)), [COLUMN])["x"]
    assert enough["shuffled"]["verdict"] == "better"


def test_a_seed_independent_difference_is_decided_by_its_clip_interval() -> None:
    """Ground truth against shuffled ground truth: nothing trained, every seed's difference the same."""
    seeds = []
    rng = np.random.default_rng(3)
    base = rng.uniform(20, 40, size=(16, 1))
    shifted = base + 3.0 + rng.normal(0, 0.5, size=(16, 1))
    for _ in range(3):
        s = Scores(metrics={"x": float(shifted.mean())})
        s.add_clips("x", ROW, shifted)
        s.add_clips("x", "shuffled", base)
        seeds.append(s)
    rec = compare_row(summarise_seeds(seeds), [COLUMN])["x"]["shuffled"]
    assert rec["verdict"] == "better" and rec["seed_independent"]
    line = next(x for x in verdict_lines(_result(summarise_seeds(seeds))) if x.startswith("  - X↑"))
    assert "the same for every seed" in line


def test_clip_ids_that_differ_are_an_error_where_clips_are_paired() -> None:
    a, b = np.ones((3, 10, 1)), np.zeros((3, 10, 1))
    ids = [f"clip{i}" for i in range(10)]
    with pytest.raises(ValueError, match="different clips"):
        paired_bootstrap(a, b, row_ids=ids, other_ids=ids[::-1])
    with pytest.raises(ValueError, match="one side only"):
        paired_bootstrap(a, b, row_ids=ids)
    assert paired_bootstrap(a, b, row_ids=ids, other_ids=list(ids)).estimate == 1.0
    s = Scores(metrics={})
    s.add_clips("x", ROW, np.zeros((10, 1)), ids=ids)
    with pytest.raises(ValueError, match="other clips than before"):
        s.add_clips("x", "shuffled", np.zeros((10, 1)), ids=ids[::-1])
    with pytest.raises(ValueError, match="9 ids for 10 clips"):
        s.add_clips("y", ROW, np.zeros((10, 1)), ids=ids[:9])
    assert Scores.from_json(s.to_json()).clip_ids == {"x": ids}


def _row(
    rid: str, effects: list[float], ids: list[str] | None, paper: float, seed: int = 0, clip_seed: int = 0
) -> dict:
    seeds = _seeds(effects, clips=len(ids) if ids else 24, seed=seed, clip_seed=clip_seed)
    for s in seeds:
        if ids is not None:
            s.clip_ids["x"] = list(ids)
    return {"id": rid, "name": rid, "paper": {"x": paper}, **summarise_seeds(seeds)}


def test_rows_are_paired_by_clip_identity_not_by_shape() -> None:
    ids = [f"c{i}" for i in range(24)]
    same = orderings([_row("#1", [6, 5, 4], ids, 2.0), _row("#2", [0, 0, 0], ids, 1.0, seed=1)], [COLUMN])
    assert same["x"]["pairs"][0]["pairing"] == "per clip (clip ids)"
    other = [f"d{i}" for i in range(24)]  # same shape, other clips: not paired per clip
    moved = orderings([_row("#1", [6, 5, 4], ids, 2.0), _row("#2", [0, 0, 0], other, 1.0)], [COLUMN])
    assert moved["x"]["pairs"][0]["pairing"] == "per seed (the rows' clip ids differ)"
    assert moved["x"]["other_clips"] == 1
    with pytest.raises(ValueError, match="has clip ids and row #2 has none"):
        orderings([_row("#1", [6, 5, 4], ids, 2.0), _row("#2", [0, 0, 0], None, 1.0)], [COLUMN])


def test_rows_without_clip_ids_are_paired_by_index_only_where_their_clips_agree() -> None:
    # without ids, the rows' shuffled calibrations (values of the clips alone) must agree clip by clip
    rows = [_row("#1", [6, 5, 4], None, 2.0, seed=0), _row("#2", [0, 0, 0], None, 1.0, seed=1)]
    assert orderings(rows, [COLUMN])["x"]["pairs"][0]["pairing"].startswith("per clip (index order")
    rows[1] = _row("#2", [0, 0, 0], None, 1.0, seed=1, clip_seed=1)  # other clips, same shape
    assert orderings(rows, [COLUMN])["x"]["pairs"][0]["pairing"] == (
        "per seed (the rows' shuffled values differ: not the same clips)"
    )


def test_an_ordering_records_per_seed_differences_and_counts_reversing_seeds() -> None:
    ids = [f"c{i}" for i in range(24)]
    rows = [_row("#3", [6.0, 5.0, -1.0], ids, 1.0, seed=0), _row("#7", [0.0, 0.0, 0.0], ids, 2.0, seed=1)]
    rec = orderings(rows, [COLUMN])["x"]
    pair = rec["pairs"][0]
    assert pair["low"] > 0 and not pair["distinguishable"] and pair["seeds_agreeing"] == 2
    assert pair["per_seed"][2] < 0 < pair["per_seed"][0]
    assert (rec["distinguishable"], rec["seeds_disagree"]) == (0, 1)


def _result(summary: dict, seeds: list[int] | None = None) -> dict:
    row = {"id": "#1", "name": "row", "paper": {"x": 50.0}, **summary}
    row["comparisons"] = compare_row(summary, [COLUMN])
    return {
        "title": "T",
        "preset": "cpu",
        "data": "synth",
        "seeds": seeds or list(range(len(summary["per_seed"]))),
        "columns": [{"key": "x", "label": "X↑", "higher_is_better": True, "reducer": "mean"}],
        "rows": [row],
        "calibration": [{"name": "ground truth", "metrics": {"x": 100.0}, "interval": {}}],
        "baselines": [{"name": "Other method", "paper": {"x": 40.0}, "re_run": False}],
        "orderings": {},
        "provenance": {
            "num_processes": 1,
            "device": "cpu",
            "wall_time_s": 1.0,
            "git_commit": "abc",
            "versions": {},
            "plugins": {},
            "peak_memory_mib": 1.0,
            "stages": {},
        },
    }


def test_results_md_puts_our_rows_then_calibration_then_the_paper_on_another_scale() -> None:
    text = render_markdown(_result(summarise_seeds(_seeds([6.0, 5.0, 4.0]))))
    ours, cal, paper = text.index("| #1 | row |"), text.index("| cal | ground truth"), text.index("| paper |")
    assert ours < cal < text.index("## The paper's numbers (another scale)") < paper
    assert "| #1 | row | 50 |" in text  # the paper's cell of our row, in the paper's table only


def test_a_single_seed_result_prints_no_interval() -> None:
    text = render_markdown(_result(summarise_seeds(_seeds([9.0])), seeds=[0]))
    assert "no interval over seeds" in text and "±" not in text
    verdicts = text[text.index("## Verdicts") :]
    line = next(x for x in verdicts.splitlines() if x.startswith("  - X↑"))
    assert line.startswith("  - X↑: cannot tell against shuffled (one training seed; difference +")
    assert "[" not in line


def test_republish_recomputes_verdicts_and_keeps_hand_written_text(tmp_path: Path) -> None:
    summary = summarise_seeds(_seeds([6.0, 5.0, -1.0]))
    result = _result(summary)
    result["rows"][0]["comparisons"]["x"]["shuffled"]["verdict"] = "better"  # as the old rule said
    folder = tmp_path / "table"
    folder.mkdir()
    (folder / "results.json").write_text(json.dumps(result))
    (folder / "results.md").write_text("# T\n\n## Notes\n\n- a note\n\n## Provenance\n")
    (folder / "README.md").write_text(
        "# T\n\nCells: old caption\n\n## Verdicts\n\n- #1 row:\n  - X↑: beats shuffled\n\n"
        "## Reading (hand-written)\n\n- kept as written\n"
    )
    republish(folder)
    stored = json.loads((folder / "results.json").read_text())
    assert stored["rows"][0]["comparisons"]["x"]["shuffled"]["verdict"] == "not distinguishable"
    assert stored == json.loads(json.dumps(recompute(result)))
    readme = (folder / "README.md").read_text()
    assert "beats shuffled" not in readme and "seeds disagree" in readme
    assert "Cells: mean over the 3 training seeds" in readme and readme.endswith("- kept as written\n")
    assert notes_of((folder / "results.md").read_text()) == ["a note"]


def test_replace_section_inserts_replaces_and_removes() -> None:
    text = "# T\n\n## A\n\nold\n\n## C\n\nc\n"
    assert replace_section(text, "A", ["## A", "", "new"]) == "# T\n\n## A\n\nnew\n\n## C\n\nc\n"
    assert replace_section(text, "B", ["## B", "", "b"], after="A") == (
        "# T\n\n## A\n\nold\n\n## B\n\nb\n\n## C\n\nc\n"
    )
    assert replace_section(text, "A", []) == "# T\n\n## C\n\nc\n"


def test_republish_of_a_folder_without_results_fails_before_writing(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    good = tmp_path / "good"
    good.mkdir()
    (good / "results.json").write_text("{}")
    assert republish_main([str(good), str(tmp_path / "missing")]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "missing/results.json: no such file" in err[0]
    assert (good / "results.json").read_text() == "{}"
