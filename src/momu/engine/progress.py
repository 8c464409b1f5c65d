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
  config with no step-counted training shows its ETA after its first unit.
"""

from __future__ import annotations

import time
from collections.abc import Mapping
from typing import Any

from tqdm.auto import tqdm

__all__ = ["JobProgress", "planned_steps"]

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
        self._in_units = 0.0  # seconds spent in finished units
        self._unit_start: float | None = None
        self._planned = 0
        self._finished_steps = 0  # steps of this unit's stages already trained or reused
        self._current = 0  # steps of the stage in training
        self._stage = ""
        self._last = 0.0

    def start_unit(self, label: str, planned: int) -> None:
        """A unit begins; ``planned`` is its optimizer steps (:func:`planned_steps`, 0: unknown)."""
        self._unit_start = time.monotonic()
        self._planned, self._finished_steps, self._current = planned, 0, 0
        self._stage = label
        self._refresh(force=True)

    def stage_step(self, name: str, step: int, steps: int) -> None:
        """Stage ``name`` of the current unit is at ``step`` of ``steps``."""
        self._stage = f"{name} {step}/{steps}"
        self._current = step
        self._refresh()

    def stage_done(self, name: str, steps: int, how: str) -> None:
        """Stage ``name`` (``steps`` steps) was trained or reused (``how``)."""
        self._finished_steps += steps
        self._current = 0
        self._stage = f"{name} {how}"
        self._refresh(force=True)

    def finish_unit(self) -> None:
        if self._unit_start is not None:
            self._in_units += time.monotonic() - self._unit_start
        self._unit_start = None
        self.done += 1
        self._stage = ""
        self.bar.update(1)
        self._refresh(force=True)

    def eta(self) -> float | None:
        """Seconds left for the whole job, or ``None`` while nothing measurable is done."""
        fraction = float(self.done)
        spent = self._in_units
        if self._unit_start is not None:
            spent += time.monotonic() - self._unit_start
            if self._planned > 0:
                fraction += min(1.0, (self._finished_steps + self._current) / self._planned)
        if fraction <= 0 or spent <= 0:
            return None
        return spent / fraction * (self.units - fraction)

    def _refresh(self, force: bool = False) -> None:
        now = time.monotonic()
        if not force and now - self._last < _REFRESH_S:
            return
        self._last = now
        eta = self.eta()
        parts = [p for p in (self._stage, f"ETA {_duration(eta)}" if eta is not None else "") if p]
        self.bar.set_postfix_str(" | ".join(parts), refresh=True)

    def close(self) -> None:
        self.bar.close()
