"""`accelerate launch` command lines for the tests that run real processes (gloo on CPU)."""

from __future__ import annotations

import sys
from pathlib import Path

LAUNCHER = Path(sys.executable).with_name("accelerate")


def accelerate_launch(script: Path, *args: str, processes: int = 1) -> list[str]:
    """``accelerate launch`` of ``script`` on ``processes`` local processes, no mixed precision or dynamo."""
    multi = ["--multi_gpu", "--num_processes", str(processes)] if processes > 1 else ["--num_processes", "1"]
    return [
        str(LAUNCHER),
        "launch",
        *multi,
        "--num_machines",
        "1",
        "--mixed_precision",
        "no",
        "--dynamo_backend",
        "no",
        str(script),
        *args,
    ]
