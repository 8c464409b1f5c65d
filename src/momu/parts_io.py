"""Save and load trained parts: ``config.json`` + ``model.safetensors`` per part (DESIGN "Saved models").

``config.json`` records the registry kind and name, the validated config and the momu version, so
:func:`load_part` rebuilds the part through the registry (built-in or plugin) and loads the weights
strictly: a missing, unexpected or mis-shaped tensor is an error naming the directory and the keys.
The part is first built on PyTorch's ``meta`` device (no memory) and its tensors' names, shapes and
dtypes compared with the safetensors *header*, so a config that would build a huge model is refused
before anything is allocated; integer weights where floats belong, and NaN or infinite weights, are
refused too. No pickles are written; weights go through safetensors (deterministic bytes,
:mod:`momu.weights_io`), every file is written atomically.
"""

from __future__ import annotations

import dataclasses
import logging
from pathlib import Path
from typing import Any

import torch
from omegaconf import OmegaConf
from safetensors import SafetensorError
from safetensors.torch import load_file
from torch import nn

from momu.io import read_json, write_json
from momu.registry import KINDS, registry_for
from momu.weights_io import TensorInfo, check_tensors, dtype_name, read_header, save_module

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
    save_module(module, directory / WEIGHTS_FILE, {"kind": kind, "name": name, "momu_version": __version__})
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
    try:
        header, metadata = read_header(weights)
    except (OSError, ValueError) as exc:
        raise ValueError(f"{weights}: cannot read safetensors: {exc}") from None
    expected = _meta_state(kind, name, record["config"], deps)
    if expected is not None:  # shapes and dtypes checked before the real part is built
        _check_against(weights, kind, name, expected, header, metadata)
    module = registry_for(kind).build(name, record["config"] or None, **deps)
    if not isinstance(module, nn.Module):
        raise TypeError(f"{directory}: {kind} '{name}' does not build a torch module")
    try:
        state = load_file(str(weights), device=map_location)
    except (SafetensorError, OSError) as exc:
        raise ValueError(f"{weights}: cannot read safetensors: {exc}") from None
    check_tensors(weights, state)
    built = {k: (dtype_name(v.dtype), tuple(v.shape)) for k, v in module.state_dict().items()}
    _check_against(
        weights,
        kind,
        name,
        built,
        {k: (dtype_name(v.dtype), tuple(v.shape)) for k, v in state.items()},
        metadata,
        module,
    )
    module.load_state_dict(state, strict=False)
    return module


def _meta_state(kind: str, name: str, config: Any, deps: dict[str, Any]) -> dict[str, TensorInfo] | None:
    """The part's tensor names, dtypes and shapes, built on the ``meta`` device (nothing allocated).

    ``None`` when the factory cannot build on ``meta`` (it then is checked after building).
    """
    try:
        with torch.device("meta"):
            module = registry_for(kind).build(name, config or None, **deps)
    except Exception:  # a factory that computes with real tensors: check after building instead
        logger.debug("%s '%s' does not build on the meta device", kind, name, exc_info=True)
        return None
    if not isinstance(module, nn.Module):
        return None
    return {k: (dtype_name(v.dtype), tuple(v.shape)) for k, v in module.state_dict().items()}


def _check_against(
    weights: Path,
    kind: str,
    name: str,
    expected: dict[str, TensorInfo],
    stored: dict[str, TensorInfo],
    metadata: dict[str, str],
    module: nn.Module | None = None,
) -> None:
    """Missing, unexpected, mis-shaped or mistyped tensors are one error naming the file and keys."""
    aliases = {k for k, v in metadata.items() if v in stored}  # tied tensors stored once (save_model)
    if module is not None:
        aliases |= {k for k in expected if k not in stored and _is_tied_alias(module, k, stored)}
    missing = [k for k in expected if k not in stored and k not in aliases]
    unexpected = [k for k in stored if k not in expected]
    shapes = [
        f"{k}: saved {stored[k][1]} vs part {v[1]}"
        for k, v in expected.items()
        if k in stored and stored[k][1] != v[1]
    ]
    dtypes = [
        f"{k}: saved {stored[k][0]} vs part {v[0]}"
        for k, v in expected.items()
        if k in stored
        and stored[k][1] == v[1]
        and stored[k][0] != v[0]
        and (_floating(v[0]) or _floating(stored[k][0]))
    ]
    if missing or unexpected or shapes or dtypes:
        problems = []
        if missing:
            problems.append(f"missing keys {missing[:10]}{' …' if len(missing) > 10 else ''}")
        if unexpected:
            problems.append(f"unexpected keys {unexpected[:10]}{' …' if len(unexpected) > 10 else ''}")
        if shapes:
            problems.append(f"shape mismatches {shapes[:10]}")
        if dtypes:
            problems.append(f"dtype mismatches {dtypes[:10]}")
        raise ValueError(f"{weights}: weights do not match {kind} '{name}': " + "; ".join(problems))


def _floating(name: str) -> bool:
    return name.startswith(("F", "BF"))


def _is_tied_alias(module: nn.Module, key: str, state: Any) -> bool:
    """True when ``key`` shares storage with a tensor that is present in ``state``."""
    tensors = module.state_dict(keep_vars=True)
    target = tensors[key]
    ptr = target.data_ptr()
    return any(k in state and k != key and v.data_ptr() == ptr for k, v in tensors.items())
