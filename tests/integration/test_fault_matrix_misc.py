"""Issue 34, process level: plugins that hang or clash, and ``data synth`` on a disk that fails or cannot
hold the dataset. Each case runs ``python -m momu ...`` as a real process and checks

* the exit status (2: usage error, nothing written; 1: the disk failed while writing);
* one ``error:`` line on stderr naming what is at fault (the entry points, the option);
* that it ends well before the case's time limit (a hang on the old code is a timeout here);
* that every file under the test's folder is as it was (no half-written dataset, no staging folder,
  no lock file; a dataset being replaced is kept whole).
"""

from __future__ import annotations

import os
import resource
import signal
import subprocess
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import pytest
from tests.helpers.fake_dist import install_fake_dist

from momu.data.synth import SynthConfig, write_dataset
from momu.data.synth.store import MAX_CLIPS

TIME_LIMIT_S = 90.0

HANGS_IN_PYTHON = """
import time
try:
    time.sleep(600)
except Exception:  # a plugin's own handler must not swallow the deadline
    time.sleep(600)
"""
HANGS_WHERE_NO_SIGNAL_REACHES = """
import signal, time
signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGALRM})  # as a C call that never returns
time.sleep(600)
"""
REGISTERS_A_BACKBONE = """
from momu.registry import BACKBONES

@BACKBONES.register("{name}")
def build(**deps):
    return "{dist}"
"""


def _plugin(site: Path, mp: pytest.MonkeyPatch, dist: str, source: str, name: str) -> None:
    module = dist.replace("-", "_")
    install_fake_dist(
        site / dist,
        mp,
        dist=dist,
        version="0.1",
        module=module,
        source=source,
        entry_points={"momu.backbones": {name: f"{module}:build"}},
    )


def _config(tmp: Path, name: str) -> str:
    path = tmp / "cfg.yaml"
    path.write_text(f"backbone:\n  name: {name}\n")
    return str(path)


def _hanging(source: str) -> Callable[[Path, pytest.MonkeyPatch], list[str]]:
    def setup(tmp: Path, mp: pytest.MonkeyPatch) -> list[str]:
        _plugin(tmp / "site", mp, "momu-hang", source, "hang_net")
        return ["config", "show", _config(tmp, "hang_net")]

    return setup


def _clash(tmp: Path, mp: pytest.MonkeyPatch) -> list[str]:
    for dist in ("momu-twin-a", "momu-twin-b"):
        _plugin(tmp / "site", mp, dist, REGISTERS_A_BACKBONE.format(name="twin_net", dist=dist), "twin_net")
    return ["config", "show", _config(tmp, "twin_net")]


def _synth(*options: str) -> Callable[[Path, pytest.MonkeyPatch], list[str]]:
    def setup(tmp: Path, mp: pytest.MonkeyPatch) -> list[str]:
        return ["data", "synth", "--out", str(tmp / "out"), "--no-progress", *options]

    return setup


def _synth_into(out: str) -> Callable[[Path, pytest.MonkeyPatch], list[str]]:
    return lambda tmp, mp: ["data", "synth", "--out", out, "--no-progress"]


def _overwrite_on_a_failing_disk(tmp: Path, mp: pytest.MonkeyPatch) -> list[str]:
    """An existing dataset, to be replaced by one whose wavs the disk cannot take: it must stay."""
    write_dataset(tmp / "out", SynthConfig(num_clips=1, min_seconds=1.0, max_seconds=1.0))
    return _synth("--overwrite", "--clips", "3", "--seconds", "8")(tmp, mp)


def _file_size_limit() -> None:  # pragma: no cover - runs in the child
    """Writes past 200 kB fail with EFBIG, as on a full disk (ENOSPC), in C code (libsndfile) too."""
    signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
    resource.setrlimit(resource.RLIMIT_FSIZE, (200_000, 200_000))


@dataclass(frozen=True)
class Case:
    setup: Callable[[Path, pytest.MonkeyPatch], list[str]]
    status: int
    names: tuple[str, ...]
    env: dict[str, str] = field(default_factory=dict)
    preexec: Callable[[], None] | None = None


CASES = {
    "plugin hangs at import (Python code)": Case(
        _hanging(HANGS_IN_PYTHON),
        2,
        ("hang_net = momu_hang:build", "momu-hang==0.1", "did not finish importing within 1 s"),
        {"MOMU_PLUGIN_TIMEOUT": "1"},
    ),
    "plugin hangs at import where no signal reaches": Case(
        _hanging(HANGS_WHERE_NO_SIGNAL_REACHES),
        2,
        ("hang_net = momu_hang:build", "momu-hang==0.1", "did not finish importing within 1 s"),
        {"MOMU_PLUGIN_TIMEOUT": "1"},
    ),
    "MOMU_PLUGIN_TIMEOUT is not a number": Case(
        _hanging(HANGS_IN_PYTHON), 2, ("MOMU_PLUGIN_TIMEOUT='soon'",), {"MOMU_PLUGIN_TIMEOUT": "soon"}
    ),
    "two plugins declare the same name": Case(
        _clash,
        2,
        (
            "twin_net = momu_twin_a:build",
            "momu-twin-a==0.1",
            "twin_net = momu_twin_b:build",
            "momu-twin-b==0.1",
        ),
    ),
    "data synth --clips over the cap": Case(
        _synth("--clips", str(MAX_CLIPS + 1)), 2, (f"--clips {MAX_CLIPS + 1}", f"at most {MAX_CLIPS:,}")
    ),
    "data synth --clips more than the disk holds": Case(
        _synth("--clips", str(MAX_CLIPS), "--seconds", "3600", "--sample-rate", "192000"),  # 138 PB
        2,
        (f"--clips {MAX_CLIPS}", "GB free"),
    ),
    "data synth --out on a read-only file system": Case(  # os.access says yes to root
        _synth_into("/proc/momu-synth"), 2, ("--out /proc/momu-synth: cannot write in /proc",)
    ),
    "data synth on a disk that fails while writing": Case(
        _overwrite_on_a_failing_disk,
        1,
        ("cannot write", "File too large"),
        preexec=_file_size_limit,
    ),
}


def _snapshot(root: Path) -> dict[Path, bytes]:
    return {p.relative_to(root): p.read_bytes() if p.is_file() else b"" for p in root.rglob("*")}


@pytest.mark.parametrize("case", list(CASES))
def test_fault(case: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    spec = CASES[case]
    argv = spec.setup(tmp_path, monkeypatch)
    before = _snapshot(tmp_path)
    env = {**os.environ, **spec.env, "PYTHONDONTWRITEBYTECODE": "1"}
    env["PYTHONPATH"] = os.pathsep.join([*map(str, (tmp_path / "site").glob("*")), env.get("PYTHONPATH", "")])
    start = time.monotonic()
    result = subprocess.run(
        [sys.executable, "-m", "momu", *argv],
        capture_output=True,
        text=True,
        env=env,
        timeout=TIME_LIMIT_S,
        preexec_fn=spec.preexec,
    )
    took = time.monotonic() - start
    lines = result.stderr.strip().splitlines()
    assert result.returncode == spec.status, result.stderr
    assert len(lines) == 1 and "error: " in lines[0], result.stderr
    for name in spec.names:
        assert name in lines[0], lines[0]
    assert took < TIME_LIMIT_S / 2
    assert _snapshot(tmp_path) == before
