"""How momu fails: one line naming the file or key, an exit status that says what kind of failure.

Exit statuses (``docs/errors.md``):

========  =========================================================================================
``0``     done.
``1``     the command ran but found problems (``data check`` found bad files, a metric of
          ``momu eval`` failed); also what ``accelerate launch`` reports for *any* failing child.
``2``     usage error: a bad argument, config key, input file or output path. The one-line
          reason is ``<prog>: error: <what>: <why>`` and nothing was written.
``143``   stopped by SIGTERM (after a checkpoint of the stage in training); rerun with ``--resume``.
``130``   stopped by Ctrl-C (SIGINT), the same way.
========  =========================================================================================

Under a launcher the child's status and stderr are not the user's last word: ``accelerate launch``
(its ``simple_launcher``) raises ``CalledProcessError`` for any non-zero child and exits 1 with that
traceback; ``accelerate launch --multi_gpu`` (torch elastic) raises ``ChildFailedError`` and prints a
failure summary, also exit 1. :func:`fail` therefore also

* writes the reason to torch elastic's error file (``TORCHELASTIC_ERROR_FILE``), so the summary's
  ``traceback :`` field shows the reason instead of "To enable traceback see ...";
* starts a small detached process (:mod:`momu.launch_epilogue`) that waits for the launcher to exit
  and then repeats the reason on stderr, so the reason is the last line the user sees.

With several processes every rank fails the same way; the first to get here prints the reason and
starts the epilogue (a claim file per launcher makes it one), the others only write their error
file — torch elastic may SIGTERM the slower ranks as soon as one has failed.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any, NoReturn

__all__ = [
    "EXIT_OK",
    "EXIT_PROBLEMS",
    "EXIT_USAGE",
    "EXIT_PREEMPTED",
    "UsageError",
    "UsageParser",
    "fail",
    "stopped",
    "one_line",
    "launcher_pid",
]

EXIT_OK = 0
EXIT_PROBLEMS = 1
EXIT_USAGE = 2
EXIT_PREEMPTED = 143

_LAUNCHER_NAMES = ("accelerate", "torchrun", "torch.distributed.run", "torch.distributed.launch")


class UsageError(ValueError):
    """A bad argument, input file or output path; ``str(err)`` names it and says what is wrong."""


def one_line(message: object) -> str:
    """``message`` on one line (inner newlines become ``"; "``), without trailing whitespace."""
    parts = [p.strip() for p in str(message).splitlines() if p.strip()]
    return "; ".join(parts) if parts else type(message).__name__


def _rank() -> int:
    try:
        return int(os.environ.get("RANK", "0"))
    except ValueError:
        return 0


def launcher_pid() -> int | None:
    """The pid of the ``accelerate launch`` / ``torchrun`` process that started this one, if any."""
    try:
        import psutil
    except ImportError:  # pragma: no cover - psutil is a dependency
        return None
    try:
        parent = psutil.Process(os.getppid())
        cmdline = " ".join(parent.cmdline())
    except (psutil.Error, OSError):
        return None
    return parent.pid if any(name in cmdline for name in _LAUNCHER_NAMES) else None


def _write_elastic_error_file(line: str) -> None:
    """Record ``line`` where torch elastic's agent reads a failed worker's reason."""
    path = os.environ.get("TORCHELASTIC_ERROR_FILE")
    if not path:
        return
    record = {
        "message": {"message": line, "extraInfo": {"py_callstack": line, "timestamp": str(int(time.time()))}}
    }
    try:
        with open(path, "w", encoding="utf-8") as fh:
            json.dump(record, fh)
    except OSError:
        pass


def _claim(pid: int) -> Path | None:
    """The claim file of launcher ``pid`` if this process is the first of its ranks to fail, else ``None``."""
    try:
        import psutil

        started = int(psutil.Process(pid).create_time() * 1000)
    except Exception:  # the launcher is already gone: nothing to outlive
        return None
    path = Path(tempfile.gettempdir()) / f"momu-fail-{pid}-{started}"
    try:
        os.close(os.open(path, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o600))
    except OSError:
        return None
    return path


def _repeat_after(pid: int, line: str, claim: Path) -> None:
    """Start :mod:`momu.launch_epilogue`: it prints ``line`` on stderr once process ``pid`` has exited."""
    try:
        subprocess.Popen(
            [sys.executable, "-m", "momu.launch_epilogue", str(pid), line, str(claim)],
            stdin=subprocess.DEVNULL,
            stdout=subprocess.DEVNULL,
            start_new_session=True,
        )
    except OSError:
        pass


def stopped(line: str, status: int) -> int:
    """Print ``line`` (why a command stopped: SIGTERM, Ctrl-C) on stderr and return ``status``.

    Under ``accelerate launch`` the launcher turns the status into 1 and prints its own traceback
    after it; the first rank to stop therefore also has the line repeated once the launcher has
    exited (:mod:`momu.launch_epilogue`), as :func:`fail` does for a usage error.
    """
    sys.stderr.write(line + "\n")
    sys.stderr.flush()
    pid = launcher_pid()
    claim = _claim(pid) if pid is not None else None
    if pid is not None and claim is not None:
        _repeat_after(pid, line, claim)
    return status


def fail(prog: str, message: object, status: int = EXIT_USAGE) -> int:
    """Print ``<prog>: error: <message>`` as one line on stderr and return ``status``.

    Under ``accelerate launch`` / torch elastic the reason also goes to the elastic error file and is
    repeated after the launcher's own report (module docstring); only rank 0 writes to stderr.
    """
    line = f"{prog}: error: {one_line(message)}"
    pid = launcher_pid()
    if pid is None:
        if _rank() == 0:
            sys.stderr.write(line + "\n")
            sys.stderr.flush()
        return status
    _write_elastic_error_file(line)
    claim = _claim(pid)
    if claim is not None:
        sys.stderr.write(line + "\n")
        sys.stderr.flush()
        _repeat_after(pid, line, claim)
    return status


class UsageParser(argparse.ArgumentParser):
    """An ``ArgumentParser`` whose errors exit through :func:`fail` (status 2, reason repeated last).

    Args:
        error_prefix: what the error line starts with (default: ``prog``).
    """

    def __init__(self, *args: Any, error_prefix: str | None = None, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.error_prefix = error_prefix

    def error(self, message: str) -> NoReturn:
        if _rank() == 0 and launcher_pid() is None:
            self.print_usage(sys.stderr)
        sys.exit(fail(self.error_prefix or self.prog, message))
