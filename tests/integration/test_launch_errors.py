"""A usage error's one-line reason is the last thing printed, under ``python`` and ``accelerate launch``.

Real processes (tests/helpers/launch.py), for a table recipe and the music-following benchmark.
``python recipes/<recipe>.py`` exits 2; the launcher turns any failing child into exit 1 plus its own
report (``CalledProcessError`` traceback, or torch elastic's failure summary with ``--multi_gpu``),
after which momu repeats the reason (docs/errors.md).
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest
from tests.helpers.launch import LAUNCHER, accelerate_launch

ROOT = Path(__file__).resolve().parents[2]
CASES = {
    "table": (
        ROOT / "recipes" / "momu_table7.py",
        ("--preset", "smoke", "--rows", "99"),
        "momu_table7: error: --rows: unknown row 99; valid rows: #1, #2, #3, #4, #5, #6, #7",
    ),
    "benchmark": (
        ROOT / "recipes" / "music_following.py",
        ("--data", "no_such_folder"),
        "music_following: error: --data no_such_folder: not a folder (give synth, a Dance with Melody folder "
        "or a pair folder)",
    ),
}


def _run(cmd: list[str], tmp_path: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [*cmd, "--out", str(tmp_path / "out")], capture_output=True, text=True, timeout=300, cwd=ROOT
    )


def _last_line(result: subprocess.CompletedProcess[str]) -> str:
    return result.stderr.strip().splitlines()[-1]


@pytest.mark.parametrize("case", CASES)
def test_python_prints_the_reason_last_and_exits_2(tmp_path: Path, case: str) -> None:
    recipe, args, reason = CASES[case]
    result = _run([sys.executable, str(recipe), *args], tmp_path)
    assert result.returncode == 2
    assert result.stderr.strip() == reason
    assert not (tmp_path / "out").exists()


@pytest.mark.skipif(not LAUNCHER.exists(), reason="accelerate's launcher is not installed")
@pytest.mark.parametrize("case", CASES)
def test_accelerate_launch_ends_with_the_reason(tmp_path: Path, case: str) -> None:
    recipe, args, reason = CASES[case]
    cmd = [str(LAUNCHER), "launch", "--config_file", str(ROOT / "recipes" / "accelerate" / "default.yaml")]
    result = _run([*cmd, str(recipe), *args], tmp_path)
    assert result.returncode == 1  # simple_launcher: any failing child is exit 1 + CalledProcessError
    assert "CalledProcessError" in result.stderr and "exit status 2" in result.stderr
    assert _last_line(result) == reason
    assert "were not passed to `accelerate launch`" not in result.stderr  # the shipped defaults
    assert not (tmp_path / "out").exists()


@pytest.mark.skipif(not LAUNCHER.exists(), reason="accelerate's launcher is not installed")
@pytest.mark.parametrize("case", CASES)
def test_accelerate_launch_multi_process_ends_with_the_reason(tmp_path: Path, case: str) -> None:
    recipe, args, reason = CASES[case]
    result = _run(accelerate_launch(recipe, *args, processes=2), tmp_path)
    assert result.returncode == 1  # torch elastic: ChildFailedError, exit 1
    assert "ChildFailedError" in result.stderr
    assert f"traceback : {reason}" in result.stderr  # the summary shows the reason, not a URL
    assert _last_line(result) == reason
    assert (
        result.stderr.count(reason) >= 3
    )  # the first failing rank, the summary (per rank with a file), last
    assert not (tmp_path / "out").exists()
