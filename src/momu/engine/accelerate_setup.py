"""Creating the run's one :class:`accelerate.Accelerator`, its trackers and its CPU thread count.

Threads: ``accelerate launch`` sets ``OMP_NUM_THREADS=1`` for its children and a plain ``python``
run leaves torch at one thread per physical core, so the same command gave different weights (and
metrics) under the two. :func:`configure_threads` sets the count itself — ``MOMU_NUM_THREADS``, or
the physical cores divided by the processes on this machine — so both agree (torch and, through
threadpoolctl, numpy's and scipy's BLAS); it is recorded in ``results.json`` and in every stage key.

Trackers are quiet unless asked: wandb runs offline and silent (``WANDB_SILENT=true``) unless the
user sets ``WANDB_MODE`` / ``WANDB_SILENT``. Each stage logs its own step as ``<stage>/step`` and
wandb's own step stays monotonic across stages (wandb drops a step smaller than the last one).
"""

from __future__ import annotations

import gc
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import torch
from accelerate import Accelerator
from accelerate.utils import DataLoaderConfiguration, GradientAccumulationPlugin

__all__ = [
    "RunConfig",
    "make_accelerator",
    "finish_accelerator",
    "TRACKERS",
    "configure_threads",
    "define_stage_axis",
]

TRACKERS = ("wandb", "none")


@dataclass
class RunConfig:
    """Process-level settings of a run.

    Attributes:
        mixed_precision: ``no``, ``fp16`` or ``bf16``: accelerate's autocast of every forward pass.
            ``bf16`` also runs on CPU (tested: a few steps stay within 5 % of fp32); ``fp16`` needs a
            GPU. Part of every stage key (docs/performance.md).
        tracker: ``wandb`` (offline unless ``WANDB_MODE``/``wandb login`` says otherwise) or ``none``.
        project: tracker project name.
        seed: base seed; the data order uses it as is, noise uses ``seed + process index``.
    """

    mixed_precision: str = "no"
    tracker: str = "wandb"
    project: str = "momu"
    seed: int = 0


def configure_threads() -> int:
    """Set torch's intra-op thread count the same way under ``python`` and ``accelerate launch``.

    ``MOMU_NUM_THREADS`` wins; otherwise physical cores // local processes (at least 1).
    """
    given = os.environ.get("MOMU_NUM_THREADS")
    if given:
        try:
            threads = int(given)
        except ValueError:
            raise ValueError(f"MOMU_NUM_THREADS must be a positive integer, got {given!r}") from None
        if threads < 1:
            raise ValueError(f"MOMU_NUM_THREADS must be a positive integer, got {given!r}")
    else:
        import psutil

        cores = psutil.cpu_count(logical=False) or os.cpu_count() or 1
        local = int(os.environ.get("LOCAL_WORLD_SIZE", os.environ.get("WORLD_SIZE", "1")) or 1)
        threads = max(1, cores // max(1, local))
    torch.set_num_threads(threads)
    from threadpoolctl import threadpool_limits

    threadpool_limits(limits=threads)  # numpy / scipy BLAS too: OMP_NUM_THREADS=1 reaches them at import
    return threads


def define_stage_axis(accelerator: Accelerator, stage: str) -> None:
    """Plot a stage's curves against its own ``<stage>/step`` (wandb; other trackers need nothing)."""
    if not accelerator.is_main_process:
        return
    for tracker in getattr(accelerator, "trackers", []):
        if getattr(tracker, "name", "") != "wandb":
            continue
        run = tracker.tracker
        run.define_metric(f"{stage}/step")
        run.define_metric(f"{stage}/*", step_metric=f"{stage}/step")


def make_accelerator(
    cfg: RunConfig, out_dir: Path, run_name: str, tracked_config: dict[str, Any]
) -> Accelerator:
    """The run's accelerator: seedable data order, step-counted accumulation, trackers started.

    wandb runs offline by default (``WANDB_MODE=offline``) so nothing leaves the machine unless
    the user sets ``WANDB_MODE=online``; ``tracker="none"`` disables tracking.
    """
    if cfg.tracker not in TRACKERS:
        raise ValueError(f"tracker must be one of {', '.join(TRACKERS)}, got {cfg.tracker!r}")
    if cfg.mixed_precision not in {"no", "fp16", "bf16"}:
        raise ValueError(f"mixed_precision must be no, fp16 or bf16, got {cfg.mixed_precision!r}")
    configure_threads()
    log_with = None
    if cfg.tracker == "wandb":
        os.environ.setdefault("WANDB_MODE", "offline")
        os.environ.setdefault("WANDB_DIR", str(out_dir))
        os.environ.setdefault("WANDB_SILENT", "true")
        log_with = "wandb"
    # Several processes without CUDA: accelerate only forms the (gloo) process group when told
    # the run is on CPU; otherwise each process would silently train alone.
    multi_process_cpu = int(os.environ.get("WORLD_SIZE", "1")) > 1 and not torch.cuda.is_available()
    accelerator = Accelerator(
        cpu=multi_process_cpu,
        mixed_precision=cfg.mixed_precision,
        log_with=log_with,
        project_dir=str(out_dir),
        # non_blocking: host-to-GPU batch copies overlap compute (with train.pin_memory's pinned batches)
        dataloader_config=DataLoaderConfiguration(
            use_seedable_sampler=True, data_seed=cfg.seed, non_blocking=torch.cuda.is_available()
        ),
        gradient_accumulation_plugin=GradientAccumulationPlugin(num_steps=1, sync_with_dataloader=False),
    )
    if log_with is not None:
        accelerator.init_trackers(
            cfg.project, config=tracked_config, init_kwargs={"wandb": {"name": run_name}}
        )
    return accelerator


def finish_accelerator(accelerator: Accelerator) -> None:
    """End a run cleanly: every process waits, frees its prepared models, then ends training.

    A DDP reducer or gloo work object destroyed only at interpreter exit can abort the process
    (``terminate called without an active exception``) or hang it; releasing them while the
    process group is alive, then destroying the group, avoids both.
    """
    accelerator.wait_for_everyone()
    accelerator.free_memory()
    gc.collect()
    accelerator.end_training()
