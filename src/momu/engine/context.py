"""A run's context: its accelerator, output folder, and the cache of trained stages.

Methods train through :meth:`RunContext.stage`. A stage is identified by a *key*: everything
that determines its weights (its config, the data config, the seed, the keys of the stages it
builds on). The trained weights are stored under ``<out>/parts/<name>-<hash(key)>/``, so

* rows of a table that share a stage (same key) train it once and reuse it;
* re-running one row, or resuming a run, loads the stages already trained instead of
  retraining them;
* a changed config changes the key and trains a new stage — never a stale reuse.
"""

from __future__ import annotations

import hashlib
import json
import logging
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from accelerate import Accelerator
from safetensors.torch import load_file, save_file
from torch import nn
from torch.utils.data import Dataset

from momu.engine.trainer import LossFn, TrainConfig, train_stage
from momu.io import atomic_path, read_json, write_json

__all__ = ["RunContext", "stage_key_hash"]

log = logging.getLogger(__name__)


def stage_key_hash(key: Mapping[str, Any]) -> str:
    """A short, stable hash of a stage key (JSON with sorted keys)."""
    text = json.dumps(key, sort_keys=True, default=str)
    return hashlib.sha256(text.encode("utf-8")).hexdigest()[:12]


@dataclass
class RunContext:
    """What a method needs from the run: the accelerator, where to write, whether to resume."""

    accelerator: Accelerator
    out_dir: Path
    resume: bool = False
    trained: dict[str, str] = field(default_factory=dict)  # stage folder -> "trained" | "reused"

    @property
    def parts_dir(self) -> Path:
        return self.out_dir / "parts"

    def stage(
        self,
        name: str,
        key: Mapping[str, Any],
        model: nn.Module,
        dataset: Dataset[Any] | Callable[[], Dataset[Any]],
        loss_fn: LossFn,
        cfg: TrainConfig,
        collate_fn: Callable[[list[Any]], Any] | None = None,
    ) -> nn.Module:
        """Train ``model`` as stage ``name`` — or load it if a stage with the same key was trained.

        ``dataset`` may be a callable so that reusing a cached stage does not build its data.
        Returns the trained (unwrapped) model in eval mode.
        """
        folder = self.parts_dir / f"{name}-{stage_key_hash(key)}"
        weights = folder / "model.safetensors"
        if weights.is_file():
            model.load_state_dict(load_file(str(weights)), strict=True)
            model.to(self.accelerator.device).eval()
            self.trained.setdefault(folder.name, "reused")  # "trained" stays if this run trained it
            log.info("stage %s: reusing %s", name, folder)
            return model
        data = dataset() if callable(dataset) else dataset
        trained = train_stage(
            self.accelerator,
            name=name,
            model=model,
            dataset=data,  # type: ignore[arg-type]
            loss_fn=loss_fn,
            cfg=cfg,
            checkpoint_root=folder / "checkpoints",
            collate_fn=collate_fn,
            resume=self.resume,
        )
        if self.accelerator.is_main_process:
            state = {k: v.detach().cpu().contiguous() for k, v in trained.state_dict().items()}
            with atomic_path(weights) as tmp:
                save_file(state, str(tmp))
            write_json(folder / "stage.json", {"name": name, "key": dict(key), "train": cfg.__dict__})
        self.accelerator.wait_for_everyone()
        self.trained[folder.name] = "trained"
        return trained

    def stage_record(self, folder: str) -> dict[str, Any]:
        """The JSON written beside a trained stage."""
        return dict(read_json(self.parts_dir / folder / "stage.json"))
