"""`python -m momu.engine.reproduce`: a recipe's results published as reproductions/<table>/."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from momu.engine.reproduce import MARKER, main, ordering_lines, publish, readme_text, row_verdicts


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


def test_rows_are_compared_with_the_shuffled_calibration_row() -> None:
    lines = row_verdicts(result())
    assert lines[0] == "- #1 a: F1↑ beats shuffled (60 vs 40); FID↓ does not beat shuffled (3 vs 1)"
    assert lines[1].startswith("- #2 b: F1↑ ties shuffled (40 vs 40)")


def test_ordering_counts_row_pairs_ordered_as_in_the_paper() -> None:
    lines = ordering_lines(result())
    # F1: ours #1 > #2, paper #1 < #2 -> 0/1; FID (lower better): ours #1 < #2, paper #1 > #2 -> 0/1
    assert "- F1↑: 0/1 row pairs ordered as in the paper; best row #1 here, #2 in the paper" in lines[3]
    assert lines[4].startswith("- FID↓: 0/1 row pairs")
    one_row = result()
    one_row["rows"] = one_row["rows"][:1]
    assert ordering_lines(one_row) == []


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
