"""What a recipe declares for the table runner (:func:`momu.engine.table.run_table`): its columns,
rows, the paper's baseline rows, presets and the evaluate / calibrate functions, and the parsed
command line (:class:`TableArgs`)."""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from omegaconf import DictConfig

from momu.engine.context import RunContext
from momu.engine.scores import Scores

__all__ = ["PRESETS", "DEFAULT_SEEDS", "Column", "Row", "PaperRow", "TableArgs", "TableSpec"]

PRESETS = ("smoke", "cpu", "paper")
DEFAULT_SEEDS: Mapping[str, Sequence[int]] = {"smoke": (0,), "cpu": (0, 1, 2), "paper": (0, 1, 2)}
"""Seeds per preset without ``--seeds``: a committed table has three (DESIGN.md "Statistics")."""


@dataclass(frozen=True)
class Column:
    """One metric cell of the table.

    Attributes:
        key: the key in the row's result (``Scores.metrics``).
        label: as printed (with its arrow).
        higher_is_better: the column's direction.
        reducer: how the cell follows from per-clip components (``mean``, or ``f1``: LORIS F1 of the
            mean BCS and BHS; :data:`momu.engine.statistics.REDUCERS`), used by the paired comparisons.
        closer_to: a comparison variant (e.g. ``"ground truth"``) whose seed-level value is the
            column's reference: the cell is better the *closer* it is to it (MoFusion Table 2's
            "Diversity →"); ``higher_is_better`` is then ignored
            (:func:`momu.engine.table_results.compare_row`).
    """

    key: str
    label: str
    higher_is_better: bool
    reducer: str = "mean"
    closer_to: str | None = None


@dataclass(frozen=True)
class Row:
    """A row we run: config overrides applied over the base config and preset."""

    id: str
    name: str
    overrides: tuple[str, ...] = ()
    paper: Mapping[str, float] = field(default_factory=dict)
    preset_overrides: Mapping[str, tuple[str, ...]] = field(default_factory=dict)

    def overrides_for(self, preset: str) -> tuple[str, ...]:
        """The row's overrides under ``preset`` (``preset_overrides[preset]`` replaces ``overrides``)."""
        return tuple(self.preset_overrides.get(preset, self.overrides))


@dataclass(frozen=True)
class PaperRow:
    """A baseline row reported with the paper's numbers; momu does not re-run it."""

    name: str
    paper: Mapping[str, float]


@dataclass
class TableArgs:
    preset: str
    data: str
    out: Path
    rows: list[str]
    seeds: list[int]
    resume: bool
    tracker: str
    overrides: list[str]
    jobs: int = 1
    threads: int | None = None
    worker: bool = False


EvaluateFn = Callable[[RunContext, DictConfig, int], Scores | dict[str, float]]
CalibrateFn = Callable[[RunContext, DictConfig, int], Mapping[str, Scores | dict[str, float]]]


@dataclass
class TableSpec:
    """Everything a recipe declares.

    Attributes:
        name: folder name of the results (``momu_table7``).
        title: heading of ``results.md``.
        base_config: the YAML (path) or mapping every row starts from.
        presets: ``preset -> overrides`` (``smoke``, ``cpu``, ``paper``).
        preset_configs: ``preset -> YAML (path) or mapping`` used instead of ``base_config`` for that
            preset (the ``paper`` preset is its own complete file, so no cpu value leaks into it).
        columns: the metric cells, in print order.
        rows: the rows momu runs.
        evaluate: ``evaluate(ctx, row_config, seed) -> Scores`` for one row and seed: its cells and
            the per-clip evidence its comparisons rest on (:class:`momu.engine.scores.Scores`; a
            plain ``{column key: value}`` dict means cells only).
        calibrate: ``calibrate(ctx, base_config, seed) -> {row name: Scores}`` (ground truth, shuffled
            ground truth) computed with the same metric code, per seed (a learned metric's feature
            extractor is trained per seed, so its real-vs-real floor is too).
        baselines: the paper's other rows, reported and marked as not re-run.
        data_key: the config key of the dataset node (``--data`` sets it).
        notes: extra lines for ``results.md``.
        check: ``check(row_config)`` run on every row before anything is created (raise
            ``ValueError``/``OSError`` with a one-line reason, e.g. a dataset that does not open).
        default_seeds: ``preset -> seeds`` used without ``--seeds`` (committed reproductions use 3;
            a preset not listed uses the config's ``seed``).
        bootstrap_seed: seed of the comparisons' bootstrap (results are reproducible).
        baseline: a row id every other row is compared with, column by column
            (:func:`~momu.engine.table_results.versus_baseline`; results.json ``versus_baseline``).
        shared_parts: the name of a table whose trained stages this one reuses (its
            ``<out>/<shared_parts>/parts``; :func:`~momu.engine.table.shared_parts_root`).
    """

    name: str
    title: str
    base_config: str | Path | Mapping[str, Any]
    presets: Mapping[str, Sequence[str]]
    columns: Sequence[Column]
    rows: Sequence[Row]
    evaluate: EvaluateFn
    calibrate: CalibrateFn | None = None
    baselines: Sequence[PaperRow] = ()
    data_key: str = "dataset"
    notes: Sequence[str] = ()
    preset_configs: Mapping[str, str | Path | Mapping[str, Any]] = field(default_factory=dict)
    check: Callable[[DictConfig], None] | None = None
    shared_parts: str | None = None
    default_seeds: Mapping[str, Sequence[int]] = field(default_factory=lambda: dict(DEFAULT_SEEDS))
    bootstrap_seed: int = 0
    baseline: str | None = None
