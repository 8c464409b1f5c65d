"""The command line and output of the Dance with Melody studies under ``benchmarks/`` (one JSON each).

``study_args(__doc__, "name")`` sets up logging and parses ``--data`` (default: the shared Dance with
Melody copy), ``--seconds`` (the excerpt's length, default the music-following benchmark's 15 s) and
``--out`` (default ``benchmarks/results/<name>.json``); :func:`write_study` writes the result, making
its folder; :func:`excerpt` cuts a clip's excerpt.
"""

from __future__ import annotations

import argparse
import json
import logging
from pathlib import Path
from typing import Any

import numpy as np

__all__ = ["study_args", "write_study", "excerpt"]

DEFAULT_DATA = "../shared/data/dance_with_melody"
LEAD_S = 2.0
"""Where the benchmark's excerpts start (``momu.following.pairs.LEAD_S``)."""
DEFAULT_SECONDS = 15.0
"""The music-following benchmark's excerpt on Dance with Melody (``reproductions/music_following_dwm``)."""


def _positive(text: str) -> float:
    value = float(text)
    if not value > 0:
        raise argparse.ArgumentTypeError(f"must be > 0, got {text}")
    return value


def study_args(
    doc: str, name: str, data_help: str | None = None, extra: dict[str, int] | None = None
) -> argparse.Namespace:
    """Logging at INFO, then the parsed ``--data`` / ``--seconds`` / ``--out`` of study ``name`` (``doc``:
    its docstring), and any ``extra`` whole-number options (``{"--option": default}``)."""
    logging.basicConfig(level=logging.INFO, format="%(message)s")
    p = argparse.ArgumentParser(description=doc.splitlines()[0])
    p.add_argument("--data", default=DEFAULT_DATA, help=data_help)
    p.add_argument("--seconds", type=_positive, default=DEFAULT_SECONDS, help="excerpt length (s)")
    p.add_argument("--out", type=Path, default=Path(f"benchmarks/results/{name}.json"))
    for option, default in (extra or {}).items():
        p.add_argument(option, type=int, default=default)
    return p.parse_args()


def write_study(path: Path, result: Any, indent: int = 2) -> None:
    """``result`` as JSON at ``path`` (its folder made), newline-terminated."""
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(result, indent=indent) + "\n")


def excerpt(clip: Any, seconds: float, start: float = LEAD_S) -> tuple[np.ndarray, np.ndarray]:
    """A dataset clip's global joint positions (its root path added back) and its audio over
    ``[start, start + seconds)``."""
    f0, f1 = int(start * clip.fps), int((start + seconds) * clip.fps)
    root = 0.0 if clip.trajectory is None else clip.trajectory[:, None]
    sr = clip.sample_rate
    return (clip.motion + root)[f0:f1], clip.audio[int(start * sr) : int((start + seconds) * sr)]
