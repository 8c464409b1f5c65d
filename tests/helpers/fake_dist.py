"""Write a throw-away installed distribution (dist-info + module) that declares momu entry points."""

from __future__ import annotations

import sys
import textwrap
from pathlib import Path

import pytest


def install_fake_dist(
    root: Path,
    monkeypatch: pytest.MonkeyPatch,
    *,
    dist: str,
    version: str,
    module: str,
    source: str,
    entry_points: dict[str, dict[str, str]],
) -> None:
    """Make ``module`` importable from ``root`` and visible to importlib.metadata as ``dist==version``."""
    root.mkdir(parents=True, exist_ok=True)
    (root / f"{module}.py").write_text(textwrap.dedent(source))
    info = root / f"{dist.replace('-', '_')}-{version}.dist-info"
    info.mkdir()
    (info / "METADATA").write_text(f"Metadata-Version: 2.1\nName: {dist}\nVersion: {version}\n")
    (info / "top_level.txt").write_text(module + "\n")
    (info / "RECORD").write_text(f"{module}.py,,\n")
    lines = []
    for group, eps in entry_points.items():
        lines.append(f"[{group}]")
        lines.extend(f"{name} = {value}" for name, value in eps.items())
    (info / "entry_points.txt").write_text("\n".join(lines) + "\n")
    monkeypatch.syspath_prepend(str(root))
    monkeypatch.delitem(sys.modules, module, raising=False)
