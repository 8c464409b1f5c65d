"""MoMu recipes at ``--preset smoke``: Table 7 on one and on two processes (gloo on CPU), Table 10."""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
from pathlib import Path

import pytest
from tests.helpers.launch import accelerate_launch

ROOT = Path(__file__).resolve().parents[2]
ENV = {**os.environ, "OMP_NUM_THREADS": "1", "WANDB_MODE": "disabled", "PYTHONHASHSEED": "0"}
TABLE7_ROWS = ["#1", "#2", "#3", "#4", "#5", "#6", "#7"]
COLUMNS = ["music_fad", "music_f1", "motion_fid", "motion_f1"]


def _launch(recipe: str, out: Path, *, processes: int = 1, extra: tuple[str, ...] = ()) -> dict:
    args = ("--preset", "smoke", "--out", str(out), "--tracker", "none", *extra)
    cmd = accelerate_launch(ROOT / "recipes" / recipe, *args, processes=processes)
    proc = subprocess.run(cmd, capture_output=True, text=True, env=ENV, timeout=600, cwd=ROOT)
    assert proc.returncode == 0, proc.stderr[-4000:]
    return json.loads((out / recipe.removesuffix(".py") / "results.json").read_text())


def _check_complete(result: dict, rows: list[str]) -> None:
    assert [r["id"] for r in result["rows"]] == rows
    for row in result["rows"]:
        for key in COLUMNS:
            assert math.isfinite(row["metrics"][key]), (row["id"], key)
        assert row["paper"], row["id"]
    names = [c["name"] for c in result["calibration"]]
    assert names == ["ground truth", "ground truth, music and motion shuffled"]
    for cal in result["calibration"]:
        assert all(math.isfinite(cal["metrics"][k]) for k in COLUMNS)
    assert result["calibration"][0]["metrics"]["music_f1"] == pytest.approx(100.0)  # GT vs itself


def test_table7_smoke_single_process(tmp_path: Path) -> None:
    result = _launch("momu_table7.py", tmp_path)
    _check_complete(result, TABLE7_ROWS)
    stages = result["provenance"]["stages"]
    # 2 music VAEs (mel, waveform), 4 motion VAEs (#1, #2, #3, base), 5 diffusion pairs (#5-#7 share one)
    assert sum(k.startswith("music_vae-") for k in stages) == 2
    assert sum(k.startswith("motion_vae-") for k in stages) == 4
    assert sum(k.startswith("diffusion-") for k in stages) == 5
    cross, joint = result["rows"][-1]["comparisons"], result["rows"][4]["comparisons"]
    assert set(cross["music_f1"]) == {"other condition", "shuffled"}
    assert set(cross["motion_f1"]) == {"other condition", "shuffled", "ground truth"}
    assert set(joint["motion_f1"]) == {"other pair", "shuffled", "ground truth"}
    assert set(cross["motion_fid"]) == {"ground truth"}  # the real-vs-real floor, per seed
    assert result["rows"][-1]["artifacts"][0]["model"].startswith("models/momu-")
    models = list((tmp_path / "momu_table7" / "models").glob("momu-*/momu.json"))
    assert len(models) == 5
    assert list((tmp_path / "momu_table7" / "models").glob("momu-*/beats.png"))


def _check_two_seeds(result: dict, out: Path) -> None:
    assert result["seeds"] == [0, 1]
    for row in result["rows"]:
        assert len(row["per_seed"]) == 2 and row["interval"]["motion_f1"] is not None
        assert len(row["comparisons"]["motion_f1"]["shuffled"]["per_seed"]) == 2
    md = (out / "momu_table7" / "results.md").read_text()
    row7 = next(line for line in md.splitlines() if line.startswith("| #7 |"))
    assert row7.count(" ± ") == 4  # every cell: mean ± half-width over the two seeds
    assert "## Verdicts" in md and "95 % Student-t interval" in md


def test_table7_smoke_two_seeds(tmp_path: Path) -> None:
    result = _launch("momu_table7.py", tmp_path, extra=("--rows", "#5,#7", "--seeds", "0", "1"))
    _check_two_seeds(result, tmp_path)


def test_table7_smoke_two_processes(tmp_path: Path) -> None:
    # a cross and a joint row over two seeds, on two gloo processes (every row runs single-process above)
    result = _launch("momu_table7.py", tmp_path, processes=2, extra=("--rows", "#5,#7", "--seeds", "0", "1"))
    _check_complete(result, ["#5", "#7"])
    assert result["provenance"]["num_processes"] == 2
    _check_two_seeds(result, tmp_path)


def test_table10_smoke(tmp_path: Path) -> None:
    result = _launch("momu_table10.py", tmp_path)
    _check_complete(result, ["Tc=0.9T", "Tc=0.7T", "Tc=0.5T", "Tc=0.3T", "Tc=0.1T"])
    stages = result["provenance"]["stages"]
    assert len(stages) == 5  # 3 stages + 2 extractors: trained once, reused by the other four rows


def test_bad_row_fails_before_training(tmp_path: Path) -> None:
    proc = subprocess.run(
        [
            sys.executable,
            str(ROOT / "recipes" / "momu_table7.py"),
            "--preset",
            "smoke",
            "--rows",
            "#8",
            "--out",
            str(tmp_path),
            "--tracker",
            "none",
        ],
        capture_output=True,
        text=True,
        env=ENV,
        timeout=120,
        cwd=ROOT,
    )
    assert proc.returncode == 2
    assert proc.stderr.strip().endswith("--rows: unknown row #8; valid rows: #1, #2, #3, #4, #5, #6, #7")
    assert not (tmp_path / "momu_table7").exists()


def test_parallel_jobs_give_the_same_numbers_as_one_process(tmp_path: Path) -> None:
    # three units on two workers: one worker evaluates two units in one process
    flags = ("--rows", "#7", "--seeds", "0", "1", "2")
    parallel = subprocess.run(
        [sys.executable, str(ROOT / "recipes" / "momu_table7.py"), "--preset", "smoke", "--out",
         str(tmp_path / "jobs"), "--tracker", "none", "--jobs", "2", *flags],
        capture_output=True, text=True, env=ENV, timeout=600, cwd=ROOT,
    )  # fmt: skip
    assert parallel.returncode == 0, parallel.stderr[-3000:]
    serial = _launch("momu_table7.py", tmp_path / "one", extra=("--threads", "1", *flags))
    jobs = json.loads((tmp_path / "jobs" / "momu_table7" / "results.json").read_text())
    assert jobs["provenance"]["jobs"] == 2 and jobs["provenance"]["threads"] == 1
    assert jobs["rows"][0]["per_seed"] == serial["rows"][0]["per_seed"]
    assert {p.name for p in (tmp_path / "jobs" / "momu_table7" / "logs").iterdir()} == {
        "7-seed0.log",
        "7-seed1.log",
        "7-seed2.log",
    }
