"""`python -m momu.engine.reproduce`: a recipe's results published as reproductions/<table>/."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from momu.engine.reproduce import MARKER, main, publish, readme_text
from momu.engine.table_report import ordering_lines, verdict_lines


def result() -> dict:
    columns = [
        {"key": "f1", "label": "F1↑", "higher_is_better": True},
        {"key": "fid", "label": "FID↓", "higher_is_better": False},
    ]
    rows = [
        {"id": "#1", "name": "a", "metrics": {"f1": 60.0, "fid": 3.0}, "paper": {"f1": 90.0, "fid": 9.0}},
        {"id": "#2", "name": "b", "metrics": {"f1": 40.0, "fid": 5.0}, "paper": {"f1": 95.0, "fid": 8.0}},
    ]
    calibration = [
        {"name": "ground truth", "metrics": {"f1": 100.0, "fid": 1.0}},
        {"name": "ground truth, shuffled", "metrics": {"f1": 40.0, "fid": 1.0}},
    ]
    provenance = {
        "wall_time_s": 61.2,
        "num_processes": 1,
        "device": "cpu",
        "peak_memory_mib": 512.4,
        "git_commit": "abc",
    }
    return {
        "title": "Table X",
        "preset": "cpu",
        "data": "synth",
        "seeds": [0],
        "columns": columns,
        "rows": rows,
        "calibration": calibration,
        "provenance": provenance,
    }


def _comparison(estimate: float, low: float, high: float, verdict: str) -> dict:
    return {
        "estimate": estimate,
        "low": low,
        "high": high,
        "n": 60,
        "method": "m",
        "verdict": verdict,
        "per_seed": [estimate] * 3,
        "seeds_agreeing": 3,
    }


def test_verdict_lines_name_the_interval_and_never_claim_within_noise() -> None:
    res = result()
    res["rows"][0]["comparisons"] = {
        "f1": {
            "shuffled": _comparison(20.0, 12.5, 27.0, "better"),
            "other condition": _comparison(1.0, -2.0, 4.0, "not distinguishable"),
        }
    }
    lines = verdict_lines(res)
    assert "- #1 a:" in lines
    line = next(x for x in lines if x.startswith("  - F1↑"))
    assert line == (
        "  - F1↑: beats shuffled (+20 [+12.5, +27], 3/3 seeds); "
        "does not follow its condition (not distinguishable) (+1 [-2, +4], 3/3 seeds)"
    )
    assert verdict_lines(result()) == []  # no comparisons, no verdicts


def test_ordering_lines_count_distinguishable_pairs_only() -> None:
    res = result()
    res["orderings"] = {
        "f1": {"pairs": [], "total": 1, "distinguishable": 1, "agree": 0},
        "fid": {"pairs": [], "total": 1, "distinguishable": 0, "agree": 0},
    }
    lines = ordering_lines(res)
    assert "- F1↑: 1 of 1 row pairs distinguishable; 0 of those 1 ordered as in the paper" in lines
    assert "- FID↓: 0 of 1 row pairs distinguishable" in lines
    assert ordering_lines(result()) == []


def test_publish_copies_results_and_keeps_a_hand_written_readme(tmp_path: Path) -> None:
    src, dst = tmp_path / "out" / "table", tmp_path / "reproductions" / "table"
    (src / "models" / "row1").mkdir(parents=True)
    (src / "results.json").write_text(json.dumps(result()))
    (src / "results.md").write_text("| table |")
    (src / "models" / "row1" / "beats.png").write_bytes(b"png")
    (src / "scratch.pt").write_bytes(b"not copied")
    readme = publish(src, dst, "python recipes/x.py")
    assert readme == dst / "README.md"
    text = readme.read_text()
    assert (
        text.startswith(MARKER)
        and "wall time: 61 s" in text
        and "peak memory (main process): 512 MiB" in text
    )
    assert text == readme_text(result(), "python recipes/x.py")
    assert {p.name for p in dst.iterdir()} == {"results.json", "results.md", "beats-row1.png", "README.md"}
    # a README a person wrote is kept; the summary goes beside it
    readme.write_text("# hand-written\n")
    assert publish(src, dst, "python recipes/x.py") == dst / "REPRODUCE.md"
    assert readme.read_text() == "# hand-written\n"


def test_publish_removes_plots_of_models_no_longer_in_the_run(tmp_path: Path) -> None:
    src, dst = tmp_path / "out" / "table", tmp_path / "reproductions" / "table"
    (src / "models" / "new").mkdir(parents=True)
    (src / "results.json").write_text(json.dumps(result()))
    (src / "models" / "new" / "beats.png").write_bytes(b"png")
    dst.mkdir(parents=True)
    (dst / "beats-old.png").write_bytes(b"stale")
    (dst / "figure.png").write_bytes(b"other plots are not touched")
    publish(src, dst, "python recipes/x.py")
    assert {p.name for p in dst.glob("*.png")} == {"beats-new.png", "figure.png"}


def test_missing_results_is_a_clear_error(tmp_path: Path) -> None:
    with pytest.raises(FileNotFoundError, match="results.json"):
        main([str(tmp_path), str(tmp_path / "dst"), "--command", "x"])
    assert not (tmp_path / "dst").exists()
