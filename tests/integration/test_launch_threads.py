"""The same stage under ``python`` and ``accelerate launch``: one thread count, one set of weights.

``accelerate launch`` exports ``OMP_NUM_THREADS=1`` to its child; momu sets the count itself
(``momu.engine.accelerate_setup.configure_threads``) so the two launches agree.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest
from tests.helpers.launch import LAUNCHER

SCRIPT = Path(__file__).parent / "scripts" / "engine_threads.py"
ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.skipif(not LAUNCHER.exists(), reason="accelerate's launcher is not installed")
def test_python_and_accelerate_launch_use_the_same_threads_and_agree(tmp_path: Path) -> None:
    env = {k: v for k, v in os.environ.items() if k not in ("MOMU_NUM_THREADS", "OMP_NUM_THREADS")}
    env["WANDB_MODE"] = "disabled"
    config = str(ROOT / "recipes" / "accelerate" / "default.yaml")
    runs = {
        "python": [sys.executable, str(SCRIPT), str(tmp_path / "python")],
        "accelerate": [
            str(LAUNCHER),
            "launch",
            "--config_file",
            config,
            str(SCRIPT),
            str(tmp_path / "accelerate"),
        ],
    }
    results = {}
    for name, cmd in runs.items():
        proc = subprocess.run(cmd, capture_output=True, text=True, env=env, timeout=300)
        assert proc.returncode == 0, proc.stderr[-2000:]
        results[name] = json.loads((tmp_path / name / "r.json").read_text())
    assert results["python"] == results["accelerate"]
