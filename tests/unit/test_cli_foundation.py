"""`momu list` and `momu config show`."""

from __future__ import annotations

import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import pytest

from momu.cli import main
from momu.registry import BACKBONES, KINDS


@dataclass
class CliNetConfig:
    depth: int = 2


@pytest.fixture
def cli_net():
    BACKBONES.register("clitest_net", config=CliNetConfig)(lambda cfg: cfg)
    yield
    BACKBONES.unregister("clitest_net")


def test_list_shows_every_kind_with_sources(capsys: pytest.CaptureFixture[str], cli_net: None) -> None:
    assert main(["list"]) == 0
    out = capsys.readouterr().out
    for kind in KINDS:
        assert f"\n{kind} (" in "\n" + out
    line = next(line for line in out.splitlines() if "clitest_net" in line)
    assert line.endswith(f"local ({__name__})")  # registered in this test module, not by momu


def test_list_one_kind(capsys: pytest.CaptureFixture[str], cli_net: None) -> None:
    assert main(["list", "backbones"]) == 0
    out = capsys.readouterr().out
    assert out.startswith("backbones (") and "metrics (" not in out


def test_config_show_prints_resolved_config(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], cli_net: None
) -> None:
    path = tmp_path / "run.yaml"
    path.write_text("backbone: clitest_net\nseed: 3\n")
    assert main(["config", "show", str(path), "backbone.depth=6"]) == 0
    out = capsys.readouterr().out
    assert "name: clitest_net" in out and "depth: 6" in out and "seed: 3" in out
    # a node no schema knows (a top-level `train:`) is an error since issue 13, not silently kept
    assert main(["config", "show", str(path), "train.lr=0.1"]) == 2
    assert "train: unknown key; valid keys: seed" in capsys.readouterr().err


def test_config_show_rejects_bad_key_with_status_2(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], cli_net: None
) -> None:
    path = tmp_path / "run.yaml"
    path.write_text("backbone: clitest_net\n")
    assert main(["config", "show", str(path), "backbone.depht=4"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1
    assert "backbone.depht" in err[0] and "valid keys: depth" in err[0]


def test_console_script_runs() -> None:
    script = Path(sys.executable).with_name("momu")
    command = [str(script)] if script.exists() else [sys.executable, "-m", "momu"]
    proc = subprocess.run([*command, "list", "methods"], capture_output=True, text=True)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.startswith("methods (")


def test_generate_lets_waiting_openmp_threads_sleep(monkeypatch: pytest.MonkeyPatch) -> None:
    """`momu generate` sets OMP_WAIT_POLICY=PASSIVE before torch loads OpenMP, unless the user set it."""
    import os

    from momu.cli import _openmp_for

    monkeypatch.delenv("OMP_WAIT_POLICY", raising=False)
    _openmp_for(["list"])
    assert "OMP_WAIT_POLICY" not in os.environ
    _openmp_for(["-v", "generate", "dance", "--music", "x.wav"])
    assert os.environ["OMP_WAIT_POLICY"] == "PASSIVE"
    monkeypatch.setenv("OMP_WAIT_POLICY", "ACTIVE")
    _openmp_for(["generate", "music"])
    assert os.environ["OMP_WAIT_POLICY"] == "ACTIVE"


def test_help_and_input_errors_do_not_load_torch(tmp_path: Path) -> None:
    """`momu --help`, a generate command with a missing song and `momu eval` with a missing folder answer
    without importing torch, diffusers, the metrics or scipy's subpackages (`momu --help` took 7-10 s on
    2 cores when they did, and 2 s while the datasets imported scipy.signal, .spatial, .ndimage and
    .special)."""
    scipy_parts = ("scipy.signal", "scipy.spatial", "scipy.ndimage", "scipy.special")
    heavy = ("torch", "diffusers", "librosa", "momu.metrics", *scipy_parts)
    code = (
        "import sys\n"
        "from momu.cli import build_parser, main\n"
        "build_parser()\n"
        f"dance = main(['generate', 'dance', '--music', {str(tmp_path / 'absent.wav')!r}, '--out', 'o'])\n"
        "scores = main(['eval', '--gen', 'absent_dir', '--gt', '.', '--metrics', 'bas'])\n"
        f"print(dance, scores, [m for m in {heavy!r} if m in sys.modules])\n"
    )
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=tmp_path)
    assert proc.stdout.split() == ["2", "2", "[]"], proc.stdout + proc.stderr
    errors = proc.stderr.strip().splitlines()
    assert "absent.wav" in errors[0] and "not found" in errors[0]
    assert "absent_dir" in errors[1] and "not found" in errors[1]
    assert not (tmp_path / "o").exists()
