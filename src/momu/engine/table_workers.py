"""``--jobs N``: a table's (row, seed) units in ``N`` long-lived worker processes.

The parent (:func:`run_units_in_workers`) starts at most ``N`` workers, each
``python <recipe> <the parent's arguments> --threads T --worker`` (one thread each by default), and
hands every worker one unit at a time: it writes ``ROW:SEED<TAB>LOG`` to the worker's stdin and
reads ``ROW:SEED<TAB>STATUS`` back from its stdout when the unit's cell is written; while the unit
runs the worker also reports its training steps, ``ROW:SEED<TAB>progress<TAB>DONE<TAB>PLANNED<TAB>STAGE``
at most once a second (:class:`UnitReporter`), so the parent's one progress line
(:class:`~momu.engine.progress.JobProgress`) shows the whole job with an ETA from the first steps. A worker
(:func:`serve_units`) evaluates the units it is sent in order, in one process, the way a table
without ``--jobs`` evaluates all of its units, with everything the unit prints sent to
``LOG`` (``<out>/<table>/logs/<row>-seed<k>.log``). So a worker pays its start (importing torch,
librosa, diffusers; about 8 CPU-s) once instead of once per unit, and the numbers are those of a
single process (``test_parallel_jobs_give_the_same_numbers_as_one_process``).

A unit that fails ends its worker (the traceback is in the unit's log, the status is the exit
status it would have had as a process: 1, or 143 when pre-empted); a worker that dies fails the
unit it held. Either way the parent starts a fresh worker for the units still waiting and reports
the failed units at the end.
"""

from __future__ import annotations

import logging
import os
import re
import selectors
import subprocess
import sys
import time
import traceback
from collections.abc import Callable, Container, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import IO, Any

from omegaconf import DictConfig

from momu.config import to_container
from momu.engine.context import RunContext
from momu.engine.progress import JobProgress, SideWorkClock, planned_steps
from momu.engine.signals import Interrupted
from momu.engine.table_units import Unit, cell_name, evaluate_unit, format_duration
from momu.errors import EXIT_PROBLEMS
from momu.metrics._audio import warm_librosa_kernels

__all__ = [
    "run_units_in_workers",
    "serve_units",
    "serve_table_units",
    "worker_argv",
    "UnitReporter",
    "unit_label",
]

log = logging.getLogger(__name__)

_WORKER_FLAGS = ("--jobs", "--rows", "--seeds", "--threads")
"""Flags a worker does not inherit from the parent (it is sent its units and gets its thread count)."""

REPORT_EVERY_S = 1.0
"""How often (at most) a worker reports its unit's steps to the parent."""

STOP_GRACE_S = 30.0
"""How long a stopping parent waits for a worker it sent SIGTERM (the worker finishes its training
step and writes a checkpoint) before it kills it."""


def worker_argv(argv: Sequence[str]) -> list[str]:
    """The recipe's arguments without :data:`_WORKER_FLAGS` and their values."""
    out: list[str] = []
    tokens = list(argv)
    i = 0
    while i < len(tokens):
        tok = tokens[i]
        if tok.split("=", 1)[0] in _WORKER_FLAGS:
            i += 1
            if "=" not in tok:  # the flag's values follow it
                i += 1
                while tok == "--seeds" and i < len(tokens) and re.fullmatch(r"[0-9,]+", tokens[i]):
                    i += 1
            continue
        out.append(tok)
        i += 1
    return out


def _worker_env(threads: int) -> dict[str, str]:
    env = dict(os.environ)
    for key in ("OMP_NUM_THREADS", "MOMU_NUM_THREADS", "MKL_NUM_THREADS"):
        env[key] = str(threads)
    return env


@dataclass
class _Worker:
    proc: subprocess.Popen[bytes]
    unit: Unit | None = None
    unread: bytes = b""  # the start of a line not yet complete

    def read_lines(self) -> list[bytes] | None:
        """The complete lines the worker has written since the last call (``None``: it has ended).

        Reads the pipe itself rather than through a buffered reader, so a line already read into a
        buffer never waits for the selector to report the pipe readable again.
        """
        chunk = os.read(_stdout(self).fileno(), 1 << 16)
        if not chunk:
            return None
        *lines, self.unread = (self.unread + chunk).split(b"\n")
        return lines

    def send(self, unit: Unit, logs: Path, progress: JobProgress | None = None) -> None:
        assert self.proc.stdin is not None
        self.proc.stdin.write(f"{unit.token}\t{logs / (cell_name(unit) + '.log')}\n".encode())
        self.proc.stdin.flush()
        self.unit = unit
        if progress is not None:
            progress.start_unit(unit_label(unit), 0)  # its planned steps come with the first report

    def close(self) -> int:
        """Let the worker finish (end of its input) and wait for it; returns its exit status."""
        if self.proc.stdin is not None and not self.proc.stdin.closed:
            try:
                self.proc.stdin.close()
            except BrokenPipeError:  # it has already gone
                pass
        return self.proc.wait()


def unit_label(unit: Unit) -> str:
    """How the progress line names ``unit``."""
    return f"row {unit.row} seed {unit.seed}"


class UnitReporter:
    """A worker's :class:`~momu.engine.progress.StageProgress`: the unit's steps, sent to the parent.

    Writes ``ROW:SEED<TAB>progress<TAB>DONE<TAB>PLANNED<TAB>STAGE`` to ``report`` (the parent's pipe)
    when a stage ends and at most every :data:`REPORT_EVERY_S` seconds while one trains.
    """

    def __init__(self, report: IO[str], unit: Unit, planned: int = 0) -> None:
        self.report, self.unit, self.planned = report, unit, planned
        self._finished_steps = 0
        self._last = 0.0
        self._side = SideWorkClock()
        self._side_work: dict[str, bool] = {}  # name -> finished

    def stage_step(self, name: str, step: int, steps: int) -> None:
        now = time.monotonic()
        if now - self._last >= REPORT_EVERY_S:
            self._last = now
            self._send(self._finished_steps + step, f"{name} {step}/{steps}")

    def side_step(self, name: str, step: int, steps: int) -> None:
        if name not in self._side_work:  # its steps join the unit's planned work (JobProgress.side_step)
            self._side_work[name] = False
            self.planned += steps
        if self._side_work[name]:  # already finished and counted
            return
        if step >= steps:
            self._side_work[name] = True
            self._finished_steps += steps
            self._send(self._finished_steps, self._side.text(name, step, steps))
            return
        now = time.monotonic()
        if now - self._last >= REPORT_EVERY_S:  # the first step is sent: the clock starts there
            self._last = now
            self._send(self._finished_steps + step, self._side.text(name, step, steps))

    def stage_done(self, name: str, steps: int, how: str) -> None:
        self._finished_steps += steps
        self._send(self._finished_steps, f"{name} {how}")

    def _send(self, done: int, stage: str) -> None:
        self.report.write(f"{self.unit.token}\tprogress\t{done}\t{self.planned}\t{stage}\n")


def _status(
    lines: list[bytes] | None, unit: Unit, name: str, progress: JobProgress | None = None
) -> int | None:
    """The exit status a worker reported for ``unit`` in ``lines`` (``None``: no report yet); its
    progress reports go to ``progress``."""
    for line in lines or []:
        token, _, rest = line.decode(errors="replace").partition("\t")
        fields = rest.split("\t", 3)
        if token == unit.token and rest.lstrip("-").isdigit():
            return int(rest)
        if token == unit.token and len(fields) == 4 and fields[0] == "progress":
            if fields[1].isdigit() and fields[2].isdigit():
                if progress is not None:
                    progress.unit_steps(unit_label(unit), int(fields[1]), int(fields[2]), fields[3])
                continue
        log.warning("%s: unexpected output of a worker: %r", name, line[:200])
    return None


def run_units_in_workers(
    script: str,
    argv: Sequence[str],
    units: Sequence[Unit],
    jobs: int,
    threads: int,
    logs: Path,
    name: str,
    progress: JobProgress | None = None,
) -> list[Unit]:
    """Evaluate ``units`` in at most ``jobs`` worker processes running ``python script ... --worker``.

    Returns the units that failed (each unit's output is in ``logs/<unit>.log``). ``progress`` (one
    bar for the whole job) follows every unit's training steps as the workers report them; units
    done, elapsed and ETA are also logged as units finish.
    """
    logs.mkdir(parents=True, exist_ok=True)
    warm_librosa_kernels()  # workers started together must not fill numba's cache together
    cmd = [sys.executable, script, *worker_argv(argv), "--threads", str(threads), "--worker"]
    env = _worker_env(threads)
    pending, failed = list(units), []
    workers: list[_Worker] = []
    start, done = time.time(), 0
    with selectors.DefaultSelector() as selector:
        try:
            while pending or workers:
                for worker in [w for w in workers if w.unit is None]:
                    if pending:
                        worker.send(pending.pop(0), logs, progress)
                    else:  # nothing left for it
                        selector.unregister(_stdout(worker))
                        workers.remove(worker)
                        worker.close()
                while pending and len(workers) < jobs:
                    proc = subprocess.Popen(cmd, stdin=subprocess.PIPE, stdout=subprocess.PIPE, env=env)
                    workers.append(_Worker(proc))
                    selector.register(_stdout(workers[-1]), selectors.EVENT_READ, workers[-1])
                    workers[-1].send(pending.pop(0), logs, progress)
                for key, _ in selector.select(timeout=1.0):
                    worker = key.data
                    unit = worker.unit
                    assert unit is not None
                    lines = worker.read_lines()
                    status = _status(lines, unit, name, progress)
                    if lines is not None and status is None:  # the unit is still running
                        continue
                    worker.unit = None
                    if status != 0:  # the worker has ended (lines is None: it died) or is ending
                        selector.unregister(_stdout(worker))
                        workers.remove(worker)
                        code = worker.close()
                        status = status if status is not None else (code or EXIT_PROBLEMS)
                    done += 1
                    if progress is not None:
                        progress.finish_unit(unit_label(unit))
                    if status != 0:
                        failed.append(unit)
                        log.error(
                            "%s: row %s seed %d failed (exit %d); see %s",
                            name, unit.row, unit.seed, status, logs / f"{cell_name(unit)}.log",
                        )  # fmt: skip
                    elapsed = time.time() - start
                    log.info(
                        "%s: row %s seed %d done (%d/%d units, %s elapsed, ETA %s)",
                        name, unit.row, unit.seed, done, len(units), format_duration(elapsed),
                        format_duration(elapsed / done * (len(units) - done)),
                    )  # fmt: skip
        finally:  # an interrupted parent leaves no worker behind
            for worker in workers:  # SIGTERM first: a worker in a training step checkpoints and stops
                if worker.proc.poll() is None:
                    worker.proc.terminate()
            for worker in workers:
                try:
                    worker.proc.wait(timeout=STOP_GRACE_S)
                except subprocess.TimeoutExpired:
                    worker.proc.kill()
                    worker.proc.wait()
    return failed


def _stdout(worker: _Worker) -> IO[bytes]:
    assert worker.proc.stdout is not None
    return worker.proc.stdout


def serve_units(run_unit: Callable[[Unit, UnitReporter], object], rows: Container[str]) -> int:
    """A ``--jobs`` worker: run each unit the parent sends on stdin, its output in the unit's log.

    ``run_unit(unit, reporter)`` tells ``reporter`` (a :class:`UnitReporter` writing to the parent's
    pipe) the unit's planned steps and its stages. Reports ``ROW:SEED<TAB>STATUS`` on the original
    stdout after each unit; stops at the end of the input (status 0) or after the first unit that
    fails (that unit's status).
    """
    report = os.fdopen(os.dup(1), "w", buffering=1)  # the parent's pipe, line by line
    home = os.dup(2)  # the parent's stderr: output between units
    _send_output_to(home)  # a stray print never lands in the status pipe
    try:
        while line := sys.stdin.readline():
            token, _, log_path = line.rstrip("\n").partition("\t")
            status = _run_unit_logged(run_unit, token, rows, Path(log_path), home, report)
            report.write(f"{token}\t{status}\n")
            if status != 0:
                return status
        return 0
    finally:
        report.close()
        os.close(home)


def serve_table_units(
    evaluate: Callable[..., Any], ctx: RunContext, configs: Mapping[str, DictConfig], *, reuse: bool
) -> int:
    """:func:`serve_units` for a table: each unit evaluated into its cell
    (:func:`~momu.engine.table_units.evaluate_unit`), its stages' steps reported to the parent."""

    def run_unit(unit: Unit, reporter: UnitReporter) -> object:
        reporter.planned = planned_steps(to_container(configs[unit.row]))
        ctx.progress = reporter
        try:
            return evaluate_unit(evaluate, ctx, configs[unit.row], unit, reuse=reuse)
        finally:
            ctx.progress = None

    return serve_units(run_unit, configs)


def _run_unit_logged(
    run_unit: Callable[[Unit, UnitReporter], object],
    token: str,
    rows: Container[str],
    log_path: Path,
    home: int,
    report: IO[str],
) -> int:
    with open(log_path, "wb") as log_file:
        _send_output_to(log_file.fileno())
        try:
            unit = Unit.parse(token)
            if unit.row not in rows:
                raise ValueError(f"--worker: unknown row {unit.row}")
            run_unit(unit, UnitReporter(report, unit))
            return 0
        except Interrupted as exc:  # SIGTERM / Ctrl-C: a stage in training wrote its checkpoint
            sys.stderr.write(f"{exc}\n")
            return exc.status
        except Exception:
            traceback.print_exc()
            return EXIT_PROBLEMS
        finally:
            _send_output_to(home)


def _send_output_to(fd: int) -> None:
    """Point this process's stdout and stderr (file descriptors 1 and 2) at ``fd``."""
    sys.stdout.flush()
    sys.stderr.flush()
    os.dup2(fd, 1)
    os.dup2(fd, 2)
