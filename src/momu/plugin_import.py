"""A time limit on importing a plugin, so a plugin that hangs at import cannot hang momu.

:func:`import_within` runs a plugin's import (``EntryPoint.load``) under a deadline of
:func:`plugin_timeout` seconds (environment variable ``MOMU_PLUGIN_TIMEOUT``, default
:data:`DEFAULT_PLUGIN_TIMEOUT_S`; ``0`` turns the limit off). Two mechanisms, because Python can
interrupt only Python code:

1. In the main thread of a POSIX process whose ``SIGALRM`` nobody else handles, a ``SIGALRM`` timer
   interrupts the import (a loop, a ``sleep``, a lock or socket wait) and :func:`import_within` raises
   :class:`momu.registry.PluginError` naming the entry point: ``momu`` prints it as one line and exits
   with status 2, a Python session gets the exception. The interrupt is raised as a
   ``BaseException`` so a plugin's own ``except Exception`` / ``except ImportError`` cannot swallow it.
2. A watchdog thread, for hangs the signal cannot reach (a plugin stuck in C code, or one that blocks
   ``SIGALRM``) and for imports outside the main thread or under another ``SIGALRM`` user (such as
   ``pytest-timeout``): after the deadline (plus as long again, at most
   :data:`WATCHDOG_GRACE_S` more, where the signal had its chance first) it prints the same one line
   through :func:`momu.errors.fail` and ends the process with status 2 (``os._exit``: a thread cannot
   stop the main thread's C call).
"""

from __future__ import annotations

import os
import signal
import sys
import threading
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path
from types import FrameType
from typing import TypeVar

__all__ = [
    "DEFAULT_PLUGIN_TIMEOUT_S",
    "PLUGIN_TIMEOUT_ENV",
    "WATCHDOG_GRACE_S",
    "PluginImportTimeout",
    "import_within",
    "plugin_timeout",
]

T = TypeVar("T")

PLUGIN_TIMEOUT_ENV = "MOMU_PLUGIN_TIMEOUT"
DEFAULT_PLUGIN_TIMEOUT_S = 120.0
"""Seconds a plugin may take to import (a heavy plugin imports torch-scale libraries in a few seconds)."""
WATCHDOG_GRACE_S = 5.0
"""Most seconds the watchdog waits past the deadline while the signal has its chance."""


class PluginImportTimeout(Exception):
    """A plugin's import did not finish within the deadline; ``str(err)`` says which and how long."""


class _Deadline(BaseException):
    """Raised inside the import by the ``SIGALRM`` handler (a BaseException: plugins cannot catch it)."""


def plugin_timeout() -> float:
    """Seconds allowed for one plugin import (``MOMU_PLUGIN_TIMEOUT``; ``0``: no limit).

    Raises:
        ValueError: the variable is not a number >= 0 (the message names it).
    """
    raw = os.environ.get(PLUGIN_TIMEOUT_ENV, "").strip()
    if not raw:
        return DEFAULT_PLUGIN_TIMEOUT_S
    try:
        seconds = float(raw)
    except ValueError:
        seconds = -1.0
    if not seconds >= 0 or seconds == float("inf"):
        raise ValueError(f"{PLUGIN_TIMEOUT_ENV}={raw!r}: expected seconds, a number >= 0 (0: no limit)")
    return seconds


def _signal_usable() -> bool:
    """Whether a ``SIGALRM`` timer can interrupt this thread without disturbing anyone else's."""
    if not hasattr(signal, "setitimer") or threading.current_thread() is not threading.main_thread():
        return False
    return signal.getsignal(signal.SIGALRM) in (signal.SIG_DFL, None) and signal.getitimer(
        signal.ITIMER_REAL
    ) == (0.0, 0.0)


def _prog() -> str:
    """The program's name for the error line: ``momu``, a recipe's name (``momu_table7``) ..."""
    if not sys.argv or sys.argv[0] in ("", "-c"):
        return "momu"
    script = Path(sys.argv[0])
    return script.parent.name if script.stem == "__main__" else script.stem


def _hard_stop(message: str) -> None:  # pragma: no cover - runs in a process that it ends
    from momu.errors import EXIT_USAGE, fail

    fail(_prog(), message, EXIT_USAGE)
    os._exit(EXIT_USAGE)


@contextmanager
def _alarm(seconds: float) -> Iterator[None]:
    def on_alarm(signum: int, frame: FrameType | None) -> None:
        raise _Deadline

    previous = signal.signal(signal.SIGALRM, on_alarm)
    signal.setitimer(signal.ITIMER_REAL, seconds)
    try:
        yield
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0.0)
        signal.signal(signal.SIGALRM, previous)


def import_within(load: Callable[[], T], seconds: float, what: str) -> T:
    """``load()`` (a plugin's import), stopped after ``seconds`` (module docstring; ``0``: no limit).

    Args:
        load: the import, e.g. ``entry_point.load``.
        seconds: the deadline.
        what: the plugin, as the error message names it (distribution and entry point).

    Raises:
        PluginImportTimeout: the import was interrupted at the deadline.
    """
    if seconds <= 0:
        return load()
    message = (
        f"{what} did not finish importing within {seconds:g} s (a plugin that hangs at import; "
        f"set {PLUGIN_TIMEOUT_ENV}=SECONDS for a slower one, 0 for no limit)"
    )
    use_signal = _signal_usable()
    grace = min(seconds, WATCHDOG_GRACE_S) if use_signal else 0.0
    watchdog = threading.Timer(seconds + grace, _hard_stop, args=(message,))
    watchdog.daemon = True
    watchdog.start()
    try:
        if not use_signal:
            return load()
        try:
            with _alarm(seconds):
                return load()
        except _Deadline:
            raise PluginImportTimeout(message) from None
    finally:
        watchdog.cancel()
