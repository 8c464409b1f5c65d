"""Train one method's models on a dataset without running a table: what ``momu train`` does.

Output layout (the recipes' own, so ``momu generate --model`` reads either):

    <out>/parts/<stage>-<hash>/   trained stages (the run context's cache: a re-run reuses them)
    <out>/models/<method>-<hash>/ the saved model (``momu generate --model <out>`` finds it)
    <out>/config.yaml             the resolved config
    <out>/train.json              provenance: command, commit, data hashes, seed, versions, wall time

A method plugs in through the method registry (``METHODS``): its factory builds an object with
``fit(ctx, dataset, data_key, seed)`` returning a model with ``save(folder)``, and :data:`RECIPES` maps
its name to the module holding its base config and presets (``BASE_CONFIG``, ``PRESETS``), so that
mofusion and harmogan join by adding a line. The dataset fixes the motion shape: the encoder's joint
count and dimension are set from the training clips (``method.encoder.num_joints``/``joint_dims``),
and the frame rate is each clip's own.
"""

from __future__ import annotations

import hashlib
import importlib
import json
import logging
import sys
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from momu.config import ConfigError, build_component, load_config, save_config, to_container
from momu.errors import one_line
from momu.io import write_json

__all__ = ["RECIPES", "TrainResult", "train_config", "train_method", "detect_dataset", "find_model"]

log = logging.getLogger(__name__)

RECIPES: dict[str, str] = {"momu": "momu.methods.momu.recipes"}
"""Method name → module with ``BASE_CONFIG`` (a YAML path) and ``PRESETS`` (name → overrides), and
optionally ``PRESET_CONFIGS`` (name → a complete YAML used instead of ``BASE_CONFIG``, as the tables
use it: MoMu's ``paper`` preset pins every paper value and inherits nothing from the cpu YAML)."""


@dataclass(frozen=True)
class TrainResult:
    """Where ``train_method`` wrote the model and its record."""

    out: Path
    model: Path
    record: dict[str, Any]


def _recipe(method: str) -> Any:
    if method not in RECIPES:
        raise ConfigError(
            f"momu train: no training recipe for method {method!r}; available: {sorted(RECIPES)}"
        )
    return importlib.import_module(RECIPES[method])


def detect_dataset(root: Path) -> str:
    """The registered loader for a dataset folder in its published layout (Dance with Melody so far)."""
    if not root.is_dir():
        raise ConfigError(f"--data {root}: dataset folder not found")
    if any(p.is_dir() and p.name.startswith("DANCE_") for p in root.iterdir()):
        return "dance_with_melody"
    raise ConfigError(
        f"--data {root}: layout not recognised (Dance with Melody: DANCE_*/ folders); name the loader with "
        "--dataset (momu list datasets)"
    )


def train_config(
    method: str,
    *,
    data: str = "synth",
    dataset: str | None = None,
    preset: str = "cpu",
    overrides: Sequence[str] = (),
) -> Any:
    """The validated config of a training run: the method's base YAML, the preset, the data, overrides."""
    from momu.config.schema import RecipeConfig  # imports torch: not when `momu` builds its parser

    recipe = _recipe(method)
    if preset not in recipe.PRESETS:
        raise ConfigError(f"--preset {preset}: valid presets for {method}: {', '.join(recipe.PRESETS)}")
    data_overrides: list[str] = []
    if data != "synth":
        root = Path(data)
        name = dataset or detect_dataset(root)
        data_overrides = [f"dataset={name}", f"dataset.root={root.resolve()}"]
    elif dataset is not None:
        raise ConfigError("--dataset names a loader for --data DIR; with --data synth it is synth_dance")
    base = getattr(recipe, "PRESET_CONFIGS", {}).get(preset, recipe.BASE_CONFIG)
    # every top-level key is checked against the recipe schema (a typo such as ``sed=3`` names the
    # valid keys), as for the tables and ``momu config show``
    return load_config(
        base, [*recipe.PRESETS[preset], *data_overrides, *overrides], schema=RecipeConfig, fill_defaults=False
    )


def _build_method(cfg: Any) -> Any:
    """The method of ``cfg``; a value its own checks reject is a ``ConfigError`` (one line, exit 2)."""
    try:
        return build_component(cfg.method, "methods")
    except ConfigError:
        raise
    except ValueError as exc:
        raise ConfigError(one_line(exc)) from None


def _clip(ds: Any, index: int) -> Any:
    """Clip ``index`` of ``ds``; a file that cannot be read is a ``ConfigError`` naming it."""
    from momu.data.files import DataFileError

    try:
        return ds[index]
    except DataFileError as exc:
        raise ConfigError(str(exc)) from None
    except (ValueError, OSError) as exc:
        raise ConfigError(f"dataset: clip {index}: {exc}") from None


def _check_clips(ds: Any, cfg: Any) -> tuple[tuple[int, int], dict[str, Any]]:
    """Read every clip once before training: ``((joints, dims) of the first training clip, hashes)``.

    A corrupt or unreadable file fails here, before any folder is made, with one line naming it.
    The hashes (SHA-256 of every clip's arrays, and of the dataset config) go into ``train.json``.
    """
    clips = {}
    shape: tuple[int, int] | None = None
    splits = set()
    for i in range(len(ds)):
        clip = _clip(ds, i)
        split = str(clip.meta.get("split", "train"))
        splits.add(split)
        if shape is None and split == "train" and clip.motion is not None and clip.audio is not None:
            shape = (int(clip.motion.shape[1]), int(clip.motion.shape[2]))
        clips[clip.id] = {"sha256": _clip_sha256(clip), "split": split}
    if shape is None:
        raise ConfigError(
            f"dataset has no 'train' clips with motion and audio (splits present: {sorted(splits)})"
        )
    node = json.dumps(to_container(cfg.dataset), sort_keys=True, default=str)
    return shape, {"config_sha256": hashlib.sha256(node.encode()).hexdigest(), "clips": clips}


def _clip_sha256(clip: Any) -> str:
    """SHA-256 of a clip's motion and audio arrays (as loaded)."""
    digest = hashlib.sha256()
    for arr in (clip.motion, clip.audio):
        if arr is not None:
            digest.update(np.ascontiguousarray(arr, dtype=np.float32).tobytes())
    return digest.hexdigest()


def find_model(folder: Path) -> Path:
    """A model folder: ``folder`` itself, or the only ``models/*`` inside a ``momu train`` output.

    A model folder holds its method's record: ``momu.json``, ``mofusion.json`` or ``harmogan.json``.
    """
    records = ("momu.json", "mofusion.json", "harmogan.json")
    if any((folder / name).is_file() for name in records):
        return folder
    found = sorted({p.parent for name in records for p in (folder / "models").glob(f"*/{name}")})
    if len(found) == 1:
        return found[0]
    if len(found) > 1:
        raise ConfigError(f"{folder}: holds several models ({', '.join(p.name for p in found)}); name one")
    return folder


def train_method(
    method: str,
    out: Path,
    *,
    data: str = "synth",
    dataset: str | None = None,
    preset: str = "cpu",
    overrides: Sequence[str] = (),
    seed: int | None = None,
    command: Sequence[str] | None = None,
    resume: bool = False,
) -> TrainResult:
    """Train ``method`` on ``data`` (``synth`` or a folder) and save the model under ``out``.

    Everything is checked before ``out`` is made: the config (every key), the dataset's options and
    every clip's files (one ``ConfigError`` naming the file). Stages finished by an earlier run into
    ``out`` are reused; ``resume`` continues a stage an interrupted run left half-trained from its
    last checkpoint (bit-identical to an uninterrupted run, see :mod:`momu.engine.context`).
    """
    from momu.engine import RunConfig, make_accelerator
    from momu.engine.context import RunContext, stage_key_hash
    from momu.engine.preflight import open_dataset
    from momu.engine.provenance import git_commit, package_versions

    cfg = train_config(method, data=data, dataset=dataset, preset=preset, overrides=overrides)
    _build_method(cfg)  # the method's own checks (check_config), before any data is read
    ds = open_dataset(cfg.dataset)
    (joints, dims), hashes = _check_clips(ds, cfg)
    shape = [f"method.encoder.num_joints={joints}", f"method.encoder.joint_dims={dims}"]
    cfg = train_config(method, data=data, dataset=dataset, preset=preset, overrides=[*overrides, *shape])
    run_seed = int(cfg.get("seed", 0) if seed is None else seed)
    out.mkdir(parents=True, exist_ok=True)
    save_config(cfg, out / "config.yaml")
    start = time.time()
    accelerator = make_accelerator(RunConfig(tracker="none", seed=run_seed), out, f"train-{method}", {})
    ctx = RunContext(accelerator=accelerator, out_dir=out, resume=resume)
    runner = _build_method(cfg)
    data_key = to_container(cfg.dataset)
    model = runner.fit(ctx, ds, data_key, run_seed)
    keys = runner.stage_keys(data_key, run_seed) if hasattr(runner, "stage_keys") else {"model": data_key}
    folder = out / "models" / f"{method}-{stage_key_hash(keys[list(keys)[-1]])}"
    record = {
        "method": method,
        "command": list(command) if command is not None else ["momu", *sys.argv[1:]],
        "git_commit": git_commit(),
        "preset": preset,
        "data": data,
        "seed": run_seed,
        "data_hashes": hashes,
        "versions": package_versions(),
        "wall_time_s": round(time.time() - start, 1),
        "stages": dict(ctx.trained),
    }
    if accelerator.is_main_process:
        model.save(folder)
        write_json(folder / "provenance.json", record)
        write_json(out / "train.json", {**record, "model": str(folder.relative_to(out))})
    log.info("momu train: %s model in %s (%.0f s)", method, folder, record["wall_time_s"])
    return TrainResult(out, folder, record)
