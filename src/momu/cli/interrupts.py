"""SIGTERM (and SIGHUP) as an exception, so a stopped command still cleans up after itself.

Python's default for SIGTERM kills the process on the spot: no ``finally`` block runs, so temporaries
stay on disk and child processes (ffmpeg) keep running. Inside :func:`exit_on_sigterm` the signal
raises :class:`Terminated` (a ``SystemExit`` with status 143, not caught by ``except Exception``)
instead; the blocks it unwinds remove their temporaries and kill their children, and the command exits
with status 143. SIGKILL cannot be caught: :func:`momu.cli.output_paths.remove_stale_partials` and
ffmpeg's own CPU-time limit (:mod:`momu.render.ffmpeg`) cover it.
"""

from __future__ import annotations

import contextlib
import signal
from collections.abc import Iterator
from types import FrameType

from momu.errors import EXIT_PREEMPTED

__all__ = ["Terminated", "exit_on_sigterm"]


class Terminated(SystemExit):
    """Raised by SIGTERM / SIGHUP inside :func:`exit_on_sigterm` (exit status 143)."""

    def __init__(self, signum: int) -> None:
        super().__init__(EXIT_PREEMPTED)
        self.signal_name = signal.Signals(signum).name


@contextlib.contextmanager
def exit_on_sigterm() -> Iterator[None]:
    """In the block SIGTERM and SIGHUP raise :class:`Terminated` (main thread only; elsewhere a no-op)."""

    def handler(signum: int, frame: FrameType | None) -> None:
        raise Terminated(signum)

    previous = {}
    try:
        for sig in (signal.SIGTERM, signal.SIGHUP):
            previous[sig] = signal.signal(sig, handler)
    except ValueError:  # not the main thread: leave signals alone
        pass
    try:
        yield
    finally:
        for sig, old in previous.items():
            signal.signal(sig, old)
