"""One numba kernel cache per distributed rank.

librosa compiles its numba kernels when its modules are imported and caches them on disk; numba
writes a ``@guvectorize`` kernel as two files with no lock between them, so processes that fill one
cold cache at the same time can load a mismatched pair and die with a segmentation fault
(numba/numba#10128, librosa/librosa#1998). ``accelerate launch --num_processes N`` starts N ranks that
import librosa together, so on a fresh install every rank gets a cache folder of its own; the
table runner's ``--jobs`` workers instead find the cache filled by their parent
(:func:`momu.metrics._audio.warm_librosa_kernels`).
"""

from __future__ import annotations

import os
from collections.abc import MutableMapping
from pathlib import Path

__all__ = ["isolate_rank_cache"]


def isolate_rank_cache(environ: MutableMapping[str, str] = os.environ) -> str | None:
    """Set ``NUMBA_CACHE_DIR`` to ``<cache>/momu/numba/rank-<LOCAL_RANK>`` in a launched rank.

    Must run before numba is imported (``import momu`` does it first). Leaves the environment as it
    is outside a distributed launch (no ``LOCAL_RANK``) and where ``NUMBA_CACHE_DIR`` is already set.
    Returns the folder it set, else ``None``.
    """
    rank = environ.get("LOCAL_RANK")
    if rank is None or "NUMBA_CACHE_DIR" in environ:
        return None
    base = Path(environ.get("XDG_CACHE_HOME") or Path.home() / ".cache")
    folder = str(base / "momu" / "numba" / f"rank-{rank}")
    environ["NUMBA_CACHE_DIR"] = folder
    return folder
