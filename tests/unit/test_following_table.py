"""The "which models follow" collector (``momu.following.table``): every cell is the run's own."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

from momu.following.checks import TESTS
from momu.following.table import SHORT_TITLES, collect, main, markdown

# adjacent tests never share a verdict and every estimate differs: a cell copied from the wrong test,
# the wrong row or the raw (ungated) verdict shows up
GENERATOR_VERDICTS = (
    "passes",
    "fails",
    "cannot tell",
    "no verdict: ground truth does not pass here",
    "fails",
    "no verdict: shuffled passes too",
    "passes",
)
GT_RAW = ("passes", "passes", "passes", "cannot tell", "fails", "passes", "cannot tell")


def _test(estimate: float, verdict: str, raw: str) -> dict[str, Any]:
    return {
        "estimate": estimate,
        "low": estimate - 0.05,
        "high": estimate + 0.05,
        "songs": 3,
        "seeds": 2,
        "per_song_seed": [[estimate]],
        "raw_verdict": raw,
        "verdict": verdict,
    }


def _direction(direction: str, offset: float, model: str) -> dict[str, Any]:
    gt = {
        "id": "ground_truth",
        "kind": "calibration",
        "tests": {t: _test(1.0 + i / 10, GT_RAW[i], GT_RAW[i]) for i, t in enumerate(TESTS)},
    }
    shuffled = {
        "id": "shuffled",
        "kind": "calibration",
        "tests": {t: _test(-5.0, "fails", "fails") for t in TESTS},
    }
    gen = {
        "id": model,
        "kind": "generator",
        # the raw verdict always differs from the gated one
        "tests": {
            t: _test(offset + i / 100, GENERATOR_VERDICTS[i], "raw-" + GENERATOR_VERDICTS[i])
            for i, t in enumerate(TESTS)
        },
    }
    if direction == "dance":
        gen["realism"] = {"foot_speed": {**_test(0.061, "fails", "fails"), "real_p5": 0.2, "real_p95": 0.5}}
    return {
        "direction": direction,
        "rows": [gt, shuffled, gen],
        "ground_truth_passes": [t for t, v in zip(TESTS, GT_RAW) if v == "passes"],
        "reference_realism": (
            {"foot_speed": {"p5": 0.2, "p95": 0.5, "median": 0.3, "windows": 9}}
            if direction == "dance"
            else {}
        ),
    }


def _results(model: str, offset: float, skeleton: str = "dwm21", directions=("dance", "music")) -> dict:
    return {
        "benchmark": "music_following",
        "data": "synth_dance (val split)",
        "settings": {
            "generator": f"/models/{model}",
            "split": "val",
            "songs": 3,
            "seconds": 10.0,
            "seeds": "0 1",
        },
        "dataset": {"name": "synth_dance", "skeleton": skeleton, "split": "val"},
        "directions": {d: _direction(d, offset + k, model) for k, d in enumerate(directions)},
        "provenance": {
            "command": ["python", "recipes/music_following.py"],
            "git_commit": "abc",
            "wall_time_s": 12.5,
        },
    }


def _md_row(md: str, label: str, direction: str) -> list[str]:
    for line in md.splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) > 2 and cells[0] == label and cells[1] == direction:
            return cells
    raise AssertionError(f"no row {label} / {direction} in the table")


def test_every_cell_is_the_runs_own_gated_verdict_and_interval():
    table = collect(
        [("a.json", _results("momu:m1", 0.2)), ("b.json", _results("mofusion:m2", 0.5, "smpl24"))]
    )
    md = markdown(table)
    header = _md_row(md, "model", "direction")
    columns = {t: header.index(SHORT_TITLES[t]) for t in TESTS}
    checked = 0
    for name, res in (
        ("momu:m1", _results("momu:m1", 0.2)),
        ("mofusion:m2", _results("mofusion:m2", 0.5, "smpl24")),
    ):
        for direction, title in (("dance", "music → dance"), ("music", "dance → music")):
            src = next(r for r in res["directions"][direction]["rows"] if r["id"] == name)
            group = next(
                g
                for g in table["groups"]
                if g["direction"] == direction and any(r["id"] == name for r in g["rows"])
            )
            row = next(r for r in group["rows"] if r["id"] == name)
            cells = _md_row(md, name, title)
            for t in TESTS:
                want = src["tests"][t]
                got = row["tests"][t]
                assert (got["estimate"], got["low"], got["high"], got["verdict"]) == (
                    want["estimate"],
                    want["low"],
                    want["high"],
                    want["verdict"],
                ), (name, direction, t)
                text = cells[columns[t]]
                assert text.startswith(f"{want['estimate']:.3f} [{want['low']:.3f}, {want['high']:.3f}]"), (
                    text
                )
                assert text.endswith(f"{want['verdict']}*") or text.endswith(f"{want['verdict']}**"), text
                assert "raw-" not in text
                checked += 1
    assert checked == 2 * 2 * len(TESTS)


def test_ground_truth_row_and_the_tests_it_passes_head_each_data_and_direction():
    same_data = [
        ("a.json", _results("momu:m1", 0.2)),
        ("c.json", _results("harmogan:m3", 0.7, directions=("dance",))),
    ]
    table = collect([*same_data, ("b.json", _results("mofusion:m2", 0.5, "smpl24", ("dance",)))])
    # the two dwm21 runs share one group per direction; the smpl24 run has its own
    kinds = [(g["direction"], [r["label"] for r in g["rows"]]) for g in table["groups"]]
    assert kinds == [
        ("dance", ["ground truth", "momu:m1", "harmogan:m3"]),
        ("music", ["ground truth", "momu:m1"]),
        ("dance", ["ground truth", "mofusion:m2"]),
    ]
    md = markdown(table)
    gt_cells = _md_row(md, "*ground truth*", "music → dance")
    assert gt_cells[-1] == "input sensitivity, tempo following, tempo match, matched (BAS Bailando)"
    for i, t in enumerate(TESTS):  # ground truth shows its raw verdicts
        assert table["groups"][0]["rows"][0]["tests"][t]["verdict"] == GT_RAW[i]
    assert "| shuffled |" not in md and "| *shuffled* |" not in md
    assert "| harmogan:m3 |" in md and "0.061 [0.011, 0.111] **fails**" in md  # realism table


def test_labels_rename_generator_rows(tmp_path: Path):
    src = tmp_path / "r.json"
    src.write_text(json.dumps(_results("momu:m1", 0.2)))
    assert main([str(src), "--out", str(tmp_path / "t"), "--label", "momu:m1=MoMu Table 7 #7"]) == 0
    md = (tmp_path / "t" / "results.md").read_text()
    assert "| MoMu Table 7 #7 | music → dance |" in md
    assert json.loads((tmp_path / "t" / "results.json").read_text())["groups"][0]["rows"][1]["label"] == (
        "MoMu Table 7 #7"
    )


def test_training_seeds_put_each_seeds_verdicts_side_by_side(tmp_path: Path):
    seeds = [_results(f"momu:s{k}", 0.2 + k) for k in range(3)]
    for direction in ("dance", "music"):  # seed 2 fails input sensitivity where seeds 0 and 1 pass it
        seeds[2]["directions"][direction]["rows"][2]["tests"]["input_sensitivity"]["verdict"] = "fails"
    sources = []
    for k, res in enumerate(seeds):
        sources.append(tmp_path / f"s{k}.json")
        sources[-1].write_text(json.dumps(res))
    other = tmp_path / "other.json"
    other.write_text(json.dumps(_results("mofusion:m2", 0.5, "smpl24", ("dance",))))
    spec = ["--training-seeds", "MoMu #7=momu:s0,momu:s1,momu:s2", "--label", "momu:s1=seed one"]
    assert main([*map(str, sources), str(other), "--out", str(tmp_path / "t"), *spec]) == 0
    records = json.loads((tmp_path / "t" / "results.json").read_text())["across_training_seeds"]
    assert [(r["recipe"], r["direction"]) for r in records] == [("MoMu #7", "dance"), ("MoMu #7", "music")]
    for rec in records:
        assert rec["models"] == ["momu:s0", "seed one", "momu:s2"]
        assert rec["tests"]["input_sensitivity"] == ["passes", "passes", "fails"]
        assert rec["tests"]["tempo_following"] == ["fails"] * 3
        assert rec["follows"] == [False] * 3  # tempo following fails at every seed
        assert rec["holds"] is False
    md = (tmp_path / "t" / "results.md").read_text()
    row = _md_row(md.split("## Across training seeds")[1], "MoMu #7", "music → dance")
    assert row[4:6] == ["passes / passes / fails", "fails / fails / fails"]
    assert row[-2:] == ["no / no / no", "**no**"]
    # a recipe whose seeds agree holds; a table without --training-seeds has no such section
    table = collect(
        [(str(p), json.loads(p.read_text())) for p in sources[:2]], None, {"r": ["momu:s0", "momu:s1"]}
    )
    assert all(rec["holds"] is True for rec in table["across_training_seeds"])
    assert "Across training seeds" not in markdown(collect([(str(other), json.loads(other.read_text()))]))


@pytest.mark.parametrize(
    ("content", "extra", "message"),
    [
        (None, [], "file not found"),
        ("{not json", [], "not readable JSON"),
        ('{"benchmark": "momu_table7"}', [], "not a results.json of recipes/music_following.py"),
        (
            '{"benchmark": "music_following", "directions": {"dance": {"rows": []}}}',
            [],
            "no ground_truth row",
        ),
        (json.dumps(_results("momu:m1", 0.2)), ["--label", "momu:m1"], "expected ROW_ID=NAME"),
        (json.dumps(_results("momu:m1", 0.2)), ["--training-seeds", "r=momu:m1"], "expected NAME=ROW_ID"),
        (
            json.dumps(_results("momu:m1", 0.2)),
            ["--training-seeds", "r=momu:m1,momu:absent"],
            "no generator row 'momu:absent'",
        ),
    ],
)
def test_bad_input_is_one_line_exit_2_and_writes_nothing(tmp_path: Path, capsys, content, extra, message):
    src = tmp_path / "r.json"
    if content is not None:
        src.write_text(content)
    out = tmp_path / "t"
    assert main([str(src), "--out", str(out), *extra]) == 2
    err = capsys.readouterr().err
    assert err.startswith("which_models_follow: error: ") and message in err and err.count("\n") == 1
    assert not out.exists()
