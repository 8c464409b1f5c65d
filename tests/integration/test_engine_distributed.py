"""The engine under two real processes (gloo on CPU) through `accelerate launch`."""

from __future__ import annotations

import json
import os
import subprocess
from pathlib import Path

from tests.helpers.launch import accelerate_launch

SCRIPT = Path(__file__).parent / "scripts" / "engine_two_processes.py"


def test_two_process_training_and_gather(tmp_path: Path) -> None:
    env = {**os.environ, "OMP_NUM_THREADS": "1", "WANDB_MODE": "disabled"}
    proc = subprocess.run(
        accelerate_launch(SCRIPT, str(tmp_path), processes=2),
        capture_output=True,
        text=True,
        env=env,
        timeout=300,
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    result = json.loads((tmp_path / "result.json").read_text())
    assert result["num_processes"] == 2
    assert result["items"] == list(range(7))  # each item exactly once, in order
    assert result["ranks"] == [0, 1]  # both processes did work
    assert (tmp_path / "ckpt" / "step_00000006" / "rng_1.safetensors").is_file()
