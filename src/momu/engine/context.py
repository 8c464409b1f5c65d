"""A run's context: its accelerator, output folder, and the cache of trained stages.

Methods train through :meth:`RunContext.stage`. A stage is identified by a *key*: everything
that determines its weights (its config, the data config, the seed, the keys of the stages it
builds on) plus what the run adds (:func:`run_facts`: the process count and the effective batch,
the CPU thread count, the device type and mixed precision — each changes the numbers), without
the training settings that do not (checkpoint and logging intervals). The trained weights are
stored under ``<out>/parts/<name>-<hash(key)>/``, so

* rows of a table that share a stage (same key) train it once and reuse it;
* re-running one row, or resuming a run, loads the stages already trained instead of
  retraining them;
* a changed config changes the key and trains a new stage — never a stale reuse, also not of a
  stage trained by a different number of processes.

A stage is seeded from ``(run seed, stage name)`` alone (:func:`stage_seed`): :meth:`RunContext.stage`
seeds torch, numpy and Python's RNG before it builds the stage's module (pass a *builder*, so the
initial weights are drawn there) and before it builds the data and trains, and the training loop
seeds its noise and data order from the same number. A stage's weights therefore do not depend on
what ran before it in the process — on whether the stages it builds on were trained just now or
loaded from the cache, nor on other rows or seeds — so a run resumed after a kill, at any moment,
trains every remaining stage exactly as an uninterrupted run does.
"""

from __future__ import annotations

import dataclasses
import fcntl
import functools
import hashlib
import json
import logging
import time
from collections import OrderedDict
from collections.abc import Callable, Iterator, Mapping
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, TypeVar

import torch
from accelerate import Accelerator
from accelerate.utils import set_seed
from safetensors.torch import load_file
from torch import nn
from torch.utils.data import Dataset

from momu.engine.progress import StageProgress
from momu.engine.provenance import git_commit
from momu.engine.trainer import (
    WEIGHT_NEUTRAL_FIELDS,
    LossFn,
    TrainConfig,
    train_stage,
    without_later_defaults,
)
from momu.io import read_json, write_json
from momu.weights_io import write_safetensors

__all__ = ["RunContext", "stage_key_hash", "run_facts", "stage_identity", "stage_seed", "STAGE_SEEDING"]

log = logging.getLogger(__name__)

T = TypeVar("T")

REMEMBERED = 4
"""How many values :meth:`RunContext.remember` keeps (the least recently used go first): a MoMu
unit needs three, its training clips with their normalisers and two evaluation sets."""


STAGE_SEEDING = "seed+name"
"""How stages are seeded (:func:`stage_seed`); part of every stage's identity, so a stage cached
under the former scheme (one seed for the whole method, drawn once at its start) is not mixed with
stages seeded this way."""


def stage_seed(seed: int, name: str) -> int:
    """The seed of stage ``name`` in a run seeded ``seed``: a function of the two alone (< 2**31)."""
    digest = hashlib.sha256(f"{int(seed)}/{name}".encode()).digest()
    return int.from_bytes(digest[:4], "big") & 0x7FFFFFFF


def stage_key_hash(key: Mapping[str, Any]) -> str:
    """A short, stable hash of a stage key (JSON with sorted keys).

    Weight-neutral training fields (checkpoint and logging intervals, :data:`WEIGHT_NEUTRAL_FIELDS`)
    and fast-path fields at their defaults are left out, here as in :func:`stage_identity`: a
    stage's key holds the hash of the stage it builds on (``after``), and changing
    ``checkpoint_every`` of stage 1 must not rename stages 2 and 3.
    """
    text = json.dumps(_without_neutral(without_later_defaults(dict(key))), sort_keys=True, default=str)
    return hashlib.sha256(text.encode("utf-8")).hexdigest()[:12]


def run_facts(accelerator: Accelerator, cfg: TrainConfig) -> dict[str, Any]:
    """What the run adds to a stage's key: everything besides the config that changes the weights."""
    n = int(accelerator.num_processes)
    return {
        "num_processes": n,
        "effective_batch": int(cfg.batch_size) * n * int(cfg.grad_accum),
        "threads": int(torch.get_num_threads()),
        "device": accelerator.device.type,
        "mixed_precision": str(accelerator.mixed_precision),
    }


def _without_neutral(node: Any) -> Any:
    """``node`` without the weight-neutral training fields under any ``train`` mapping."""
    if isinstance(node, Mapping):
        out = {}
        for k, v in node.items():
            if k == "train" and isinstance(v, Mapping):
                v = {tk: tv for tk, tv in v.items() if tk not in WEIGHT_NEUTRAL_FIELDS}
            out[k] = _without_neutral(v)
        return out
    if isinstance(node, list):
        return [_without_neutral(v) for v in node]
    return node


def stage_identity(key: Mapping[str, Any], accelerator: Accelerator, cfg: TrainConfig) -> dict[str, Any]:
    """The key naming a stage's folder: the method's key (less weight-neutral fields) + :func:`run_facts`.

    Fast-path fields at their defaults are left out too (:func:`~momu.engine.trainer.without_later_defaults`).
    """
    return {
        **_without_neutral(without_later_defaults(dict(key))),
        "run": run_facts(accelerator, cfg),
        "seeding": STAGE_SEEDING,
    }


@dataclass
class RunContext:
    """What a method needs from the run: the accelerator, where to write, whether to resume."""

    accelerator: Accelerator
    out_dir: Path
    resume: bool = False
    trained: dict[str, str] = field(default_factory=dict)  # stage folder -> "trained" | "reused[, ...]"
    timings: dict[str, dict[str, float]] = field(default_factory=dict)  # category -> wall_s, cpu_s, calls
    parts_root: Path | None = None  # a stage cache shared by several tables of one output folder
    derived: OrderedDict[str, Any] = field(default_factory=OrderedDict, repr=False)  # see remember()
    progress: StageProgress | None = None  # the table run's progress line: told every stage's steps

    @contextmanager
    def timed(self, category: str) -> Iterator[None]:
        """Add the wall and CPU (this process) seconds of the block to ``timings[category]``."""
        wall, cpu = time.perf_counter(), time.process_time()
        try:
            yield
        finally:
            rec = self.timings.setdefault(category, {"wall_s": 0.0, "cpu_s": 0.0, "calls": 0.0})
            rec["wall_s"] += time.perf_counter() - wall
            rec["cpu_s"] += time.process_time() - cpu
            rec["calls"] += 1

    def remember(self, key: Any, build: Callable[[], T]) -> T:
        """``build()``, computed once for ``key`` by this process and then handed out again.

        For what every unit of a table derives the same way from its config, such as a dataset
        split's clips and the normalisers fitted on them: a single-process table or a ``--jobs``
        worker then builds them once instead of once per unit. ``key`` (JSON-able) must hold
        everything the value depends on. The caller must not modify what it gets back: the next
        unit gets the same objects. The last :data:`REMEMBERED` values are kept.
        """
        text = json.dumps(key, sort_keys=True, default=str)
        if text in self.derived:
            self.derived.move_to_end(text)
        else:
            self.derived[text] = build()
            while len(self.derived) > REMEMBERED:
                self.derived.popitem(last=False)
        value: T = self.derived[text]
        return value

    @functools.cached_property
    def commit(self) -> str:
        """The git commit this run's code is at (:func:`~momu.engine.provenance.git_commit`)."""
        return git_commit()

    def mark_reused(self, name: str, record: Path) -> None:
        """Record that the cached stage ``name`` was reused; ``record`` is the JSON written beside it.

        The record's ``git_commit`` is the commit that trained the stage. A stage key hashes the
        configuration, not the code, so a stage trained by an older commit is reused after the code
        changed (docs/recipes.md). When that commit is not this run's, the entry says so:
        ``"reused, trained at <commit>"``, or ``"reused, trained at an unrecorded commit"`` for a
        stage cached before commits were recorded. "trained" stays if this run trained the stage.
        """
        trained_at = read_json(record).get("git_commit") if record.is_file() else None
        if trained_at == self.commit:
            how = "reused"
        else:
            how = f"reused, trained at {trained_at or 'an unrecorded commit'}"
        self.trained.setdefault(name, how)

    @property
    def parts_dir(self) -> Path:
        """Where trained stages are cached: ``parts_root``, else ``<out_dir>/parts``."""
        return self.parts_root if self.parts_root is not None else self.out_dir / "parts"

    @contextmanager
    def lock(self, name: str, *, wait: bool = True) -> Iterator[bool]:
        """Hold an exclusive lock on stage ``name`` of this output folder (``parts/.locks/<name>``).

        Parallel table jobs (``--jobs``) share the output folder; a job that needs a stage another
        job is training waits for it and then reuses it instead of training it twice. Within one
        accelerate run of several processes the processes already coordinate through barriers, so
        no file lock is taken there (one would deadlock against them).

        Yields whether the lock is held: always ``True`` when ``wait``; with ``wait=False`` it is
        ``False`` at once if another job holds the lock, so a job that needs several stages can
        train one nobody is training instead of waiting
        (:func:`momu.methods.momu.scoring.start_extractors`).
        """
        if self.accelerator.num_processes > 1:
            yield True
            return
        folder = self.parts_dir / ".locks"
        folder.mkdir(parents=True, exist_ok=True)
        with open(folder / f"{name}.lock", "a+") as handle:
            try:
                fcntl.flock(handle, fcntl.LOCK_EX if wait else fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                yield False
                return
            try:
                yield True
            finally:
                fcntl.flock(handle, fcntl.LOCK_UN)

    def stage_folder_name(self, name: str, key: Mapping[str, Any], cfg: TrainConfig) -> str:
        """The folder (under :attr:`parts_dir`) that :meth:`stage` trains or reuses for this key."""
        return f"{name}-{stage_key_hash(stage_identity(key, self.accelerator, cfg))}"

    def stage(
        self,
        name: str,
        key: Mapping[str, Any],
        model: nn.Module | Callable[[], nn.Module],
        dataset: Dataset[Any] | Callable[[], Dataset[Any]],
        loss_fn: LossFn,
        cfg: TrainConfig,
        collate_fn: Callable[[list[Any]], Any] | None = None,
    ) -> nn.Module:
        """Train ``model`` as stage ``name`` — or load it if a stage with the same key was trained.

        The stage is seeded from ``(cfg.seed, name)`` (:func:`stage_seed`) before anything else:
        ``model`` should be a *builder* (a callable returning the module) so that its initial
        weights are drawn from that seed, whatever ran before; a built module is taken as it is (a
        stage that continues training another stage's weights). ``dataset`` may be a callable so
        that reusing a cached stage does not build its data; it is built after the module. The
        training loop gets ``cfg`` with the stage's seed (its noise and data order). Returns the
        trained (unwrapped) model in eval mode.
        """
        identity = stage_identity(key, self.accelerator, cfg)
        folder = self.parts_dir / self.stage_folder_name(name, key, cfg)
        seeded = dataclasses.replace(cfg, seed=stage_seed(cfg.seed, name))
        with self.lock(folder.name):
            set_seed(seeded.seed)  # torch (and CUDA), numpy, Python: the same on every process
            module = model if isinstance(model, nn.Module) else model()
            return self._stage(name, identity, folder, module, dataset, loss_fn, seeded, collate_fn)

    def _stage(
        self,
        name: str,
        identity: Mapping[str, Any],
        folder: Path,
        model: nn.Module,
        dataset: Dataset[Any] | Callable[[], Dataset[Any]],
        loss_fn: LossFn,
        cfg: TrainConfig,
        collate_fn: Callable[[list[Any]], Any] | None,
    ) -> nn.Module:
        weights = folder / "model.safetensors"
        if weights.is_file():
            model.load_state_dict(load_file(str(weights)), strict=True)
            model.to(self.accelerator.device).eval()
            self.mark_reused(folder.name, folder / "stage.json")
            log.info("stage %s: reusing %s", name, folder)
            if self.progress is not None:
                self.progress.stage_done(name, cfg.steps, "reused")
            return model
        data = dataset() if callable(dataset) else dataset
        with self.timed(f"train {name}"):
            trained = train_stage(
                self.accelerator,
                name=name,
                model=model,
                dataset=data,
                loss_fn=loss_fn,
                cfg=cfg,
                checkpoint_root=folder / "checkpoints",
                collate_fn=collate_fn,
                resume=self.resume,
                on_step=None if self.progress is None else functools.partial(self.progress.stage_step, name),
            )
        if self.progress is not None:
            self.progress.stage_done(name, cfg.steps, "trained")
        if self.accelerator.is_main_process:
            write_safetensors(weights, trained.state_dict())
            write_json(
                folder / "stage.json",
                {
                    "name": name,
                    "key": dict(identity),
                    "train": cfg.__dict__,  # its seed is the stage's (stage_seed)
                    "git_commit": self.commit,
                },
            )
        self.accelerator.wait_for_everyone()
        self.trained[folder.name] = "trained"
        return trained

    def stage_record(self, folder: str) -> dict[str, Any]:
        """The JSON written beside a trained stage."""
        return dict(read_json(self.parts_dir / folder / "stage.json"))
