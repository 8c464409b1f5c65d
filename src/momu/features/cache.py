"""On-disk feature cache keyed by (feature name, feature config, source identity).

A feature computed once for a given source (an audio file, a dataset clip) and config is stored
as ``<root>/<name>/<key[:2]>/<key>.npz`` and loaded on later runs instead of being recomputed::

    cache = FeatureCache("~/.cache/momu/features")
    mel = cache.get_or_compute("momu_mel", MoMuMelConfig(), file_identity(path),
                               lambda: momu_mel(*load(path)))

* The key is the SHA-256 of canonical JSON of ``{name, config, source, version}``: any change to a
  config field, to the source (a file's size or modification time, a clip id or its dataset config)
  or to the cache format gives a new entry.
* Writes are atomic (temporary file + rename, :func:`momu.io.atomic_path`), so an interrupted run
  never leaves a half-written entry; npz files are read with ``allow_pickle=False``.
* An unreadable entry (truncated by a crash of another tool, disk error) is recomputed and replaced.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import logging
import os
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

import numpy as np

from momu.io import atomic_path, remove_stale_temporaries

__all__ = ["FeatureCache", "cache_key", "file_identity", "clip_identity", "CACHE_FORMAT"]

logger = logging.getLogger(__name__)

#: Bumped when the stored layout changes, so old entries are not reused.
CACHE_FORMAT = 1

_META = "__momu_cache_key__"

Feature = np.ndarray | dict[str, np.ndarray]


def _plain(value: Any) -> Any:
    """A JSON-able canonical form of configs and identities (dataclasses, mappings, paths, numpy)."""
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return {
            "__type__": type(value).__name__,
            **{f.name: _plain(getattr(value, f.name)) for f in dataclasses.fields(value)},
        }
    if isinstance(value, Mapping):
        return {str(k): _plain(v) for k, v in sorted(value.items(), key=lambda kv: str(kv[0]))}
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    if isinstance(value, Path):
        return str(value)
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, np.ndarray):
        return {
            "__ndarray__": hashlib.sha256(np.ascontiguousarray(value).tobytes()).hexdigest(),
            "shape": list(value.shape),
        }
    if value is None or isinstance(value, (bool, int, float, str)):
        return value
    try:  # OmegaConf containers
        from omegaconf import DictConfig, ListConfig, OmegaConf

        if isinstance(value, (DictConfig, ListConfig)):
            return _plain(OmegaConf.to_container(value, resolve=True))
    except ImportError:  # pragma: no cover
        pass
    raise TypeError(f"cannot build a cache key from a {type(value).__name__}: {value!r}")


def cache_key(name: str, config: Any, source: Any) -> str:
    """Hex SHA-256 identifying feature ``name`` computed with ``config`` from ``source``."""
    payload = {"name": name, "config": _plain(config), "source": _plain(source), "format": CACHE_FORMAT}
    text = json.dumps(payload, sort_keys=True, separators=(",", ":"), allow_nan=True)
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


def file_identity(path: str | Path) -> dict[str, Any]:
    """``{path, size, mtime_ns}`` of an existing file: its cache identity (changes when it is rewritten)."""
    p = Path(path).expanduser()
    try:
        st = p.stat()
    except FileNotFoundError:
        raise FileNotFoundError(f"{p}: source file not found") from None
    return {"path": str(p.resolve()), "size": st.st_size, "mtime_ns": st.st_mtime_ns}


def clip_identity(clip_id: str, dataset: str, dataset_config: Any = None) -> dict[str, Any]:
    """Cache identity of a clip generated or loaded by a dataset (id + dataset name + its config)."""
    return {"clip": str(clip_id), "dataset": dataset, "dataset_config": _plain(dataset_config)}


class FeatureCache:
    """Feature arrays on disk, keyed by :func:`cache_key`.

    Args:
        root: cache folder (created on first write). ``None`` disables caching: every call computes.
        enabled: ``False`` also disables it (a config switch).

    Attributes:
        hits / misses: counts for this instance (for logs and tests).
    """

    def __init__(self, root: str | Path | None, *, enabled: bool = True) -> None:
        self.root = None if root is None else Path(os.path.expanduser(str(root)))
        self.enabled = enabled and self.root is not None
        self.hits = 0
        self.misses = 0

    def path_for(self, name: str, key: str) -> Path:
        """Where the entry ``key`` of feature ``name`` lives."""
        if self.root is None:
            raise ValueError("FeatureCache: caching is disabled (root is None)")
        safe = "".join(c if c.isalnum() or c in "-_." else "_" for c in name) or "feature"
        return self.root / safe / key[:2] / f"{key}.npz"

    def _read(self, path: Path, key: str) -> Feature | None:
        try:
            with np.load(path, allow_pickle=False) as z:
                stored = str(z[_META]) if _META in z.files else None
                if stored != key:
                    logger.warning("%s: cache entry has key %s, expected %s; recomputing", path, stored, key)
                    return None
                arrays = {k: z[k] for k in z.files if k != _META}
        except (OSError, ValueError, KeyError, EOFError) as exc:
            logger.warning("%s: unreadable cache entry (%s); recomputing", path, exc)
            return None
        if list(arrays) == ["__array__"]:
            return arrays["__array__"]
        return arrays

    def get(self, name: str, config: Any, source: Any) -> Feature | None:
        """The cached feature, or ``None`` when absent (or caching is disabled)."""
        if not self.enabled:
            return None
        key = cache_key(name, config, source)
        path = self.path_for(name, key)
        if not path.is_file():
            return None
        return self._read(path, key)

    def put(self, name: str, config: Any, source: Any, value: Feature) -> Path | None:
        """Store ``value`` (an array or dict of arrays) atomically; returns its file (``None``: disabled)."""
        if not self.enabled:
            return None
        key = cache_key(name, config, source)
        if isinstance(value, Mapping):
            arrays = {str(k): np.asarray(v) for k, v in value.items()}
            if "__array__" in arrays or _META in arrays:
                raise ValueError(f"FeatureCache.put: reserved array name in {sorted(arrays)}")
        else:
            arrays = {"__array__": np.asarray(value)}
        for k, a in arrays.items():
            if a.dtype == object:
                raise TypeError(f"FeatureCache.put: array {k!r} has dtype object (would need pickle)")
        path = self.path_for(name, key)
        remove_stale_temporaries(path.parent, ".npz")  # left by writers that were killed
        with atomic_path(path) as tmp:
            np.savez(tmp, **arrays, **{_META: np.asarray(key)})  # type: ignore[arg-type]
        return path

    def get_or_compute(self, name: str, config: Any, source: Any, compute: Callable[[], Feature]) -> Feature:
        """The cached feature, computing and storing it with ``compute()`` on a miss."""
        cached = self.get(name, config, source)
        if cached is not None:
            self.hits += 1
            return cached
        self.misses += 1
        value = compute()
        self.put(name, config, source, value)
        return value

    def clear(self, name: str | None = None) -> int:
        """Delete the entries of feature ``name`` (all features when ``None``); returns the count."""
        if self.root is None or not self.root.is_dir():
            return 0
        base = self.path_for(name, "xx").parent.parent if name else self.root
        count = 0
        for f in base.rglob("*.npz"):
            f.unlink(missing_ok=True)
            count += 1
        return count

    def __repr__(self) -> str:
        state = f"enabled={self.enabled}, hits={self.hits}, misses={self.misses}"
        return f"FeatureCache({str(self.root)!r}, {state})"
