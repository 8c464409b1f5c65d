"""The table runner every recipe calls: rows as config overrides, one shared run, one result file.

A recipe declares a :class:`TableSpec` — its base config, presets, rows (each a list of config
overrides plus the paper's numbers for its cells), the paper's baseline rows (reported, not
re-run) and an ``evaluate`` function — and calls :func:`run_table`. The runner

1. parses ``[--preset …] [--data synth|DIR] [--out DIR] [--rows …] [--seeds …] [--resume]
   [--tracker …] [key=value …]``;
2. resolves and validates every selected row's config *before any training* (a bad override, an
   unknown row or a missing dataset fails at once with a one-line reason, exit status 2);
3. creates one accelerator and runs each row for each seed through the spec's ``evaluate``,
   which trains through :class:`~momu.engine.context.RunContext` (stages shared by rows are
   trained once and cached under the output folder);
4. adds the calibration rows (ground truth, shuffled ground truth) the spec computes with the
   same metric code;
5. writes ``<out>/<table>/results.json`` and ``results.md`` with the paper's numbers side by side
   and the provenance a reader needs (commit, configs, seeds, versions, plugins, processes,
   device, wall time, peak memory).
"""

from __future__ import annotations

import argparse
import logging
import platform
import resource
import subprocess
import sys
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path
from typing import Any

import torch
from omegaconf import DictConfig

from momu.config import ConfigError, load_config, save_config, to_container
from momu.engine.accelerate_setup import TRACKERS, RunConfig, finish_accelerator, make_accelerator
from momu.engine.context import RunContext
from momu.engine.scores import Scores, as_scores
from momu.engine.table_report import render_markdown
from momu.engine.table_results import compare_row, orderings, summarise_seeds
from momu.engine.trainer import Preempted
from momu.io import atomic_write_text, write_json
from momu.registry import BUILTIN_SOURCE, REGISTRIES

__all__ = ["Column", "Row", "PaperRow", "TableSpec", "TableArgs", "run_table", "parse_table_args"]

log = logging.getLogger(__name__)

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


EvaluateFn = Callable[[RunContext, DictConfig, int], "Scores | dict[str, float]"]
CalibrateFn = Callable[[RunContext, DictConfig, int], Mapping[str, "Scores | dict[str, float]"]]


@dataclass
class TableSpec:
    """Everything a recipe declares.

    Attributes:
        name: folder name of the results (``momu_table7``).
        title: heading of ``results.md``.
        base_config: the YAML (path) or mapping every row starts from.
        presets: ``preset -> overrides`` (``smoke``, ``cpu``, ``paper``).
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
        default_seeds: ``preset -> seeds`` used without ``--seeds`` (committed reproductions use 3;
            a preset not listed uses the config's ``seed``).
        bootstrap_seed: seed of the comparisons' bootstrap (results are reproducible).
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
    default_seeds: Mapping[str, Sequence[int]] = field(default_factory=lambda: dict(DEFAULT_SEEDS))
    bootstrap_seed: int = 0


def _csv(text: str) -> list[str]:
    return [t.strip() for t in text.split(",") if t.strip()]


def parse_table_args(spec: TableSpec, argv: Sequence[str] | None = None) -> TableArgs:
    """Parse a recipe's command line."""
    default_preset = "paper" if torch.cuda.is_available() else "cpu"
    parser = argparse.ArgumentParser(
        prog=f"accelerate launch recipes/{spec.name}.py",
        description=spec.title,
    )
    parser.add_argument(
        "--preset",
        choices=PRESETS,
        default=default_preset,
        help=f"hyperparameter preset (default here: {default_preset})",
    )
    parser.add_argument(
        "--data", default="synth", help="'synth' (built-in synth_dance) or a dataset root folder"
    )
    parser.add_argument("--out", type=Path, default=Path("outputs"), help="output folder (default: outputs/)")
    parser.add_argument(
        "--rows", type=_csv, default=None, help="comma-separated row ids, e.g. #1,#7 or 1,7 (default: all)"
    )
    parser.add_argument(
        "--seeds",
        nargs="+",
        default=None,
        metavar="SEED",
        help="training seeds, e.g. --seeds 0 1 2 or 0,1,2 (default: 3 at cpu and paper, 1 at smoke)",
    )
    parser.add_argument("--resume", action="store_true", help="resume from the checkpoints under --out")
    parser.add_argument(
        "--tracker",
        choices=TRACKERS,
        default="wandb",
        help="experiment tracker (wandb is offline by default)",
    )
    parser.add_argument("overrides", nargs="*", metavar="key=value", help="config overrides for every row")
    ns = parser.parse_intermixed_args(argv)  # overrides may sit before or after the flags
    seeds, overrides = _split_seeds(parser, ns.seeds or [])
    return TableArgs(
        preset=ns.preset,
        data=ns.data,
        out=ns.out,
        rows=[_row_id(spec, r) for r in ns.rows] if ns.rows else [r.id for r in spec.rows],
        seeds=seeds,
        resume=ns.resume,
        tracker=ns.tracker,
        overrides=[*overrides, *ns.overrides],
    )


def _split_seeds(parser: argparse.ArgumentParser, tokens: Sequence[str]) -> tuple[list[int], list[str]]:
    """``--seeds`` tokens as seeds; ``key=value`` tokens that ``nargs`` swallowed go back to overrides."""
    seeds: list[int] = []
    overrides: list[str] = []
    for token in tokens:
        if "=" in token:
            overrides.append(token)
            continue
        for part in _csv(token):
            try:
                seeds.append(int(part))
            except ValueError:
                parser.error(f"--seeds: {part!r} is not an integer seed")
    if len(set(seeds)) != len(seeds):
        parser.error(f"--seeds: repeated seed in {seeds}")
    return seeds, overrides


def _row_id(spec: TableSpec, given: str) -> str:
    """``given`` as a row id; a bare number names the ``#``-prefixed row (``--rows 7`` is ``#7``)."""
    ids = {r.id for r in spec.rows}
    return f"#{given}" if given not in ids and f"#{given}" in ids else given


def _data_overrides(spec: TableSpec, data: str) -> list[str]:
    if data == "synth":
        return []
    root = Path(data)
    if not root.is_dir():
        raise ConfigError(f"--data {data}: dataset folder not found")
    return [f"{spec.data_key}.root={root.resolve()}"]


def resolve_row_configs(spec: TableSpec, args: TableArgs) -> dict[str, DictConfig]:
    """Every selected row's validated config; raises ConfigError before anything is trained."""
    known = {r.id: r for r in spec.rows}
    unknown = [r for r in args.rows if r not in known]
    if unknown:
        raise ConfigError(f"--rows: unknown row {', '.join(unknown)}; valid rows: {', '.join(known)}")
    if args.preset not in spec.presets:
        raise ConfigError(
            f"--preset {args.preset}: not defined for {spec.name}; valid: {', '.join(spec.presets)}"
        )
    preset = [*spec.presets[args.preset], *_data_overrides(spec, args.data)]
    configs: dict[str, DictConfig] = {}
    for row_id in args.rows:
        row = known[row_id]
        try:  # preset and data first, then what makes the row, then the user's overrides
            configs[row_id] = load_config(spec.base_config, [*preset, *row.overrides, *args.overrides])
        except ConfigError as exc:
            raise ConfigError(f"row {row_id} ({row.name}): {exc}") from None
    return configs


def _git_commit() -> str:
    try:
        out = subprocess.run(
            ["git", "rev-parse", "HEAD"],
            capture_output=True,
            text=True,
            check=True,
            cwd=Path(__file__).resolve().parent,
        )
        dirty = subprocess.run(
            ["git", "status", "--porcelain", "--untracked-files=no"],
            capture_output=True,
            text=True,
            cwd=Path(__file__).resolve().parent,
        ).stdout.strip()
        return out.stdout.strip() + ("+dirty" if dirty else "")
    except (OSError, subprocess.CalledProcessError):
        return "unknown"


def _versions() -> dict[str, str]:
    out = {"python": platform.python_version()}
    for dist in ("momu", "torch", "numpy", "scipy", "librosa", "diffusers", "accelerate", "omegaconf"):
        try:
            out[dist] = version(dist)
        except PackageNotFoundError:
            out[dist] = "not installed"
    return out


def _plugin_sources() -> dict[str, str]:
    found: dict[str, str] = {}
    for kind, registry in REGISTRIES.items():
        for name, source in registry.sources().items():
            if source != BUILTIN_SOURCE:
                found[f"{kind}.{name}"] = source
    return found


def _peak_memory_mib() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def _threads() -> int:
    return int(torch.get_num_threads())


def _seeds(spec: TableSpec, args: TableArgs, first: DictConfig) -> list[int]:
    if args.seeds:
        return list(args.seeds)
    if args.preset in spec.default_seeds:
        return [int(s) for s in spec.default_seeds[args.preset]]
    return [int(first.get("seed", 0))]


def _columns_json(spec: TableSpec) -> list[dict[str, Any]]:
    return [
        {
            "key": c.key,
            "label": c.label,
            "higher_is_better": c.higher_is_better,
            "reducer": c.reducer,
            "closer_to": c.closer_to,
        }
        for c in spec.columns
    ]


def _row_result(spec: TableSpec, row: Row, cfg: DictConfig, per_seed: list[Scores]) -> dict[str, Any]:
    summary = summarise_seeds(per_seed)
    return {
        "id": row.id,
        "name": row.name,
        **summary,
        "comparisons": compare_row(summary, spec.columns, bootstrap_seed=spec.bootstrap_seed),
        "paper": dict(row.paper),
        "config": to_container(cfg),
    }


def _calibration_result(per_seed: Mapping[str, list[Scores]]) -> list[dict[str, Any]]:
    out = []
    for name, scores in per_seed.items():
        summary = summarise_seeds(scores)
        out.append(
            {
                "name": name,
                "metrics": summary["metrics"],
                "interval": summary["interval"],
                "per_seed": summary["per_seed"],
            }
        )
    return out


def run_table(spec: TableSpec, argv: Sequence[str] | None = None) -> int:
    """Run a table recipe; returns the process exit status (2: bad arguments, 143: pre-empted)."""
    logging.basicConfig(level=logging.INFO, format="%(levelname)s %(name)s: %(message)s")
    args = parse_table_args(spec, argv)
    try:
        configs = resolve_row_configs(spec, args)
    except ConfigError as exc:
        sys.stderr.write(f"{spec.name}: error: {exc}\n")
        return 2
    first = next(iter(configs.values()))
    seeds = _seeds(spec, args, first)
    out = args.out / spec.name
    out.mkdir(parents=True, exist_ok=True)
    start = time.time()
    run_cfg = RunConfig(
        tracker=args.tracker,
        project="momu",
        seed=seeds[0],
        mixed_precision=str(first.get("mixed_precision", "no")),
    )
    accelerator = make_accelerator(run_cfg, out, spec.name, {"preset": args.preset, "rows": args.rows})
    ctx = RunContext(accelerator=accelerator, out_dir=out, resume=args.resume)
    rows_out = []
    calibration: dict[str, list[Scores]] = {}
    try:
        for row in spec.rows:
            if row.id not in configs:
                continue
            cfg = configs[row.id]
            per_seed = []
            for seed in seeds:
                log.info("%s: row %s (%s), seed %d", spec.name, row.id, row.name, seed)
                per_seed.append(as_scores(spec.evaluate(ctx, cfg, seed)))
            rows_out.append(_row_result(spec, row, cfg, per_seed))
        if spec.calibrate is not None:
            for seed in seeds:
                for name, scores in spec.calibrate(ctx, first, seed).items():
                    calibration.setdefault(name, []).append(as_scores(scores))
    except Preempted as exc:
        sys.stderr.write(f"{spec.name}: {exc}\n")
        finish_accelerator(accelerator)
        return 143
    result = {
        "table": spec.name,
        "title": spec.title,
        "preset": args.preset,
        "data": args.data,
        "seeds": seeds,
        "columns": _columns_json(spec),
        "rows": rows_out,
        "calibration": _calibration_result(calibration),
        "baselines": [{"name": b.name, "paper": dict(b.paper), "re_run": False} for b in spec.baselines],
        "orderings": orderings(rows_out, spec.columns, bootstrap_seed=spec.bootstrap_seed),
        "provenance": {
            "git_commit": _git_commit(),
            "versions": _versions(),
            "plugins": _plugin_sources(),
            "num_processes": accelerator.num_processes,
            "threads": _threads(),
            "device": str(accelerator.device)
            + (f" ({torch.cuda.get_device_name()})" if torch.cuda.is_available() else ""),
            "argv": list(argv if argv is not None else sys.argv[1:]),
            "wall_time_s": time.time() - start,
            "peak_memory_mib": _peak_memory_mib(),
            "stages": dict(ctx.trained),
        },
    }
    if accelerator.is_main_process:
        save_config(first, out / "config.yaml")
        write_json(out / "results.json", result)
        atomic_write_text(out / "results.md", render_markdown(result, spec.notes))
        log.info("%s: wrote %s", spec.name, out / "results.md")
    accelerator.wait_for_everyone()
    finish_accelerator(accelerator)
    return 0
