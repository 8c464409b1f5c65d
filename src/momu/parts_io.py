"""Save and load trained parts: ``config.json`` + ``model.safetensors`` per part (DESIGN "Saved models").

``config.json`` records the registry kind and name, the validated config and the momu version, so
:func:`load_part` rebuilds the part through the registry (built-in or plugin) and loads the weights
strictly: a missing, unexpected or mis-shaped tensor is an error naming the directory and the keys.
No pickles are written; weights go through safetensors, every file is written atomically.
"""

from __future__ import annotations

import dataclasses
import logging
from pathlib import Path
from typing import Any

from omegaconf import OmegaConf
from safetensors import SafetensorError
from safetensors.torch import load_file, save_model
from torch import nn

from momu.io import atomic_path, read_json, write_json
from momu.registry import KINDS, registry_for

__all__ = ["CONFIG_FILE", "WEIGHTS_FILE", "FORMAT_VERSION", "save_part", "load_part", "read_part_config"]

logger = logging.getLogger(__name__)

CONFIG_FILE = "config.json"
WEIGHTS_FILE = "model.safetensors"
FORMAT_VERSION = 1


def _config_dict(kind: str, name: str, cfg: Any) -> dict[str, Any] | None:
    entry = registry_for(kind).get(name)
    if entry.config is None:
        if cfg not in (None, {}):
            raise ValueError(f"cfg: {kind} '{name}' takes no config, got {cfg!r}")
        return None
    if cfg is None:
        cfg = entry.default_config()
    if dataclasses.is_dataclass(cfg) and not isinstance(cfg, type):
        if not isinstance(cfg, entry.config):
            raise TypeError(
                f"cfg: expected a {entry.config.__name__} for {kind} '{name}', got {type(cfg).__name__}"
            )
        plain = OmegaConf.to_container(OmegaConf.structured(cfg), resolve=True)
    else:  # a mapping of params: validate through the registry's config machinery
        from momu.config import instantiate_config

        plain = OmegaConf.to_container(
            OmegaConf.structured(instantiate_config(entry, dict(cfg))), resolve=True
        )
    assert isinstance(plain, dict)
    return {str(k): v for k, v in plain.items()}


def save_part(module: nn.Module, kind: str, name: str, cfg: Any, directory: str | Path) -> Path:
    """Write ``directory/config.json`` and ``directory/model.safetensors`` for a built part.

    Args:
        module: the part (its ``state_dict`` is saved; tied tensors are stored once).
        kind: registry kind (``"backbones"``, ``"encoders"``, ...).
        name: registered name (``"dit"`` ...).
        cfg: the config the part was built from (dataclass instance or mapping; ``None`` = defaults).
        directory: target folder (created).

    Returns:
        ``directory`` as a Path.
    """
    from momu import __version__

    if kind not in KINDS:
        raise ValueError(f"kind: unknown kind {kind!r}; valid kinds: {', '.join(KINDS)}")
    if not isinstance(module, nn.Module):
        raise TypeError(f"module: expected a torch.nn.Module, got {type(module).__name__}")
    entry = registry_for(kind).get(name)
    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    record = {
        "format": FORMAT_VERSION,
        "kind": kind,
        "name": name,
        "source": entry.source,
        "momu_version": __version__,
        "config": _config_dict(kind, name, cfg),
    }
    with atomic_path(directory / WEIGHTS_FILE) as tmp:
        save_model(module, str(tmp), metadata={"kind": kind, "name": name, "momu_version": __version__})
    write_json(directory / CONFIG_FILE, record)
    return directory


def read_part_config(directory: str | Path) -> dict[str, Any]:
    """The parsed and checked ``config.json`` of a saved part."""
    path = Path(directory) / CONFIG_FILE
    if not path.is_file():
        raise FileNotFoundError(f"{path}: no saved part here (config.json missing)")
    record = read_json(path)
    if not isinstance(record, dict):
        raise ValueError(f"{path}: expected a JSON object")
    for key in ("kind", "name", "config"):
        if key not in record:
            raise ValueError(f"{path}: missing key '{key}'")
    if record["kind"] not in KINDS:
        raise ValueError(f"{path}: unknown kind {record['kind']!r}; valid kinds: {', '.join(KINDS)}")
    if int(record.get("format", FORMAT_VERSION)) > FORMAT_VERSION:
        raise ValueError(
            f"{path}: format {record['format']} is newer than this momu reads ({FORMAT_VERSION})"
        )
    return record


def load_part(directory: str | Path, *, map_location: str = "cpu", **deps: Any) -> nn.Module:
    """Rebuild a saved part through the registry and load its weights strictly.

    Args:
        directory: a folder written by :func:`save_part`.
        map_location: device for the loaded tensors.
        deps: keyword dependencies forwarded to the part's factory.

    Raises:
        FileNotFoundError: a file is missing. ValueError: malformed files, or weights that do not
            match the rebuilt part (the message lists missing/unexpected/mis-shaped keys).
    """
    from momu import __version__

    directory = Path(directory)
    record = read_part_config(directory)
    weights = directory / WEIGHTS_FILE
    if not weights.is_file():
        raise FileNotFoundError(f"{weights}: weights file missing")
    if record.get("momu_version") != __version__:
        logger.warning(
            "%s was saved by momu %s, loading with %s", directory, record.get("momu_version"), __version__
        )
    kind, name = record["kind"], record["name"]
    module = registry_for(kind).build(name, record["config"] or None, **deps)
    if not isinstance(module, nn.Module):
        raise TypeError(f"{directory}: {kind} '{name}' does not build a torch module")
    try:
        state = load_file(str(weights), device=map_location)
    except (SafetensorError, OSError) as exc:
        raise ValueError(f"{weights}: cannot read safetensors: {exc}") from None
    expected = module.state_dict()
    # tied tensors are stored once by save_model; any other name of the same storage may be absent
    missing = [k for k in expected if k not in state and not _is_tied_alias(module, k, state)]
    unexpected = [k for k in state if k not in expected]
    shapes = [
        f"{k}: saved {tuple(state[k].shape)} vs part {tuple(v.shape)}"
        for k, v in expected.items()
        if k in state and tuple(state[k].shape) != tuple(v.shape)
    ]
    if missing or unexpected or shapes:
        problems = []
        if missing:
            problems.append(f"missing keys {missing[:10]}{' …' if len(missing) > 10 else ''}")
        if unexpected:
            problems.append(f"unexpected keys {unexpected[:10]}{' …' if len(unexpected) > 10 else ''}")
        if shapes:
            problems.append(f"shape mismatches {shapes[:10]}")
        raise ValueError(f"{weights}: weights do not match {kind} '{name}': " + "; ".join(problems))
    module.load_state_dict(state, strict=False)
    return module


def _is_tied_alias(module: nn.Module, key: str, state: dict[str, Any]) -> bool:
    """True when ``key`` shares storage with a tensor that is present in ``state``."""
    tensors = module.state_dict(keep_vars=True)
    target = tensors[key]
    ptr = target.data_ptr()
    return any(k in state and k != key and v.data_ptr() == ptr for k, v in tensors.items())
