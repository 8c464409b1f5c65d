"""The benchmark's songs with their real dances: excerpts of a paired dataset.

:func:`load_pairs` reads ``--data``: ``synth`` (the built-in ``synth_dance``), a Dance with Melody
folder (``DANCE_*`` sub-folders; the agreed split: ``split_ratios = [0.6, 0.2, 0.2]``, ``split_seed =
0``), or a folder of pairs in ``momu eval``'s layout (``<stem>.wav`` + ``<stem>.npy|.npz``), all through
the project's loaders. Each :class:`Pair` keeps its whole clip (motion as global positions: a
root-centred dance gets its trajectory back) and the excerpt the benchmark uses: ``seconds`` long,
starting :data:`LEAD_S` in when the clip is long enough (so that a delayed copy of the real dance — a
calibration row — shows real frames, not a held pose).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

__all__ = ["Pair", "LEAD_S", "DWM_SPLIT", "load_pairs", "load_generated", "dataset_node", "MIN_SECONDS"]

LEAD_S = 2.0
"""Where an excerpt starts in a clip long enough for it (s)."""
MIN_SECONDS = 4.0
"""Shortest usable excerpt (s): two periods of the slowest tempo searched (20 BPM = 3 s) need more."""
DWM_SPLIT = {"split_ratios": [0.6, 0.2, 0.2], "split_seed": 0}
"""The project's agreed Dance with Melody split for the music-following work."""


@dataclass(frozen=True)
class Pair:
    """A song and its real dance.

    Attributes:
        id: the clip id. audio: the whole song (mono float32). sample_rate: its rate.
        motion: the whole dance ``(T, J, D)`` as global positions. fps: its rate.
        skeleton: the joint layout's name. start: where the excerpt starts (s). seconds: its length.
    """

    id: str
    audio: np.ndarray
    sample_rate: int
    motion: np.ndarray
    fps: float
    skeleton: str
    start: float
    seconds: float

    def excerpt_audio(self, offset: float = 0.0) -> np.ndarray:
        """The song's excerpt, its window moved ``offset`` s later (silence before the song's start)."""
        a = int(round((self.start + offset) * self.sample_rate))
        n = int(round(self.seconds * self.sample_rate))
        if a >= 0:
            return self.audio[a : a + n]
        return np.concatenate([np.zeros(-a, dtype=self.audio.dtype), self.audio[: n + a]])

    def excerpt_motion(self, offset: float = 0.0) -> np.ndarray:
        """The dance's excerpt, its window moved ``offset`` s later (``offset < 0``: earlier frames; a
        window reaching before the clip holds its first pose there)."""
        n = int(round(self.seconds * self.fps))
        first = int(round((self.start + offset) * self.fps))
        idx = np.clip(np.arange(first, first + n), 0, len(self.motion) - 1)
        return self.motion[idx]


def dataset_node(data: str, split: str, skeleton: str, seconds: float, songs: int) -> dict[str, Any]:
    """The registry node (``build_component(node, "datasets")``) of ``--data`` (``synth`` or a folder)."""
    if data == "synth":
        return {
            "name": "synth_dance",
            "skeleton": skeleton,
            "num_clips": max(64, 8 * songs),
            "min_seconds": seconds + LEAD_S + 1.0,
            "max_seconds": seconds + LEAD_S + 1.0,
            "split": split,
            "seed": 0,
        }
    root = Path(data).resolve()  # one spelling per folder: the table groups runs by this node
    if any(p.is_dir() and p.name.startswith("DANCE_") for p in root.iterdir()):
        return {
            "name": "dance_with_melody",
            "root": str(root),
            "split": split,
            "sample_rate": 16000,
            **DWM_SPLIT,
        }
    return {"name": "pair_folder", "root": str(root)}


def _pair_folder(root: Path, fps: float) -> list[Any]:
    """A folder in ``momu eval``'s layout as clips (motion and audio paired by stem; a ``.npy`` motion's
    rate from its ``<stem>.json`` sidecar, else ``fps``)."""
    from momu.cli.eval_inputs import load_pairs as eval_pairs

    clips, _ = eval_pairs(root, root, fps)
    return list(clips)


def load_pairs(node: dict[str, Any], seconds: float, songs: int | None, fps: float = 30.0) -> list[Pair]:
    """The first ``songs`` clips (by id) of the dataset ``node`` carrying motion and audio, as excerpts
    of ``seconds`` (shorter when a clip is shorter; clips under :data:`MIN_SECONDS` are skipped)."""
    from momu.config import build_component
    from momu.data.types import iter_clips

    if node["name"] == "pair_folder":
        clips = _pair_folder(Path(node["root"]), fps)
    else:
        clips = list(iter_clips(build_component(node, "datasets")))
    clips = sorted((c for c in clips if c.motion is not None and c.audio is not None), key=lambda c: c.id)
    out: list[Pair] = []
    for clip in clips:
        motion = np.asarray(clip.motion, dtype=np.float64)
        if clip.trajectory is not None:
            motion = motion + np.asarray(clip.trajectory, dtype=np.float64)[:, None, :]
        audio = np.asarray(clip.audio, dtype=np.float32).reshape(-1)
        length = min(len(motion) / clip.fps, len(audio) / float(clip.sample_rate))
        if length < MIN_SECONDS:
            continue
        start = LEAD_S if length >= seconds + LEAD_S + 1.0 else 0.0
        span = min(seconds, length - start)
        out.append(
            Pair(clip.id, audio, int(clip.sample_rate), motion, float(clip.fps), clip.skeleton, start, span)
        )
        if songs is not None and len(out) == songs:
            break
    return out


def load_generated(
    folder: Path, pairs: list[Pair], direction: str, fps: float = 30.0
) -> list[tuple[np.ndarray, float]]:
    """Outputs generated elsewhere for the benchmark's songs, cut to their excerpts.

    ``folder`` holds, per song id, ``<id>.npy|.npz`` (music → dance: the dance generated for the whole
    song, from its start) or ``<id>.wav|...`` (dance → music: the music for the whole dance), in
    ``momu eval``'s layout (a ``.npy``'s rate from its ``<id>.json`` sidecar, else ``fps``).

    Raises:
        ValueError: a song without its file (one line naming the folder and the ids).
    """
    from momu.cli.eval_inputs import load_pairs as eval_pairs

    clips = {c.id: c for c in eval_pairs(folder, folder, fps)[0]}
    kind = "motion" if direction == "dance" else "audio"
    missing = [p.id for p in pairs if p.id not in clips or getattr(clips[p.id], kind) is None]
    if missing:
        raise ValueError(f"{folder}: no generated {kind} for {', '.join(missing[:10])}")
    out: list[tuple[np.ndarray, float]] = []
    for p in pairs:
        c = clips[p.id]
        if direction == "dance":
            m = np.asarray(c.motion, dtype=np.float64)
            a = int(round(p.start * c.fps))
            out.append((m[a : a + int(round(p.seconds * c.fps))], float(c.fps)))
        else:
            y, sr = np.asarray(c.audio, dtype=np.float32), int(c.sample_rate or 0)
            a = int(round(p.start * sr))
            out.append((y[a : a + int(round(p.seconds * sr))], float(sr)))
    return out
