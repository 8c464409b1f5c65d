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
import os
import signal
import sys
import time
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import torch
from omegaconf import DictConfig
from tqdm.contrib.logging import logging_redirect_tqdm

from momu.config import ConfigError, save_config, to_container
from momu.engine.accelerate_setup import TRACKERS, RunConfig, finish_accelerator, make_accelerator
from momu.engine.context import RunContext
from momu.engine.preflight import check_datasets, check_outputs, row_config
from momu.engine.progress import JobProgress, planned_steps
from momu.engine.provenance import git_commit, package_versions, peak_memory_mib, plugin_sources
from momu.engine.scores import Scores, as_scores
from momu.engine.signals import Interrupted, exit_status, stop_on_signals
from momu.engine.state import ResumeError
from momu.engine.table_report import render_markdown
from momu.engine.table_results import compare_row, orderings, summarise_seeds, versus_baseline
from momu.engine.table_spec import PRESETS, Column, PaperRow, Row, TableArgs, TableSpec
from momu.engine.table_units import (
    Unit,
    cell_path,
    evaluate_unit,
    format_duration,
    merge_timings,
)
from momu.engine.table_workers import run_units_in_workers, serve_table_units, unit_label
from momu.errors import EXIT_PROBLEMS, UsageParser, fail, one_line, stopped
from momu.io import atomic_write_text, write_json

__all__ = ["Column", "Row", "PaperRow", "TableSpec", "TableArgs", "run_table", "parse_table_args"]

log = logging.getLogger(__name__)


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
    parser.add_argument(
        "--jobs",
        type=int,
        default=1,
        help="run the (row, seed) units in N worker processes (single-process runs; default 1)",
    )
    parser.add_argument(
        "--threads",
        type=int,
        default=None,
        help="torch threads per process (default: 1 with --jobs > 1, else MOMU_NUM_THREADS or physical "
        "cores / processes); recorded",
    )
    parser.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)  # a --jobs worker
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
        jobs=ns.jobs,
        threads=ns.threads,
        worker=ns.worker,
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
    preset, data = spec.presets[args.preset], _data_overrides(spec, args.data)
    configs: dict[str, DictConfig] = {}
    for row_id in args.rows:
        row = known[row_id]
        # preset, what makes the row, the user's overrides, then --data (it survives `dataset=NAME`)
        configs[row_id] = row_config(
            spec.preset_configs.get(args.preset, spec.base_config),
            f"row {row_id} ({row.name})",
            row.overrides_for(args.preset),
            preset,
            args.overrides,
            data,
        )
    return configs


def shared_parts_root(spec: TableSpec, out: Path) -> Path | None:
    """Where the stages of ``spec``'s tables live under the output folder ``out`` (``None``: in the
    table's own ``<out>/<table>/parts``). Studies that reuse a table run's stages build their
    :class:`~momu.engine.context.RunContext` with it."""
    return out / spec.shared_parts / "parts" if spec.shared_parts else None


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


def _check_parallel(args: TableArgs, argv: Sequence[str] | None) -> None:
    if args.jobs < 1:
        raise ConfigError(f"--jobs: must be >= 1, got {args.jobs}")
    if args.threads is not None and args.threads < 1:
        raise ConfigError(f"--threads: must be >= 1, got {args.threads}")
    if args.jobs > 1 and int(os.environ.get("WORLD_SIZE", "1")) > 1:
        raise ConfigError("--jobs: runs single-process workers; with --num_processes > 1 use --jobs 1")
    if args.jobs > 1 and argv is not None:
        raise ConfigError("--jobs: needs the recipe to run as a script (python recipes/<table>.py ...)")


def _units(spec: TableSpec, configs: Mapping[str, DictConfig], seeds: Sequence[int]) -> list[Unit]:
    """Every (row, seed) unit in table order."""
    return [Unit(row.id, seed) for row in spec.rows if row.id in configs for seed in seeds]


def run_table(spec: TableSpec, argv: Sequence[str] | None = None) -> int:
    """Run a table recipe; returns the process exit status (docs/errors.md: 2 bad arguments, 143
    stopped by SIGTERM, 130 by Ctrl-C — one line each; a stage or extractor in training writes a
    checkpoint first, and ``--resume`` continues from it)."""
    logging.basicConfig(level=logging.INFO, format="%(levelname)s %(name)s: %(message)s")
    try:  # log lines go above the progress bars instead of through them
        with stop_on_signals(), logging_redirect_tqdm():
            return _run_table(spec, argv)
    except Interrupted as exc:  # one line, repeated after accelerate launch's own report
        return stopped(f"{spec.name}: {one_line(exc)}", exc.status)
    except ResumeError as exc:  # --resume found checkpoints, none intact
        return fail(spec.name, exc)
    except KeyboardInterrupt:  # before the handlers were installed
        sys.stderr.write(f"{spec.name}: interrupted (Ctrl-C)\n")
        return exit_status(signal.SIGINT)


def _run_table(spec: TableSpec, argv: Sequence[str] | None) -> int:
    args = parse_table_args(spec, argv)
    try:  # everything is checked before any folder, tracker or model is made
        _check_parallel(args, argv)
        configs = resolve_row_configs(spec, args)
        check_outputs(args.out, spec.name)
        if not args.worker:
            check_datasets(configs, spec.check)
    except ConfigError as exc:
        return fail(spec.name, exc)
    threads = args.threads or (1 if args.jobs > 1 else None)
    if threads is not None:  # configure_threads (make_accelerator) sets torch and BLAS to this
        os.environ["MOMU_NUM_THREADS"] = str(threads)
    first = next(iter(configs.values()))
    seeds = _seeds(spec, args, first)
    out = args.out / spec.name
    out.mkdir(parents=True, exist_ok=True)
    start = time.time()
    run_cfg = RunConfig(
        tracker="none" if args.worker else args.tracker,
        project="momu",
        seed=seeds[0],
        mixed_precision=str(first.get("mixed_precision", "no")),
    )
    accelerator = make_accelerator(run_cfg, out, spec.name, {"preset": args.preset, "rows": args.rows})
    ctx = RunContext(
        accelerator=accelerator, out_dir=out, resume=args.resume, parts_root=shared_parts_root(spec, args.out)
    )
    if args.worker:  # a --jobs worker: each unit the parent sends, evaluated into its cell
        status = serve_table_units(spec.evaluate, ctx, configs, reuse=args.resume)
        finish_accelerator(accelerator)
        return status
    units = _units(spec, configs, seeds)
    reuse = args.resume
    if args.jobs > 1:
        todo = [u for u in units if not (args.resume and cell_path(out, u, configs[u.row]).is_file())]
        script = str(Path(sys.argv[0]).resolve())
        job = JobProgress(spec.name, len(todo), enabled=accelerator.is_main_process)
        try:
            failed = run_units_in_workers(
                script, sys.argv[1:], todo, args.jobs, threads or 1, out / "logs", spec.name, job
            )
        finally:
            job.close()
        if failed:
            finish_accelerator(accelerator)
            units_text = ", ".join(f"{u.row} seed {u.seed}" for u in failed)
            return fail(
                spec.name, f"{len(failed)} unit(s) failed: {units_text}; see {out / 'logs'}", EXIT_PROBLEMS
            )
        reuse = True  # every cell was just written by a worker
    rows_out = []
    calibration: dict[str, list[Scores]] = {}
    stages: dict[str, str] = {}
    timings: dict[str, dict[str, float]] = {}
    progress = JobProgress(spec.name, len(units), enabled=accelerator.is_main_process)
    ctx.progress = progress
    try:
        done = 0
        for row in spec.rows:
            if row.id not in configs:
                continue
            cfg = configs[row.id]
            per_seed = []
            for seed in seeds:
                unit = Unit(row.id, seed)
                log.info("%s: row %s (%s), seed %d", spec.name, row.id, row.name, seed)
                progress.start_unit(unit_label(unit), planned_steps(to_container(cfg)))
                scores, trained, unit_timings = evaluate_unit(spec.evaluate, ctx, cfg, unit, reuse=reuse)
                progress.finish_unit()
                per_seed.append(scores)
                for folder, how in trained.items():
                    if stages.get(folder) != "trained":
                        stages[folder] = how
                merge_timings(timings, unit_timings)
                done += 1
                elapsed = time.time() - start
                log.info(
                    "%s: %d/%d units done, %s elapsed, ETA %s",
                    spec.name, done, len(units), format_duration(elapsed),
                    format_duration(elapsed / done * (len(units) - done)),
                )  # fmt: skip
            rows_out.append(_row_result(spec, row, cfg, per_seed))
        if spec.calibrate is not None:
            for seed in seeds:
                for name, cal in spec.calibrate(ctx, first, seed).items():
                    calibration.setdefault(name, []).append(as_scores(cal))
    except Interrupted:
        finish_accelerator(accelerator)
        raise
    finally:
        progress.close()
        ctx.progress = None
    for folder, how in ctx.trained.items():  # stages the calibration trained or reused
        stages.setdefault(folder, how)
    merge_timings(timings, ctx.timings)
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
        **(
            {
                "versus_baseline": versus_baseline(
                    rows_out, spec.columns, spec.baseline, bootstrap_seed=spec.bootstrap_seed
                )
            }
            if spec.baseline is not None and any(r["id"] == spec.baseline for r in rows_out)
            else {}
        ),
        "provenance": {
            "git_commit": git_commit(),
            "versions": package_versions(),
            "plugins": plugin_sources(),
            "num_processes": accelerator.num_processes,
            "jobs": args.jobs,
            "threads": _threads(),
            "device": str(accelerator.device)
            + (f" ({torch.cuda.get_device_name()})" if torch.cuda.is_available() else ""),
            "argv": list(argv if argv is not None else sys.argv[1:]),
            "wall_time_s": time.time() - start,
            "peak_memory_mib": peak_memory_mib(),
            "stages": stages,
            "timings": timings,
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
