"""What every result file records about how it was produced: commit, versions, plugins, memory."""

from __future__ import annotations

import platform
import resource
import subprocess
from importlib.metadata import PackageNotFoundError, version
from pathlib import Path

from momu.registry import BUILTIN_SOURCE, REGISTRIES

__all__ = ["git_commit", "package_versions", "plugin_sources", "peak_memory_mib"]


def git_commit() -> str:
    try:
        out = subprocess.run(
            ["git", "rev-parse", "HEAD"],
            capture_output=True,
            text=True,
            check=True,
            cwd=Path(__file__).resolve().parent,
        )
        dirty = subprocess.run(
            ["git", "status", "--porcelain", "--untracked-files=no"],
            capture_output=True,
            text=True,
            cwd=Path(__file__).resolve().parent,
        ).stdout.strip()
        return out.stdout.strip() + ("+dirty" if dirty else "")
    except (OSError, subprocess.CalledProcessError):
        return "unknown"


def package_versions() -> dict[str, str]:
    out = {"python": platform.python_version()}
    for dist in ("momu", "torch", "numpy", "scipy", "librosa", "diffusers", "accelerate", "omegaconf"):
        try:
            out[dist] = version(dist)
        except PackageNotFoundError:
            out[dist] = "not installed"
    return out


def plugin_sources() -> dict[str, str]:
    found: dict[str, str] = {}
    for kind, registry in REGISTRIES.items():
        for name, source in registry.sources().items():
            if source != BUILTIN_SOURCE:
                found[f"{kind}.{name}"] = source
    return found


def peak_memory_mib() -> float:
    """Peak resident memory of this process or of its largest worker (``--jobs``), in MiB."""
    own = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    children = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss
    return max(own, children) / 1024.0
