"""Stopping on a signal: SIGTERM (cluster pre-emption), SIGINT (Ctrl-C), or a launcher that is gone.

Two layers, one for the whole command and one for a training loop:

* :func:`stop_on_signals` (around a whole ``momu train`` or recipe run) turns SIGTERM and SIGINT
  into :class:`Interrupted`, which the command reports as **one line** and exit status
  **143** (SIGTERM) or **130** (SIGINT) — no traceback. Stages already trained stay in the cache.
* :func:`stop_flag` (around a training loop: :func:`momu.engine.trainer.train_stage`, the
  extractors' loop) replaces that with a flag the loop reads after each optimizer step: the loop
  writes a checkpoint and raises :class:`Interrupted` (the engine's :class:`~momu.engine.trainer.Preempted`)
  with the same status, so ``--resume`` continues from that step. A second Ctrl-C while the step
  finishes stops at once, without a checkpoint.

The flag is also up when the ``accelerate launch`` process that started this one has exited (an
orphaned trainer must not go on writing into ``--out``).
"""

from __future__ import annotations

import os
import signal
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

__all__ = ["Interrupted", "StopFlag", "stop_flag", "stop_on_signals", "exit_status", "signal_name"]

_HANDLED = (signal.SIGTERM, signal.SIGINT)


def exit_status(signum: int) -> int:
    """The shell's status for a process ended by ``signum``: ``128 + signum`` (143 SIGTERM, 130 SIGINT)."""
    return 128 + int(signum)


def signal_name(signum: int) -> str:
    """``"SIGTERM"``, ``"SIGINT"`` ..."""
    return signal.Signals(signum).name


class Interrupted(RuntimeError):
    """A signal stopped the run; ``status`` is the exit status to return (143, 130)."""

    def __init__(self, message: str, status: int) -> None:
        super().__init__(message)
        self.status = status


class StopFlag:
    """SIGTERM or SIGINT arrived, or the launcher that started this process is gone."""

    def __init__(self) -> None:
        from momu.errors import launcher_pid

        self.signum: int | None = None
        self._launcher = launcher_pid()
        self._parent = os.getppid()

    @property
    def orphaned(self) -> bool:
        return self._launcher is not None and os.getppid() != self._parent

    @property
    def stop(self) -> bool:
        return self.signum is not None or self.orphaned

    @property
    def reason(self) -> str:
        return signal_name(self.signum) if self.signum is not None else "the exit of its accelerate launcher"

    @property
    def status(self) -> int:
        return exit_status(self.signum if self.signum is not None else signal.SIGTERM)


def _raise_interrupted(signum: int, frame: Any) -> None:
    raise Interrupted(
        f"stopped by {signal_name(signum)} outside a training step; the stages trained so far are kept "
        "(rerun the same command to reuse them)",
        exit_status(signum),
    )


def _raise_again(signum: int, frame: Any) -> None:
    raise Interrupted(
        f"stopped by a second {signal_name(signum)} before the step ended, without a checkpoint "
        "(rerun the same command with --resume to continue from the last one)",
        exit_status(signum),
    )


@contextmanager
def _handlers(handler: Any) -> Iterator[bool]:
    """``handler`` for SIGTERM and SIGINT inside the block (the previous ones restored after);
    yields ``False`` and changes nothing outside the main thread."""
    try:
        previous = {s: signal.signal(s, handler) for s in _HANDLED}
    except ValueError:  # not the main thread: leave signals alone
        yield False
        return
    try:
        yield True
    finally:
        for s, old in previous.items():
            signal.signal(s, old)


@contextmanager
def stop_on_signals() -> Iterator[None]:
    """SIGTERM and SIGINT raise :class:`Interrupted` inside the block (see the module docstring)."""
    with _handlers(_raise_interrupted):
        yield


@contextmanager
def stop_flag() -> Iterator[StopFlag]:
    """A :class:`StopFlag` set by SIGTERM or SIGINT inside the block; the loop checks it after each
    step. A second signal while the flag is up raises :class:`Interrupted` at once."""
    flag = StopFlag()

    def handler(signum: int, frame: Any) -> None:
        if flag.signum is not None:
            _raise_again(signum, frame)
        flag.signum = signum

    with _handlers(handler):
        yield flag
