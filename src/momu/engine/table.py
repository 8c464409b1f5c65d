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

import logging
import math
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

from momu.config import ConfigError, save_config, to_container
from momu.engine.accelerate_setup import TRACKERS, RunConfig, finish_accelerator, make_accelerator
from momu.engine.context import RunContext
from momu.engine.preflight import check_datasets, check_outputs, row_config
from momu.engine.trainer import Preempted
from momu.errors import EXIT_PREEMPTED, UsageParser, fail
from momu.io import atomic_write_text, write_json
from momu.registry import BUILTIN_SOURCE, REGISTRIES

__all__ = ["Column", "Row", "PaperRow", "TableSpec", "TableArgs", "run_table", "parse_table_args"]

log = logging.getLogger(__name__)

PRESETS = ("smoke", "cpu", "paper")


@dataclass(frozen=True)
class Column:
    """One metric cell of the table: ``key`` in the row's result dict, ``label`` as printed."""

    key: str
    label: str
    higher_is_better: bool


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


EvaluateFn = Callable[[RunContext, DictConfig, int], dict[str, float]]
CalibrateFn = Callable[[RunContext, DictConfig], dict[str, dict[str, float]]]


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
        evaluate: ``evaluate(ctx, row_config, seed) -> {column key: value}`` for one row and seed.
        calibrate: ``calibrate(ctx, base_config) -> {row name: {column key: value}}``
            (ground truth, shuffled ground truth) computed with the same metric code.
        baselines: the paper's other rows, reported and marked as not re-run.
        data_key: the config key of the dataset node (``--data`` sets it).
        notes: extra lines for ``results.md``.
        check: ``check(row_config)`` run on every row before anything is created (raise
            ``ValueError``/``OSError`` with a one-line reason, e.g. a dataset that does not open).
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
    check: Callable[[DictConfig], None] | None = None


def _csv(text: str) -> list[str]:
    return [t.strip() for t in text.split(",") if t.strip()]


def parse_table_args(spec: TableSpec, argv: Sequence[str] | None = None) -> TableArgs:
    """Parse a recipe's command line."""
    default_preset = "paper" if torch.cuda.is_available() else "cpu"
    parser = UsageParser(
        prog=f"accelerate launch recipes/{spec.name}.py",
        error_prefix=spec.name,
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
        type=lambda s: [int(x) for x in _csv(s)],
        default=None,
        help="comma-separated seeds (default: the config's seed)",
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
    return TableArgs(
        preset=ns.preset,
        data=ns.data,
        out=ns.out,
        rows=[_row_id(spec, r) for r in ns.rows] if ns.rows else [r.id for r in spec.rows],
        seeds=ns.seeds or [],
        resume=ns.resume,
        tracker=ns.tracker,
        overrides=list(ns.overrides),
    )


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
    preset, data = spec.presets[args.preset], _data_overrides(spec, args.data)
    configs: dict[str, DictConfig] = {}
    for row_id in args.rows:
        row = known[row_id]
        # preset, what makes the row, the user's overrides, then --data (it survives `dataset=NAME`)
        configs[row_id] = row_config(
            spec.base_config, f"row {row_id} ({row.name})", row.overrides, preset, args.overrides, data
        )
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


def _aggregate(per_seed: list[dict[str, float]]) -> tuple[dict[str, float], dict[str, float]]:
    keys = sorted({k for result in per_seed for k in result})
    mean, std = {}, {}
    for key in keys:
        values = [r[key] for r in per_seed if key in r]
        mean[key] = float(sum(values) / len(values))
        std[key] = (
            float(math.sqrt(sum((v - mean[key]) ** 2 for v in values) / (len(values) - 1)))
            if len(values) > 1
            else 0.0
        )
    return mean, std


def _fmt(value: float | None) -> str:
    if value is None:
        return "—"
    if not math.isfinite(value):
        return str(value)
    return f"{value:.3g}" if abs(value) < 1000 else f"{value:.0f}"


def render_markdown(spec: TableSpec, result: Mapping[str, Any]) -> str:
    """``results.md``: our numbers with the paper's beside them, calibration rows, provenance."""
    cols = list(spec.columns)
    header = "| id | row | " + " | ".join(f"{c.label} ours | {c.label} paper" for c in cols) + " |"
    lines = [
        f"# {spec.title}",
        "",
        f"Preset `{result['preset']}`, data `{result['data']}`, seeds "
        f"{result['seeds']}, {result['provenance']['num_processes']} process(es) on "
        f"{result['provenance']['device']}, {result['provenance']['wall_time_s']:.0f} s.",
        "",
        header,
        "|" + "---|" * (2 + 2 * len(cols)),
    ]
    for row in result["rows"]:
        cells = []
        for c in cols:
            ours = row["metrics"].get(c.key)
            spread = row.get("std", {}).get(c.key, 0.0)
            text = _fmt(ours) + (f" ± {_fmt(spread)}" if spread else "")
            cells += [text, _fmt(row["paper"].get(c.key))]
        lines.append(f"| {row['id']} | {row['name']} | " + " | ".join(cells) + " |")
    for row in result["calibration"]:
        cells = []
        for c in cols:
            cells += [_fmt(row["metrics"].get(c.key)), "—"]
        lines.append(f"| cal | {row['name']} (calibration) | " + " | ".join(cells) + " |")
    for row in result["baselines"]:
        cells = []
        for c in cols:
            cells += ["not re-run", _fmt(row["paper"].get(c.key))]
        lines.append(f"| paper | {row['name']} | " + " | ".join(cells) + " |")
    lines += [
        "",
        "Arrows: "
        + ", ".join(f"{c.label} {'higher' if c.higher_is_better else 'lower'} is better" for c in cols)
        + ".",
        "Baseline rows marked *not re-run* are the paper's numbers, reported for reference.",
        "Calibration rows use the same metric code on ground truth and on ground truth with music and "
        "motion shuffled across clips: they show what *good* and *chance* are on this data.",
    ]
    lines += ["", *spec.notes] if spec.notes else []
    prov = result["provenance"]
    lines += [
        "",
        "## Provenance",
        "",
        f"- commit: `{prov['git_commit']}`",
        f"- versions: {', '.join(f'{k} {v}' for k, v in prov['versions'].items())}",
        f"- plugins: {prov['plugins'] or 'none'}",
        f"- peak memory (main process): {prov['peak_memory_mib']:.0f} MiB",
        f"- stages: {', '.join(f'{k} ({v})' for k, v in prov['stages'].items()) or 'none'}",
        "- resolved configs: in results.json (`rows[].config`).",
    ]
    return "\n".join(lines) + "\n"


def run_table(spec: TableSpec, argv: Sequence[str] | None = None) -> int:
    """Run a table recipe; returns the process exit status (2: bad arguments, 143: pre-empted)."""
    logging.basicConfig(level=logging.INFO, format="%(levelname)s %(name)s: %(message)s")
    args = parse_table_args(spec, argv)
    try:  # everything is checked before any folder, tracker or model is made
        configs = resolve_row_configs(spec, args)
        check_outputs(args.out, spec.name)
        check_datasets(configs, spec.check)
    except ConfigError as exc:
        return fail(spec.name, exc)
    first = next(iter(configs.values()))
    seeds = args.seeds or [int(first.get("seed", 0))]
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
    try:
        for row in spec.rows:
            if row.id not in configs:
                continue
            cfg = configs[row.id]
            per_seed = []
            for seed in seeds:
                log.info("%s: row %s (%s), seed %d", spec.name, row.id, row.name, seed)
                per_seed.append(spec.evaluate(ctx, cfg, seed))
            mean, std = _aggregate(per_seed)
            rows_out.append(
                {
                    "id": row.id,
                    "name": row.name,
                    "metrics": mean,
                    "std": std,
                    "per_seed": per_seed,
                    "paper": dict(row.paper),
                    "config": to_container(cfg),
                }
            )
        calibration = spec.calibrate(ctx, first) if spec.calibrate is not None else {}
    except Preempted as exc:
        sys.stderr.write(f"{spec.name}: {exc}\n")
        finish_accelerator(accelerator)
        return EXIT_PREEMPTED
    result = {
        "table": spec.name,
        "title": spec.title,
        "preset": args.preset,
        "data": args.data,
        "seeds": seeds,
        "columns": [
            {"key": c.key, "label": c.label, "higher_is_better": c.higher_is_better} for c in spec.columns
        ],
        "rows": rows_out,
        "calibration": [{"name": name, "metrics": metrics} for name, metrics in calibration.items()],
        "baselines": [{"name": b.name, "paper": dict(b.paper), "re_run": False} for b in spec.baselines],
        "provenance": {
            "git_commit": _git_commit(),
            "versions": _versions(),
            "plugins": _plugin_sources(),
            "num_processes": accelerator.num_processes,
            "num_threads": torch.get_num_threads(),
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
        atomic_write_text(out / "results.md", render_markdown(spec, result))
        log.info("%s: wrote %s", spec.name, out / "results.md")
    accelerator.wait_for_everyone()
    finish_accelerator(accelerator)
    return 0
