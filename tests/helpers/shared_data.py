"""Where the real-data folder is: ``../shared/data`` beside the checkout (or beside the main checkout of a
git worktree), or ``$MOMU_SHARED_DATA``. Tests that need it skip where it is absent.

The Dance with Melody subset there grows over time (8 dances, then 23): tests read what it holds
from the folder itself (:func:`dance_with_melody_folders`), never from a list written into a test.
"""

from __future__ import annotations

import os
from pathlib import Path

__all__ = ["DWM_STYLES", "dance_with_melody_folders", "shared_data_dir"]

ROOT = Path(__file__).resolve().parents[2]

DWM_STYLES = {"C": "cha-cha", "R": "rumba", "T": "tango", "W": "waltz"}
"""Style of a ``DANCE_<letter>_<n>`` folder, as ``shared/data/README.md`` names them."""


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


def dance_with_melody_folders(root: Path) -> list[Path]:
    """The ``DANCE_*`` folders under ``root``, sorted by name: the dances the loader must find."""
    return sorted(p for p in root.iterdir() if p.is_dir() and p.name.startswith("DANCE_"))
