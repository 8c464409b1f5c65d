"""The one training loop every method uses, on one CPU, N processes, or a multi-GPU node.

A method hands the loop a *stage*: the module to train, a dataset, a collate function and a
loss function. The loop owns everything else: accelerate ``prepare`` (once), gradient
accumulation, mixed precision, gradient clipping, per-process seeding, progress bars on the main
process, tracker logging, checkpoints every ``checkpoint_minutes`` of training (and/or every
``checkpoint_every`` steps), exact resume, and a checkpoint on SIGTERM (cluster pre-emption) — or
when the ``accelerate launch`` process that started it has gone — before exiting.

Checkpoints are crash-safe (:mod:`momu.engine.state`): a kill at any moment leaves the previous
checkpoint or the new one, never a half-written folder that resume would trust. Resuming skips and
reports incomplete folders, and refuses to start over silently when a checkpoint folder exists
but holds no complete checkpoint.

Fast paths (:mod:`momu.engine.fast_paths`, docs/performance.md): SDPA kernel choice, ``torch.compile``
of the backbones, fused AdamW, pinned / persistent data loading, each a field of
:class:`TrainConfig`; and no host-device synchronisation between logging steps (losses, logs and the
finiteness check stay on the device until a logging or checkpoint step).

Resume is exact: a run interrupted after step ``k`` and resumed from its checkpoint ends with the
same weights as an uninterrupted run, because the checkpoint holds the model, the optimizer, every
process's RNG states and the step, and the data order of epoch ``e`` is a pure function of
``(seed, e)`` (accelerate's seedable sampler), so the resumed run skips the batches already seen.
"""

from __future__ import annotations

import dataclasses
import logging
import math
import shutil
import time
from collections.abc import Callable, Mapping
from contextlib import closing
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import torch
from accelerate import Accelerator
from accelerate.utils import set_seed
from torch import nn
from torch.utils.data import DataLoader, Dataset
from tqdm.auto import tqdm

from momu.engine.accelerate_setup import define_stage_axis
from momu.engine.fast_paths import (
    StepMeter,
    attention_kernels,
    compile_backbones,
    loader_options,
    make_adamw,
    validate_fast_paths,
)
from momu.engine.signals import Interrupted, stop_flag
from momu.engine.state import (
    ResumeError,
    capture_rng,
    load_tensors_and_json,
    mark_complete,
    prune_checkpoints,
    recover_checkpoints,
    replace_checkpoint,
    restore_rng,
    resume_point,
    save_tensors_and_json,
)
from momu.io import read_json, write_json

__all__ = [
    "TrainConfig",
    "Preempted",
    "ResumeError",
    "LossFn",
    "train_stage",
    "WEIGHT_NEUTRAL_FIELDS",
    "KEYED_WHEN_SET",
    "without_later_defaults",
]

log = logging.getLogger(__name__)

LossFn = Callable[[nn.Module, Any], "torch.Tensor | tuple[torch.Tensor, Mapping[str, float | torch.Tensor]]"]
"""``loss_fn(model, batch)``: the loss, or ``(loss, logs)``; a log value may be a float or a detached
0-d tensor (a tensor costs no host-device synchronisation: it is read only at logging steps)."""


@dataclass
class TrainConfig:
    """Optimisation settings of one training stage (every field is a config key).

    ``batch_size`` is per process: the effective batch is
    ``batch_size × num_processes × grad_accum``.

    Checkpoints: every ``checkpoint_minutes`` of training time (default 10: a kill loses at most
    that much; ``benchmarks/bench_checkpoint.py`` measures the cost, well under 1 % of step time at
    every preset) and every ``checkpoint_every`` steps (0: off); both 0 checkpoints only at the
    end and on SIGTERM. They do not change the weights, so they are not part of a stage's key
    (:data:`WEIGHT_NEUTRAL_FIELDS`).
    """

    steps: int = 1000
    batch_size: int = 16
    lr: float = 1e-4
    weight_decay: float = 0.0
    beta1: float = 0.9
    beta2: float = 0.999
    grad_accum: int = 1
    max_grad_norm: float = 1.0  # 0 disables clipping
    warmup_steps: int = 0  # linear warm-up of the learning rate
    lr_schedule: str = "constant"  # after warm-up: "constant", or "cosine" decay to 0 at `steps`
    checkpoint_every: int = 0  # steps between checkpoints (0: no step interval)
    checkpoint_minutes: float = 10.0  # training minutes between checkpoints (0: no time interval)
    keep_checkpoints: int = 2  # newest checkpoints kept (0 keeps all)
    log_every: int = 25
    seed: int = 0
    num_workers: int = 0  # DataLoader worker processes (0: load in the training process)
    # fast paths (momu.engine.fast_paths, docs/performance.md)
    pin_memory: bool = True  # page-locked batches, on CUDA only
    persistent_workers: bool = False  # keep the workers alive across epochs (num_workers > 0)
    attention: str = "auto"  # SDPA kernels allowed: auto, math, flash, efficient, cudnn
    compile: str = "none"  # torch.compile backend of the backbones ("none": eager PyTorch)
    fused_optimizer: bool = False  # AdamW(fused=True) where the device supports it


WEIGHT_NEUTRAL_FIELDS = (
    "checkpoint_every",
    "checkpoint_minutes",
    "keep_checkpoints",
    "log_every",
    "pin_memory",
)
"""TrainConfig fields that do not change the trained weights (left out of stage keys).

``num_workers`` is *not* one: a dataset that draws randomness in ``__getitem__`` (MoFusion's
caption choice) draws it from each worker's RNG, so the worker count changes the batches.
"""

KEYED_WHEN_SET = ("persistent_workers", "attention", "compile", "fused_optimizer")
"""TrainConfig fields added after stage keys existed: in a stage's key only when not at their default.

Each may change the numbers (kernels round differently; persistent workers keep their RNG across
epochs), so a non-default value trains its own stage; at the default they are left out, so every
stage key written before they existed keeps its hash.
"""

_LATER_FIELDS = ("pin_memory", *KEYED_WHEN_SET)


def without_later_defaults(node: Any) -> Any:
    """``node`` with every TrainConfig-shaped mapping stripped of the later fields at their defaults.

    Hashes of configs (stage keys, cached table cells) taken before the fast-path fields existed
    stay the same: a mapping holding every :class:`TrainConfig` field loses ``pin_memory`` and
    :data:`KEYED_WHEN_SET` where they are at their defaults.
    """
    if isinstance(node, Mapping):
        out = {k: without_later_defaults(v) for k, v in node.items()}
        if _TRAIN_FIELDS <= set(out):
            out = {k: v for k, v in out.items() if not (k in _LATER_FIELDS and v == _DEFAULTS[k])}
        return out
    if isinstance(node, list):
        return [without_later_defaults(v) for v in node]
    return node


_DEFAULTS = {f.name: f.default for f in dataclasses.fields(TrainConfig)}
_TRAIN_FIELDS = set(_DEFAULTS)


class Preempted(Interrupted):
    """Raised after SIGTERM or SIGINT (or the launcher's exit) once the checkpoint is written."""

    def __init__(self, checkpoint: Path, reason: str = "SIGTERM", status: int = 143) -> None:
        super().__init__(
            f"stopped by {reason}; checkpoint written to {checkpoint}; rerun the same command with "
            "--resume to continue from it",
            status,
        )
        self.checkpoint = checkpoint


def _any_process(accelerator: Accelerator, *values: bool) -> tuple[bool, ...]:
    """Each flag OR-ed over the processes (one collective for all of them)."""
    if accelerator.num_processes == 1:
        return values
    flags = torch.tensor([1.0 if v else 0.0 for v in values], device=accelerator.device)
    summed = accelerator.reduce(flags, reduction="sum")
    return tuple(bool(x > 0) for x in summed.tolist())


def _save(
    accelerator: Accelerator, root: Path, step: int, model: nn.Module, optimizer: Any, cfg: TrainConfig
) -> Path:
    """Write checkpoint ``step`` under ``root`` crash-safely (all processes take part; see state.py)."""
    final = root / f"step_{step:08d}"
    staging = root / f".staging_{step:08d}"
    if accelerator.is_main_process:
        root.mkdir(parents=True, exist_ok=True)
        for note in recover_checkpoints(root):
            log.warning("%s", note)
        shutil.rmtree(staging, ignore_errors=True)
        staging.mkdir(parents=True)
    accelerator.wait_for_everyone()
    save_tensors_and_json(staging, f"rng_{accelerator.process_index}", capture_rng())
    if accelerator.is_main_process:
        save_tensors_and_json(staging, "model", accelerator.unwrap_model(model).state_dict())
        save_tensors_and_json(staging, "optimizer", optimizer.state_dict())
        write_json(staging / "trainer.json", {"step": step, "num_processes": accelerator.num_processes})
    accelerator.wait_for_everyone()  # every process's RNG state is in before the marker
    if accelerator.is_main_process:
        mark_complete(staging, step)
        replace_checkpoint(staging, final)
        prune_checkpoints(root, cfg.keep_checkpoints)
    accelerator.wait_for_everyone()
    return final


def _resume_point(accelerator: Accelerator, root: Path, name: str) -> Path | None:
    """The checkpoint to resume from after recovering interrupted saves; ``None``: nothing under ``root``.

    The newest complete checkpoint whose files match their recorded SHA-256; corrupt or incomplete
    ones are reported and skipped (:func:`~momu.engine.state.resume_point`).

    Raises:
        ResumeError: ``root`` holds checkpoint folders but none of them is complete and intact.
    """
    if accelerator.is_main_process:
        for note in recover_checkpoints(root):
            log.warning("stage %s: %s", name, note)
    accelerator.wait_for_everyone()
    return resume_point(root, f"stage {name!r}")


def _load(accelerator: Accelerator, checkpoint: Path, model: nn.Module, optimizer: Any) -> int:
    meta = read_json(checkpoint / "trainer.json")
    if meta["num_processes"] != accelerator.num_processes:
        raise ValueError(
            f"{checkpoint} was written by {meta['num_processes']} processes; resuming needs the same number "
            f"(this run has {accelerator.num_processes})"
        )
    accelerator.unwrap_model(model).load_state_dict(load_tensors_and_json(checkpoint, "model"), strict=True)
    optimizer.load_state_dict(load_tensors_and_json(checkpoint, "optimizer"))
    restore_rng(load_tensors_and_json(checkpoint, f"rng_{accelerator.process_index}"))
    return int(meta["step"])


LR_SCHEDULES = ("constant", "cosine")


def lr_factor(step: int, cfg: TrainConfig) -> float:
    """Learning-rate multiplier of optimizer step ``step`` (0-based): linear warm-up, then the schedule.

    ``"constant"`` keeps 1 after warm-up; ``"cosine"`` decays ``0.5 (1 + cos(π p))`` with ``p`` the
    fraction of the post-warm-up steps done, reaching 0 at ``cfg.steps``.
    """
    if cfg.lr_schedule not in LR_SCHEDULES:
        raise ValueError(f"lr_schedule: expected one of {LR_SCHEDULES}, got {cfg.lr_schedule!r}")
    if step < cfg.warmup_steps:
        return (step + 1) / cfg.warmup_steps
    if cfg.lr_schedule == "constant":
        return 1.0
    p = (step - cfg.warmup_steps) / max(1, cfg.steps - cfg.warmup_steps)
    return 0.5 * (1.0 + math.cos(math.pi * min(1.0, p)))


def train_stage(
    accelerator: Accelerator,
    *,
    name: str,
    model: nn.Module,
    dataset: Dataset[Any],
    loss_fn: LossFn,
    cfg: TrainConfig,
    checkpoint_root: Path,
    collate_fn: Callable[[list[Any]], Any] | None = None,
    resume: bool = False,
    on_step: Callable[[int, int], None] | None = None,
) -> nn.Module:
    """Train ``model`` on ``dataset`` for ``cfg.steps`` optimizer steps and return it unwrapped.

    Args:
        accelerator: the run's accelerator (created once per run with the gradient-accumulation
            plugin from :func:`momu.engine.make_accelerator`).
        name: stage name used in logs, progress bars and tracker keys.
        loss_fn: ``loss_fn(model, batch)`` returning the loss, or ``(loss, logs)``.
        checkpoint_root: folder of this stage's checkpoints (``step_<n>/``).
        resume: continue from the newest checkpoint under ``checkpoint_root`` if there is one.
        on_step: called as ``on_step(step, cfg.steps)`` after each optimizer step (and once at the
            start), on the main process (a job's progress line, :mod:`momu.engine.progress`).

    Raises:
        Preempted: SIGTERM arrived; a checkpoint was written first.
        ValueError: the dataset is smaller than one batch per process.
    """
    per_step = cfg.batch_size * accelerator.num_processes
    if len(dataset) < per_step:  # type: ignore[arg-type]
        raise ValueError(
            f"stage {name!r}: dataset has {len(dataset)} items, fewer than one batch "  # type: ignore[arg-type]
            f"({cfg.batch_size} per process × {accelerator.num_processes} processes)"
        )
    lr_factor(0, cfg)  # a bad schedule name fails before any work
    validate_fast_paths(cfg)
    set_seed(cfg.seed, device_specific=True)  # seed + process index: distinct noise per process
    model.to(accelerator.device)  # before the optimizer: fused kernels are chosen per device
    compile_backbones(model, cfg.compile)
    params = [p for p in model.parameters() if p.requires_grad]
    optimizer = make_adamw(params, cfg)
    loader = DataLoader(
        dataset,
        batch_size=cfg.batch_size,
        shuffle=True,
        drop_last=True,
        collate_fn=collate_fn,
        **loader_options(cfg, accelerator.device),
        # Its own generator: creating an iterator must not draw from the global RNG, or a run
        # resumed mid-epoch would see different noise from the uninterrupted one.
        generator=torch.Generator().manual_seed(cfg.seed),
    )
    # The data order is a function of the stage's seed, not of the run's first seed: a stage trains
    # the same whichever other seeds (or --jobs workers) the run has.
    accelerator.dataloader_config.data_seed = cfg.seed
    model, optimizer, loader = accelerator.prepare(model, optimizer, loader)
    accelerator.gradient_accumulation_steps = cfg.grad_accum
    accelerator.step = 0  # accumulation boundaries count from this stage's first micro-batch

    step = 0
    checkpoint = _resume_point(accelerator, checkpoint_root, name) if resume else None
    if checkpoint is not None:
        step = _load(accelerator, checkpoint, model, optimizer)
        log.info("stage %s: resumed from %s (step %d)", name, checkpoint, step)

    define_stage_axis(accelerator, name)
    batches = len(loader)
    micro = step * cfg.grad_accum
    epoch, skip = divmod(micro, batches)
    bar = tqdm(
        total=cfg.steps, initial=step, desc=name, disable=not accelerator.is_local_main_process, leave=False
    )
    if not accelerator.is_main_process:
        on_step = None
    if on_step is not None:
        on_step(step, cfg.steps)
    model.train()
    meter = StepMeter()
    last_save = time.monotonic()
    with stop_flag() as flag, attention_kernels(cfg.attention), closing(bar):  # closed also when stopped
        while step < cfg.steps:
            sampler = getattr(loader, "set_epoch", None)
            if sampler is not None:
                loader.set_epoch(epoch)
            batch_iter = accelerator.skip_first_batches(loader, skip) if skip else loader
            for batch in batch_iter:
                for group in optimizer.param_groups:
                    group["lr"] = cfg.lr * lr_factor(step, cfg)
                with accelerator.accumulate(model):
                    out = loss_fn(model, batch)
                    loss, logs = out if isinstance(out, tuple) else (out, {})
                    meter.watch(loss, step)
                    accelerator.backward(loss)
                    if accelerator.sync_gradients and cfg.max_grad_norm > 0:
                        accelerator.clip_grad_norm_(params, cfg.max_grad_norm)
                    optimizer.step()
                    optimizer.zero_grad(set_to_none=True)
                if not accelerator.sync_gradients:
                    continue
                step += 1
                bar.update(1)
                if on_step is not None:
                    on_step(step, cfg.steps)
                meter.add({"loss": loss, **logs})
                if step % cfg.log_every == 0 or step == cfg.steps:
                    count = cfg.log_every if step % cfg.log_every == 0 else step % cfg.log_every
                    meter.check(name)
                    means = {f"{name}/{k}": v / count for k, v in meter.take().items()}
                    # the tracker's own step stays monotonic across stages; each stage has its axis
                    accelerator.log({**means, f"{name}/step": step})
                    bar.set_postfix(loss=f"{means[f'{name}/loss']:.4g}")
                due = (
                    cfg.checkpoint_minutes > 0
                    and time.monotonic() - last_save >= 60.0 * cfg.checkpoint_minutes
                )
                stop, due = _any_process(
                    accelerator, flag.stop, due
                )  # any process that is due makes all save
                if stop:
                    meter.check(name)
                    raise Preempted(
                        _save(accelerator, checkpoint_root, step, model, optimizer, cfg),
                        flag.reason,
                        flag.status,
                    )
                every = cfg.checkpoint_every and step % cfg.checkpoint_every == 0
                if (every or due) and step < cfg.steps:
                    meter.check(name)
                    _save(accelerator, checkpoint_root, step, model, optimizer, cfg)
                    last_save = time.monotonic()
                if step >= cfg.steps:
                    break
            epoch, skip = epoch + 1, 0
    meter.check(name)
    _save(accelerator, checkpoint_root, step, model, optimizer, cfg)
    model.eval()
    return accelerator.unwrap_model(model, keep_fp32_wrapper=False)  # a plain module, as when reloaded


def steps_per_epoch(dataset_size: int, cfg: TrainConfig, num_processes: int) -> int:
    """Optimizer steps in one pass over the data (for choosing ``steps``)."""
    return max(1, math.floor(dataset_size / (cfg.batch_size * num_processes)) // cfg.grad_accum)
