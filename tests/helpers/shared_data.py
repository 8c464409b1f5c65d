"""Where the real-data folder is: ``../shared/data`` beside the checkout (or beside the main checkout of a
git worktree), or ``$MOMU_SHARED_DATA``. Tests that need it skip where it is absent."""

from __future__ import annotations

import os
from pathlib import Path

__all__ = ["shared_data_dir"]

ROOT = Path(__file__).resolve().parents[2]


def _candidates() -> list[Path]:
    found = [Path(os.environ["MOMU_SHARED_DATA"])] if os.environ.get("MOMU_SHARED_DATA") else []
    found.append(ROOT.parent / "shared" / "data")
    git = ROOT / ".git"
    if git.is_file():  # a worktree: ".git" names <main checkout>/.git/worktrees/<name>
        text = git.read_text().strip()
        if text.startswith("gitdir:"):
            found.append(Path(text.split(":", 1)[1].strip()).parents[2].parent / "shared" / "data")
    return found


def shared_data_dir() -> Path:
    """The first existing candidate folder (the default ``../shared/data`` when none exists)."""
    return next((c for c in _candidates() if c.is_dir()), ROOT.parent / "shared" / "data")
