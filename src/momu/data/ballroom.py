"""The Ballroom dataset (Gouyon et al., ISMIR 2004; HarmoGAN's test music); registered as ``ballroom``.

Music only: ``Clip.motion`` is ``None`` and ``Clip.fps`` is 0. Layout under ``root``::

    <Genre>/<name>.wav     one folder per genre (ChaChaCha, Jive, Quickstep, Rumba-American,
                           Rumba-International, Rumba-Misc, Samba, Tango, VienneseWaltz, Waltz)

The genre folder name is ``Clip.style``. With ``beats_dir`` set (the BallroomAnnotations
repository: ``<name>.beats``, lines ``<time in seconds> <beat position in bar>``), the annotated
beat times go to ``meta["beat_times"]`` (seconds) and the bar positions to
``meta["beat_positions"]``. No official split exists; ``split`` uses
:func:`~momu.data.common.hash_split`.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from momu.data.common import (
    AUDIO_SUFFIXES,
    DataFileError,
    ItemRef,
    LazyClipDataset,
    LoaderConfig,
    check_split,
    hash_split,
    load_audio,
    read_lines,
    require_root,
)
from momu.data.types import Clip
from momu.registry import DATASETS

__all__ = ["BallroomConfig", "BallroomDataset", "read_beats_file"]


@dataclass
class BallroomConfig(LoaderConfig):
    """Options of the ``ballroom`` loader.

    Attributes:
        genres: genre folders to load (empty: every folder holding audio files).
        beats_dir: folder of ``<name>.beats`` annotations, relative to ``root`` or absolute
            ("" = none). A missing annotation for a track is an error when set.
        split_ratios: train/val/test fractions of the hash split.
        split_seed: seed of the hash split.
    """

    genres: list[str] = field(default_factory=list)
    beats_dir: str = ""
    split_ratios: list[float] = field(default_factory=lambda: [0.9, 0.05, 0.05])
    split_seed: int = 0


def read_beats_file(path: str | Path) -> tuple[np.ndarray, np.ndarray]:
    """``(times in seconds, bar positions)`` of a BallroomAnnotations ``.beats`` file.

    Raises:
        DataFileError: a line that is not ``<time> [<position>]``, or times that decrease.
    """
    times: list[float] = []
    positions: list[int] = []
    for number, line in enumerate(read_lines(path), start=1):
        fields = line.split()
        try:
            times.append(float(fields[0]))
            positions.append(int(float(fields[1])) if len(fields) > 1 else 0)
        except (ValueError, IndexError):
            raise DataFileError(
                path, f"line {number}: expected '<time> <beat position>', got {line!r}"
            ) from None
    t = np.asarray(times, dtype=np.float64)
    if t.size and (not np.all(np.isfinite(t)) or np.any(np.diff(t) < 0) or t[0] < 0):
        raise DataFileError(path, "beat times must be finite, non-negative and non-decreasing")
    return t, np.asarray(positions, dtype=np.int64)


class BallroomDataset(LazyClipDataset):
    """Ballroom tracks as music-only :class:`~momu.data.types.Clip` (see the module docstring)."""

    name = "ballroom"

    def __init__(self, cfg: BallroomConfig) -> None:
        root = require_root(cfg.root, self.name, "one folder of .wav files per genre")
        check_split(cfg.split, self.name)
        genre_dirs = sorted(
            p
            for p in root.iterdir()
            if p.is_dir() and any(f.suffix.lower() in AUDIO_SUFFIXES for f in p.iterdir())
        )
        if cfg.genres:
            missing = sorted(set(cfg.genres) - {p.name for p in genre_dirs})
            if missing:
                raise FileNotFoundError(
                    f"{self.name}: genre folder(s) {missing} not found (or empty) in {root}"
                )
            genre_dirs = [p for p in genre_dirs if p.name in cfg.genres]
        if not genre_dirs:
            raise FileNotFoundError(f"{self.name}: no genre folders with audio files in {root}")
        beats = Path(cfg.beats_dir).expanduser() if cfg.beats_dir else None
        self.beats_dir = None if beats is None else (beats if beats.is_absolute() else root / beats)
        if self.beats_dir is not None and not self.beats_dir.is_dir():
            raise FileNotFoundError(f"{self.name}: beats_dir {self.beats_dir} does not exist")
        refs = []
        for genre_dir in genre_dirs:
            for path in sorted(genre_dir.iterdir()):
                if path.suffix.lower() not in AUDIO_SUFFIXES:
                    continue
                item_id = f"{genre_dir.name}/{path.stem}"
                split = hash_split(item_id, cfg.split_ratios, cfg.split_seed)
                if cfg.split in ("all", split):
                    refs.append(ItemRef(item_id, path, {"split": split, "genre": genre_dir.name}))
        super().__init__(cfg, root, refs)
        self.cfg: BallroomConfig = cfg

    def load(self, ref: ItemRef) -> Clip:
        meta: dict[str, Any] = {"split": ref.extra["split"], "source": str(ref.path)}
        if self.beats_dir is not None:
            times, positions = read_beats_file(self.beats_dir / f"{ref.path.stem}.beats")
            meta.update(beat_times=times, beat_positions=positions)
        audio = None
        sample_rate = None
        if self.cfg.load_audio:
            audio, sample_rate = load_audio(ref.path, sample_rate=self.cfg.sample_rate)
        return Clip(
            id=ref.id,
            motion=None,
            fps=0.0,
            audio=audio,
            sample_rate=sample_rate,
            style=ref.extra["genre"],
            meta=meta,
        )


@DATASETS.register("ballroom", config=BallroomConfig)
def build_ballroom(cfg: BallroomConfig, **_: Any) -> BallroomDataset:
    """Ballroom music from ``cfg.root`` (see :mod:`momu.data.ballroom`)."""
    return BallroomDataset(cfg)
