"""Resumable training state in safetensors + JSON (no pickles).

accelerate's ``save_state`` stores optimizer and RNG states with ``torch.save`` (pickle). momu
writes nothing as pickle, so the engine saves the same state itself:

* ``model.safetensors`` — the unwrapped model's state dict;
* ``optimizer.safetensors`` + ``optimizer.json`` — every tensor of the optimizer state dict, and
  the rest of its structure (param groups, scalar entries) as JSON;
* ``rng_<rank>.safetensors`` + ``rng_<rank>.json`` — torch (CPU and CUDA), numpy and Python RNG
  states of each process;
* ``trainer.json`` — the step counter and anything else the loop needs to resume.

A checkpoint folder is written under a temporary name and renamed when complete, so a pre-empted
save never leaves a checkpoint that looks valid but is not.
"""

from __future__ import annotations

import json
import random
import shutil
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
import torch
from safetensors.torch import load_file, save_file

from momu.io import read_json, write_json

__all__ = [
    "flatten_state",
    "unflatten_state",
    "capture_rng",
    "restore_rng",
    "save_tensors_and_json",
    "load_tensors_and_json",
    "checkpoint_dirs",
    "latest_checkpoint",
]

_TENSOR = "__tensor__"


def flatten_state(obj: Any, prefix: str = "") -> tuple[Any, dict[str, torch.Tensor]]:
    """Split a nested state (dicts, lists, tensors, scalars) into a JSON skeleton and named tensors."""
    tensors: dict[str, torch.Tensor] = {}

    def walk(node: Any, path: str) -> Any:
        if isinstance(node, torch.Tensor):
            tensors[path] = node.detach().cpu().contiguous()
            return {_TENSOR: path}
        if isinstance(node, Mapping):
            return {"__dict__": [[_key(k), walk(v, f"{path}.{k}")] for k, v in node.items()]}
        if isinstance(node, (list, tuple)):
            items = [walk(v, f"{path}.{i}") for i, v in enumerate(node)]
            return {"__tuple__": items} if isinstance(node, tuple) else items
        if isinstance(node, np.ndarray):
            tensors[path] = torch.from_numpy(np.ascontiguousarray(node))
            return {_TENSOR: path, "numpy": True}
        if isinstance(node, (bool, int, float, str)) or node is None:
            return node
        raise TypeError(f"cannot serialise {type(node).__name__} at {path or '<root>'} without pickle")

    return walk(obj, prefix), tensors


def _key(key: Any) -> Any:
    if isinstance(key, (bool, int, float, str)) or key is None:
        return key
    raise TypeError(f"state dict key {key!r} is not a JSON scalar")


def unflatten_state(skeleton: Any, tensors: Mapping[str, torch.Tensor]) -> Any:
    """Inverse of :func:`flatten_state`."""
    if isinstance(skeleton, dict):
        if _TENSOR in skeleton:
            tensor = tensors[skeleton[_TENSOR]]
            return tensor.numpy() if skeleton.get("numpy") else tensor
        if "__dict__" in skeleton:
            return {k: unflatten_state(v, tensors) for k, v in skeleton["__dict__"]}
        if "__tuple__" in skeleton:
            return tuple(unflatten_state(v, tensors) for v in skeleton["__tuple__"])
    if isinstance(skeleton, list):
        return [unflatten_state(v, tensors) for v in skeleton]
    return skeleton


def save_tensors_and_json(directory: Path, stem: str, state: Any) -> None:
    """Write ``state`` as ``<stem>.safetensors`` (its tensors) and ``<stem>.json`` (the rest)."""
    skeleton, tensors = flatten_state(state)
    save_file(tensors, str(directory / f"{stem}.safetensors"))
    write_json(directory / f"{stem}.json", skeleton)


def load_tensors_and_json(directory: Path, stem: str) -> Any:
    """Read what :func:`save_tensors_and_json` wrote."""
    tensors_path = directory / f"{stem}.safetensors"
    if not tensors_path.is_file():
        raise FileNotFoundError(f"{tensors_path}: missing from checkpoint {directory}")
    return unflatten_state(read_json(directory / f"{stem}.json"), load_file(str(tensors_path)))


def capture_rng() -> dict[str, Any]:
    """The torch (CPU + CUDA), numpy and Python RNG states of this process."""
    np_state: Any = np.random.get_state()
    state: dict[str, Any] = {
        "torch": torch.get_rng_state(),
        "numpy": {
            "name": str(np_state[0]),
            "keys": np.asarray(np_state[1]),
            "pos": int(np_state[2]),
            "has_gauss": int(np_state[3]),
            "gauss": float(np_state[4]),
        },
        "python": json.loads(json.dumps(random.getstate())),
    }
    if torch.cuda.is_available():
        state["cuda"] = list(torch.cuda.get_rng_state_all())
    return state


def restore_rng(state: Mapping[str, Any]) -> None:
    """Restore what :func:`capture_rng` captured."""
    torch.set_rng_state(state["torch"])
    numpy_state: Any = state["numpy"]
    np.random.set_state(
        (
            numpy_state["name"],
            np.asarray(numpy_state["keys"], dtype=np.uint32),
            numpy_state["pos"],
            numpy_state["has_gauss"],
            numpy_state["gauss"],
        )
    )
    version, internal, gauss = state["python"]
    random.setstate((version, tuple(internal), gauss))
    if "cuda" in state and torch.cuda.is_available():
        torch.cuda.set_rng_state_all(list(state["cuda"]))


def checkpoint_dirs(root: Path) -> list[Path]:
    """Complete checkpoints under ``root`` (``step_<n>`` folders with a ``trainer.json``), oldest first."""
    if not root.is_dir():
        return []
    found = [p for p in root.glob("step_*") if p.is_dir() and (p / "trainer.json").is_file()]
    return sorted(found, key=lambda p: int(p.name.split("_")[1]))


def latest_checkpoint(root: Path) -> Path | None:
    """The newest complete checkpoint under ``root``, if any."""
    dirs = checkpoint_dirs(root)
    return dirs[-1] if dirs else None


def prune_checkpoints(root: Path, keep: int) -> None:
    """Delete all but the ``keep`` newest checkpoints (``keep`` ≤ 0 keeps all)."""
    if keep <= 0:
        return
    for old in checkpoint_dirs(root)[:-keep]:
        shutil.rmtree(old, ignore_errors=True)
