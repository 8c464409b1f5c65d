"""Real ``momu`` / recipe processes for the tests of signals, kills and resume."""

from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

RECIPES = Path(__file__).resolve().parents[2] / "recipes"
_ANSI = re.compile(r"\x1b\[[0-9;]*[A-Za-z]")


def momu_argv(*args: str) -> list[str]:
    """``python -m momu ARGS`` with this interpreter."""
    return [sys.executable, "-m", "momu", *args]


def recipe_argv(table: str, *args: str) -> list[str]:
    """``python recipes/<table>.py ARGS`` with this interpreter."""
    return [sys.executable, str(RECIPES / f"{table}.py"), *args]


@dataclass
class Finished:
    """A process that has ended: its status and output."""

    status: int
    stdout: str
    stderr: str

    def error_lines(self) -> list[str]:
        """The stderr lines that are not progress bars or log records."""
        plain = _ANSI.sub("", self.stderr)  # progress bars move the cursor
        lines = [part.strip() for line in plain.splitlines() for part in line.split("\r")]
        return [
            line
            for line in lines
            if line and not line.startswith(("INFO ", "WARNING ", "DEBUG ")) and "it/s]" not in line
            and "s/it]" not in line and "step/s]" not in line and "s/step]" not in line
            and "units [" not in line and "%|" not in line
        ]  # fmt: skip


def run(argv: Sequence[str], timeout: float = 600.0) -> Finished:
    """Run ``argv`` to the end."""
    done = subprocess.run(list(argv), capture_output=True, text=True, timeout=timeout, check=False)
    return Finished(done.returncode, done.stdout, done.stderr)


def run_and_signal(
    argv: Sequence[str],
    when: Callable[[], bool],
    signum: int,
    *,
    delay: float = 0.0,
    timeout: float = 600.0,
) -> Finished:
    """Start ``argv``, send ``signum`` once ``when()`` holds (polled every 20 ms, then ``delay`` s),
    and wait for it to end. Fails if the process ends before the condition held."""
    with open(os.devnull, "rb") as stdin:
        proc = subprocess.Popen(
            list(argv), stdin=stdin, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
        )
    deadline = time.monotonic() + timeout
    try:
        while not when():
            if proc.poll() is not None:
                out, err = proc.communicate()
                raise AssertionError(
                    f"ended (status {proc.returncode}) before the signal was due:\n{err[-3000:]}"
                )
            if time.monotonic() > deadline:
                raise AssertionError("the condition for the signal never held")
            time.sleep(0.02)
        time.sleep(delay)
        proc.send_signal(signum)
        out, err = proc.communicate(timeout=max(1.0, deadline - time.monotonic()))
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    return Finished(proc.returncode if proc.returncode >= 0 else 128 - proc.returncode, out, err)


def exists(pattern: str, root: Path) -> Callable[[], bool]:
    """A condition: some path under ``root`` matches the glob ``pattern``."""
    return lambda: any(root.glob(pattern))


SIGKILL = signal.SIGKILL
SIGTERM = signal.SIGTERM
SIGINT = signal.SIGINT
