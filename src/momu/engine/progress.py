"""The progress line of a whole table run: units done, the stage training now, elapsed time and ETA.

A table run is a list of units (row × seed), each of which trains (or reuses) a few stages and then
evaluates. Per-stage bars alone tell nothing about the job: :class:`JobProgress` is one bar on the
main process, counting units, whose line also shows the stage in training with its step (updated
every step, :meth:`RunContext.stage <momu.engine.context.RunContext.stage>` reports them) and an
ETA for the whole job from the first unit's first steps on:

* a unit's *planned* work is the optimizer steps of the training configs in its config
  (:func:`planned_steps`: every ``TrainConfig``-shaped node, e.g. MoMu's ``train_music_vae``,
  ``train_motion_vae``, ``train_diffusion``); a stage reused from the cache counts as done at once;
* the fraction of the job done is ``(units done + steps done in this unit / its planned steps) /
  units``, and the ETA is the time spent in units so far scaled to the rest. Until a unit has
  finished, evaluation time is not in the estimate (it enters with the first finished unit); a
  config with no step-counted training shows its ETA after its first unit. The learned metrics'
  extractors (trained once per run by the first unit that needs them, before its stages) show their
  steps with the time they have left at their own rate (:meth:`JobProgress.side_step`), and their
  steps join that unit's planned work when they begin: the job's ETA is there from the extractors'
  first steps (rough until the stages run: it prices a stage step like an extractor step).

With ``--jobs N`` several units run at once in worker processes: each worker reports its unit's steps
to the parent (:class:`momu.engine.table_workers.UnitReporter`), whose one bar follows them all
(:meth:`JobProgress.unit_steps`); the fraction done adds every running unit's part, and the time is
the wall time during which some unit was running, so the ETA holds for one process and for ``N``.
"""

from __future__ import annotations

import time
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any, Protocol

from tqdm.auto import tqdm

__all__ = ["JobProgress", "SideWorkClock", "StageProgress", "planned_steps"]

_REFRESH_S = 1.0


def planned_steps(tree: Any) -> int:
    """The sum of ``steps`` over every ``TrainConfig``-shaped mapping of a plain config tree."""
    from momu.engine.trainer import TrainConfig

    fields = set(TrainConfig.__dataclass_fields__)
    if isinstance(tree, Mapping):
        own = int(tree["steps"]) if fields <= set(tree) and isinstance(tree.get("steps"), int) else 0
        return own + sum(planned_steps(v) for v in tree.values())
    if isinstance(tree, (list, tuple)):
        return sum(planned_steps(v) for v in tree)
    return 0


def _duration(seconds: float) -> str:
    from momu.engine.table_units import format_duration

    return format_duration(seconds)


class SideWorkClock:
    """The line of work outside the planned steps (an extractor in training): its step and, from its
    own rate so far, the time it has left (``motion extractor 300/2000, 2 min 10 s left``)."""

    def __init__(self) -> None:
        self._started: dict[str, tuple[float, int]] = {}

    def text(self, name: str, step: int, steps: int) -> str:
        now = time.monotonic()
        start, first = self._started.setdefault(name, (now, step))
        if step <= first or now <= start:
            return f"{name} {step}/{steps}"
        left = (now - start) / (step - first) * max(0, steps - step)
        return f"{name} {step}/{steps}, {_duration(left)} left"


class StageProgress(Protocol):
    """What :class:`~momu.engine.context.RunContext` tells about its stages (``ctx.progress``)."""

    def stage_step(self, name: str, step: int, steps: int) -> None: ...

    def stage_done(self, name: str, steps: int, how: str) -> None: ...

    def side_step(self, name: str, step: int, steps: int) -> None: ...


@dataclass
class _RunningUnit:
    """A unit in progress: its planned steps, the steps of its finished stages and of the current one."""

    start: float
    planned: int = 0
    finished_steps: int = 0
    current: int = 0
    side: dict[str, bool] = field(default_factory=dict)  # side work in ``planned``: name -> finished
    stage: str = ""

    def fraction(self) -> float:
        return min(1.0, (self.finished_steps + self.current) / self.planned) if self.planned > 0 else 0.0


class JobProgress:
    """One bar for a table run (see the module docstring); disabled off the main process."""

    def __init__(self, name: str, units: int, *, enabled: bool = True) -> None:
        self.units = units
        self.done = 0
        self.bar = tqdm(
            total=units,
            desc=name,
            unit="unit",
            disable=not enabled,
            dynamic_ncols=True,
            bar_format="{desc}: {n_fmt}/{total_fmt} units [{elapsed}]{postfix}",
        )
        self._busy = 0.0  # seconds during which some unit was running, up to _busy_since
        self._busy_since: float | None = None
        self._running: dict[str, _RunningUnit] = {}
        self._latest = ""  # the unit stage_step / stage_done / finish_unit talk about
        self._last = 0.0
        self._side = SideWorkClock()

    def start_unit(self, label: str, planned: int) -> None:
        """Unit ``label`` begins; ``planned`` is its optimizer steps (:func:`planned_steps`, 0: unknown)."""
        now = time.monotonic()
        if not self._running:
            self._busy_since = now
        self._running[label] = _RunningUnit(start=now, planned=planned, stage=label)
        self._latest = label
        self._refresh(force=True)

    def stage_step(self, name: str, step: int, steps: int) -> None:
        """Stage ``name`` of the latest unit is at ``step`` of ``steps``."""
        unit = self._running.get(self._latest)
        if unit is not None:
            unit.stage, unit.current = f"{name} {step}/{steps}", step
        self._refresh()

    def side_step(self, name: str, step: int, steps: int) -> None:
        """Work of the latest unit outside its configured stages (a metric's extractor, trained by its
        first evaluation) is at ``step`` of ``steps``: shown with its own time left, and its steps join
        the unit's planned work when they begin, so the job has an ETA from its first minutes."""
        unit = self._running.get(self._latest)
        if unit is not None:
            if name not in unit.side:
                unit.side[name] = False
                unit.planned += steps
            if unit.side[name]:  # already finished and counted
                return
            unit.stage, unit.current = self._side.text(name, step, steps), step
            if step >= steps:
                unit.side[name] = True
                unit.finished_steps, unit.current = unit.finished_steps + steps, 0
        self._refresh()

    def stage_done(self, name: str, steps: int, how: str) -> None:
        """Stage ``name`` (``steps`` steps) of the latest unit was trained or reused (``how``)."""
        unit = self._running.get(self._latest)
        if unit is not None:
            unit.finished_steps += steps
            unit.current = 0
            unit.stage = f"{name} {how}"
        self._refresh(force=True)

    def unit_steps(self, label: str, steps_done: int, planned: int, stage: str) -> None:
        """A ``--jobs`` worker's report on unit ``label``: ``steps_done`` of ``planned``, now ``stage``."""
        unit = self._running.get(label)
        if unit is None:
            return
        unit.planned, unit.finished_steps, unit.current, unit.stage = planned, steps_done, 0, stage
        self._refresh()

    def finish_unit(self, label: str | None = None) -> None:
        """Unit ``label`` (default: the latest) has ended."""
        self._running.pop(self._latest if label is None else label, None)
        if not self._running and self._busy_since is not None:
            self._busy += time.monotonic() - self._busy_since
            self._busy_since = None
        self.done += 1
        self.bar.update(1)
        self._refresh(force=True)

    def eta(self) -> float | None:
        """Seconds left for the whole job, or ``None`` while nothing measurable is done."""
        fraction = self.done + sum(unit.fraction() for unit in self._running.values())
        spent = self._busy
        if self._busy_since is not None:
            spent += time.monotonic() - self._busy_since
        if fraction <= 0 or spent <= 0:
            return None
        return spent / fraction * (self.units - fraction)

    def _stage_text(self) -> str:
        if len(self._running) == 1:
            return next(iter(self._running.values())).stage
        texts = [
            label if unit.stage == label else f"{label}: {unit.stage}"
            for label, unit in self._running.items()
        ]
        return "; ".join(texts)

    def _refresh(self, force: bool = False) -> None:
        now = time.monotonic()
        if not force and now - self._last < _REFRESH_S:
            return
        self._last = now
        eta = self.eta()
        parts = [p for p in (self._stage_text(), f"ETA {_duration(eta)}" if eta is not None else "") if p]
        self.bar.set_postfix_str(" | ".join(parts), refresh=True)

    def close(self) -> None:
        self.bar.close()
