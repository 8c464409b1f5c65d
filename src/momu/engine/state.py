"""Resumable training state in safetensors + JSON (no pickles).

accelerate's ``save_state`` stores optimizer and RNG states with ``torch.save`` (pickle). momu
writes nothing as pickle, so the engine saves the same state itself:

* ``model.safetensors`` — the unwrapped model's state dict;
* ``optimizer.safetensors`` + ``optimizer.json`` — every tensor of the optimizer state dict, and
  the rest of its structure (param groups, scalar entries) as JSON;
* ``rng_<rank>.safetensors`` + ``rng_<rank>.json`` — torch (CPU and CUDA), numpy and Python RNG
  states of each process;
* ``trainer.json`` — the step counter and anything else the loop needs to resume;
* ``complete.json`` — written last: every file of the checkpoint with its size and SHA-256.

Crash safety (a process may be killed between any two system calls):

* a checkpoint is written under ``.staging_<step>`` and becomes ``step_<step>`` by one rename,
  after its ``complete.json``; a folder counts as a checkpoint only if that marker is there and
  every file it lists has the listed size;
* replacing ``step_<n>`` renames the old one to ``.replaced_<n>`` first, and pruning renames a
  checkpoint to ``.pruned_<n>`` before deleting it, so no half-deleted folder is ever named
  ``step_*``;
* :func:`recover_checkpoints` (run before every save and before resuming) finishes what a killed
  save started — a complete ``.staging_<n>`` or ``.replaced_<n>`` whose ``step_<n>`` is missing or
  incomplete is renamed into place — and removes the leftovers; incomplete ``step_*`` folders are
  reported and skipped, never deleted.

Corruption (a disk or copy that changed bytes, not sizes): resuming (:func:`resume_point`) checks
every file of the newest complete checkpoint against the SHA-256 in its ``complete.json``; a
checkpoint whose bytes differ is reported (one line naming the file) and skipped, and the stage
continues from the newest checkpoint that verifies. If checkpoints exist but none is complete and
intact, resuming refuses (:class:`ResumeError`) instead of silently training from step 0.
"""

from __future__ import annotations

import hashlib
import json
import logging
import os
import random
import shutil
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
import torch
from safetensors.torch import load_file

from momu.io import read_json, write_json
from momu.weights_io import write_safetensors

__all__ = [
    "flatten_state",
    "unflatten_state",
    "capture_rng",
    "restore_rng",
    "save_tensors_and_json",
    "load_tensors_and_json",
    "checkpoint_dirs",
    "latest_checkpoint",
    "prune_checkpoints",
    "mark_complete",
    "is_complete",
    "incomplete_checkpoints",
    "recover_checkpoints",
    "replace_checkpoint",
    "COMPLETE_MARKER",
    "ResumeError",
    "checksum_problem",
    "resume_point",
    "write_checkpoint",
]

log = logging.getLogger(__name__)

COMPLETE_MARKER = "complete.json"

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
    write_safetensors(directory / f"{stem}.safetensors", tensors)
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


def _step(path: Path) -> int:
    return int(path.name.rsplit("_", 1)[1])


class ResumeError(RuntimeError):
    """``--resume`` found checkpoints but no complete, intact one (nothing to resume from)."""


def _sha256(path: Path) -> str:
    digest = hashlib.sha256()
    with open(path, "rb") as handle:
        for block in iter(lambda: handle.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def mark_complete(directory: Path, step: int) -> None:
    """Write ``complete.json`` (every file of ``directory``, its size and SHA-256); call it last."""
    paths = [p for p in sorted(directory.iterdir()) if p.is_file() and p.name != COMPLETE_MARKER]
    record = {
        "step": int(step),
        "files": {p.name: p.stat().st_size for p in paths},
        "sha256": {p.name: _sha256(p) for p in paths},
    }
    write_json(directory / COMPLETE_MARKER, record)


def checksum_problem(directory: Path) -> str | None:
    """``None`` if every file of the complete checkpoint ``directory`` has the SHA-256 its
    ``complete.json`` lists, else one line naming the first file that does not (a checkpoint written
    before checksums were recorded is checked by size only)."""
    sums = read_json(directory / COMPLETE_MARKER).get("sha256") or {}
    for name, expected in sums.items():
        if _sha256(directory / name) != expected:
            return f"{directory / name}: contents differ from the SHA-256 recorded when it was written"
    return None


def is_complete(directory: Path) -> bool:
    """``directory`` holds its ``complete.json`` and every file it lists, at the listed size."""
    try:
        record = read_json(directory / COMPLETE_MARKER)
        files = record["files"]
        return bool(files) and all((directory / n).stat().st_size == int(size) for n, size in files.items())
    except (OSError, ValueError, KeyError, TypeError, AttributeError):
        return False


def _step_dirs(root: Path, pattern: str) -> list[Path]:
    if not root.is_dir():
        return []
    found = []
    for p in root.glob(pattern):
        try:
            _step(p)
        except ValueError:
            continue
        if p.is_dir():
            found.append(p)
    return sorted(found, key=_step)


def checkpoint_dirs(root: Path) -> list[Path]:
    """Complete checkpoints under ``root`` (``step_<n>`` folders with a valid marker), oldest first."""
    return [p for p in _step_dirs(root, "step_*") if is_complete(p)]


def incomplete_checkpoints(root: Path) -> list[Path]:
    """``step_*`` folders under ``root`` that are not complete checkpoints (skipped by resume)."""
    return [p for p in _step_dirs(root, "step_*") if not is_complete(p)]


def latest_checkpoint(root: Path) -> Path | None:
    """The newest complete checkpoint under ``root``, if any."""
    dirs = checkpoint_dirs(root)
    return dirs[-1] if dirs else None


def _discard(path: Path) -> None:
    """Rename ``path`` out of the ``step_*`` namespace, then delete it (a kill leaves no half-folder)."""
    trash = path.with_name(f".pruned_{_step(path):08d}_{os.getpid()}")
    os.rename(path, trash)
    shutil.rmtree(trash, ignore_errors=True)


def replace_checkpoint(staging: Path, final: Path) -> None:
    """Move the complete ``staging`` folder to ``final``, keeping an old ``final`` until it is in place."""
    old = final.with_name(f".replaced_{_step(final):08d}")
    if final.exists():
        shutil.rmtree(old, ignore_errors=True)
        os.rename(final, old)
    os.rename(staging, final)
    shutil.rmtree(old, ignore_errors=True)


def recover_checkpoints(root: Path) -> list[str]:
    """Finish or undo what killed saves left under ``root``; returns one line per action taken.

    A complete ``.staging_<n>`` or ``.replaced_<n>`` becomes ``step_<n>`` when that is missing or
    incomplete; other leftovers (incomplete staging, ``.pruned_*``) are deleted. Incomplete ``step_*``
    folders are left alone (and skipped by :func:`checkpoint_dirs`).
    """
    notes: list[str] = []
    if not root.is_dir():
        return notes
    for pattern in (".staging_*", ".replaced_*"):
        for candidate in _step_dirs(root, pattern):
            final = root / f"step_{_step(candidate):08d}"
            if is_complete(candidate) and not is_complete(final):
                if final.exists():
                    os.rename(final, final.with_name(f".pruned_{_step(final):08d}_{os.getpid()}"))
                os.rename(candidate, final)
                notes.append(f"{final}: restored from {candidate.name} (a save was interrupted)")
            else:
                shutil.rmtree(candidate, ignore_errors=True)
    for leftover in root.glob(".pruned_*"):
        shutil.rmtree(leftover, ignore_errors=True)
    return notes


def resume_point(root: Path, name: str) -> Path | None:
    """The newest complete checkpoint under ``root`` whose files verify (:func:`checksum_problem`).

    Incomplete and corrupt checkpoints are logged and skipped. Returns ``None`` when ``root`` holds
    no checkpoint folder at all (the stage starts from step 0). Run :func:`recover_checkpoints` first.

    Raises:
        ResumeError: ``root`` holds checkpoint folders but none is complete and intact.
    """
    skipped = incomplete_checkpoints(root)
    for folder in skipped:
        log.warning(
            "%s: skipping incomplete checkpoint %s (no complete.json or a file is short)", name, folder
        )
    bad: list[Path] = []
    for checkpoint in reversed(checkpoint_dirs(root)):
        problem = checksum_problem(checkpoint)
        if problem is None:
            if bad:
                log.warning("%s: resuming from the older checkpoint %s", name, checkpoint)
            return checkpoint
        log.warning("%s: skipping corrupt checkpoint: %s", name, problem)
        bad.append(checkpoint)
    if skipped or bad:
        found = ", ".join(p.name for p in [*skipped, *bad])
        raise ResumeError(
            f"{name}: --resume found no complete checkpoint under {root} that is intact (incomplete or "
            f"corrupt: {found}); delete {root} to train it from scratch"
        )
    return None


def write_checkpoint(
    root: Path, step: int, states: Mapping[str, Any], records: Mapping[str, Any], keep: int
) -> Path:
    """Write checkpoint ``step`` of a single-process loop crash-safely and return its folder.

    ``states`` are written with :func:`save_tensors_and_json` (``<stem>.safetensors`` + JSON),
    ``records`` as ``<stem>.json``; then the marker, the rename into place and pruning to ``keep``.
    """
    final = root / f"step_{step:08d}"
    staging = root / f".staging_{step:08d}"
    root.mkdir(parents=True, exist_ok=True)
    for note in recover_checkpoints(root):
        log.warning("%s", note)
    shutil.rmtree(staging, ignore_errors=True)
    staging.mkdir(parents=True)
    for stem, state in states.items():
        save_tensors_and_json(staging, stem, state)
    for stem, record in records.items():
        write_json(staging / f"{stem}.json", record)
    mark_complete(staging, step)
    replace_checkpoint(staging, final)
    prune_checkpoints(root, keep)
    return final


def prune_checkpoints(root: Path, keep: int) -> None:
    """Delete all but the ``keep`` newest complete checkpoints (``keep`` ≤ 0 keeps all)."""
    if keep <= 0:
        return
    for old in checkpoint_dirs(root)[:-keep]:
        _discard(old)
