"""A table's work units — one row for one seed — their cached results, and running them in parallel.

A *unit* is ``(row, seed)``. Its result (the :class:`~momu.engine.scores.Scores` ``evaluate``
returned, plus the stages it trained or reused and its timings) is written to
``<out>/<table>/cells/<row>-seed<k>-<hash>.json`` where the hash covers the row's resolved config
and the seed, so a cell is never reused for another configuration.

``--jobs N`` runs the units of a single-process table in ``N`` worker processes (one thread each by
default; :mod:`momu.engine.table_workers`), each a long-lived ``python <recipe> --worker`` with the
same arguments that the parent sends one unit at a time; the workers share the output folder, and
stages two units share are trained once (the stage lock of
:meth:`momu.engine.context.RunContext.lock`, the second unit waits and reuses). Units are ordered
seed by seed within a row, so units running at the same time rarely wait on each other. The parent
then assembles the table from the cells. Every unit runs with the same thread count whatever
``N`` is, so the numbers do not depend on ``N`` (thread count changes floating-point reductions,
hence trained weights; it is recorded in the provenance).
"""

from __future__ import annotations

import hashlib
import json
import logging
import re
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from omegaconf import DictConfig

from momu.config import to_container
from momu.engine.context import RunContext
from momu.engine.scores import Scores, as_scores
from momu.engine.trainer import without_later_defaults
from momu.io import write_json

__all__ = [
    "Unit",
    "cell_name",
    "cell_path",
    "save_cell",
    "load_cell",
    "format_duration",
]

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class Unit:
    """One row of a table for one training seed."""

    row: str
    seed: int

    @property
    def token(self) -> str:
        """``ROW:SEED`` as passed to ``--unit``."""
        return f"{self.row}:{self.seed}"

    @classmethod
    def parse(cls, token: str) -> Unit:
        row, sep, seed = token.rpartition(":")
        if not sep or not row or not seed.lstrip("-").isdigit():
            raise ValueError(f"--unit: expected ROW:SEED (e.g. #7:0), got {token!r}")
        return cls(row, int(seed))


def _config_hash(cfg: DictConfig, seed: int) -> str:
    # fast-path fields at their defaults are left out: cells cached before they existed stay valid
    config = without_later_defaults(to_container(cfg))
    text = json.dumps({"config": config, "seed": seed}, sort_keys=True, default=str)
    return hashlib.sha256(text.encode("utf-8")).hexdigest()[:12]


def cell_name(unit: Unit) -> str:
    """A file-name-safe name of a unit (``#7`` seed 0 → ``7-seed0``)."""
    slug = re.sub(r"[^A-Za-z0-9_.=-]+", "_", unit.row).strip("_") or "row"
    return f"{slug}-seed{unit.seed}"


def cell_path(out: Path, unit: Unit, cfg: DictConfig) -> Path:
    """Where the result of ``unit`` with config ``cfg`` is cached."""
    return out / "cells" / f"{cell_name(unit)}-{_config_hash(cfg, unit.seed)}.json"


def save_cell(
    path: Path, scores: Scores, trained: Mapping[str, str], timings: Mapping[str, Mapping[str, float]]
) -> None:
    """Write a unit's result (atomically)."""
    write_json(
        path,
        {
            "scores": scores.to_json(),
            "stages": dict(trained),
            "timings": {k: dict(v) for k, v in timings.items()},
        },
    )


def load_cell(path: Path) -> tuple[Scores, dict[str, str], dict[str, dict[str, float]]]:
    """``(scores, stages, timings)`` of a cached unit."""
    data = json.loads(path.read_text())
    return Scores.from_json(data["scores"]), dict(data["stages"]), dict(data["timings"])


def format_duration(seconds: float) -> str:
    seconds = max(0.0, float(seconds))
    if seconds < 60:
        return f"{seconds:.0f} s"
    minutes, sec = divmod(int(round(seconds)), 60)
    hours, minutes = divmod(minutes, 60)
    return f"{hours} h {minutes:02d} min" if hours else f"{minutes} min {sec:02d} s"


def evaluate_unit(
    evaluate: Callable[[RunContext, DictConfig, int], Any],
    ctx: RunContext,
    cfg: DictConfig,
    unit: Unit,
    *,
    reuse: bool,
) -> tuple[Scores, dict[str, str], dict[str, dict[str, float]]]:
    """A unit's result: from its cell when ``reuse`` and cached, else evaluated (and cached)."""
    path = cell_path(ctx.out_dir, unit, cfg)
    if reuse and path.is_file():
        return load_cell(path)
    before_trained, before = dict(ctx.trained), {k: dict(v) for k, v in ctx.timings.items()}
    ctx.trained.clear()
    ctx.timings.clear()
    try:
        scores = as_scores(evaluate(ctx, cfg, unit.seed))
        trained, timings = dict(ctx.trained), {k: dict(v) for k, v in ctx.timings.items()}
    finally:
        ctx.trained.clear()
        ctx.trained.update(before_trained)
        ctx.timings.clear()
        ctx.timings.update(before)
    if ctx.accelerator.is_main_process:
        save_cell(path, scores, trained, timings)
    return scores, trained, timings


def merge_timings(total: dict[str, dict[str, float]], part: Mapping[str, Mapping[str, float]]) -> None:
    for key, rec in part.items():
        into = total.setdefault(key, {"wall_s": 0.0, "cpu_s": 0.0, "calls": 0.0})
        for field_name, value in rec.items():
            into[field_name] = into.get(field_name, 0.0) + float(value)
