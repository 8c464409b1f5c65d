"""The LORIS benchmark (Yu et al., ICML 2023; MoMu Tables 2-4); registered as ``loris``.

LORIS pairs music with 2D poses for three scenarios, each cut into 25 s (and 50 s) segments:
AIST++ dance (``dance``, 25 s only), floor exercise (``fe``) and figure skating (``fs``).
Layout under ``root`` (as the LORIS list files name it, ``.../LORIS/<subset>/<kind>_s<L>/<name>``)::

    <subset>/audio_s<L>/<name>.wav      the segment's music
    <subset>/pose2d_s<L>/<name>.npy     (T, 17, 3) COCO-17 keypoints: x, y (pixels), confidence
    <subset>/<subset>_{audio,pose2d}_s<L>_{train,test}_segment.txt   the official lists (optional)

The list files are the ones in the LORIS repository's ``data/<subset>/`` folder; they are looked
up in ``root/<subset>/``, ``root/data/<subset>/`` and ``lists_dir``. Each line is a path ending
in ``<subset>/<kind>_s<L>/<name>.<ext>``; only ``<name>`` is used, the file is read from
``root/<subset>/<kind>_s<L>/``. The audio and pose lists must name the same segments.

Assumptions (LORIS ships no README for its data): the pose files carry no frame rate, so
``fps`` (``None`` by default) is inferred as ``T / segment seconds`` — LORIS's own loader
likewise treats a file as one segment and drops frames to a fixed context length; keypoints with
confidence <= ``min_confidence`` are missing and interpolated from neighbouring frames
(MoMu App. B.2). For ``dance`` the style is the AIST genre code of the segment name.

``split``: ``train`` / ``test`` from the official lists (``val`` is not published) or ``all``.
With ``use_lists=False`` (or without list files) the split is MoMu's random 90/5/5
(:func:`~momu.data.common.hash_split`) over every pose file.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from momu.data.common import (
    DataFileError,
    ItemRef,
    LazyClipDataset,
    LoaderConfig,
    MissingDataFileError,
    check_length_match,
    check_split,
    clean_keypoints,
    hash_split,
    load_audio,
    load_npy,
    read_lines,
    require_root,
    skeleton_shape,
)
from momu.data.types import Clip
from momu.registry import DATASETS

__all__ = ["LorisConfig", "LorisDataset", "SUBSETS"]

SUBSETS = {"dance": "dance", "fe": "fe", "floor_exercise": "fe", "fs": "fs", "figure_skating": "fs"}
"""Accepted ``subset`` names and the LORIS folder each maps to."""


@dataclass
class LorisConfig(LoaderConfig):
    """Options of the ``loris`` loader.

    Attributes:
        subset: ``dance``, ``fe`` / ``floor_exercise`` or ``fs`` / ``figure_skating``.
        seconds: segment length, 25 or 50 (``dance`` has 25 only).
        fps: motion frame rate; ``None`` infers ``T / seconds`` per file.
        min_confidence: keypoints with confidence <= this are treated as missing.
        max_gap: longest run of missing frames that is interpolated (frames).
        length_tolerance_seconds: accepted difference between the audio's length and ``seconds``.
        use_lists: use the official train/test lists when present.
        lists_dir: extra folder to look for the list files in ("" = only the default places).
        split_ratios: train/val/test fractions of the hash split (without lists).
        split_seed: seed of the hash split.
    """

    split: str = "train"
    subset: str = "dance"
    seconds: int = 25
    fps: float | None = None
    min_confidence: float = 0.0
    max_gap: int | None = 30
    length_tolerance_seconds: float = 1.0
    use_lists: bool = True
    lists_dir: str = ""
    split_ratios: list[float] = field(default_factory=lambda: [0.9, 0.05, 0.05])
    split_seed: int = 0


class LorisDataset(LazyClipDataset):
    """LORIS segments as :class:`~momu.data.types.Clip` (see the module docstring)."""

    name = "loris"

    def __init__(self, cfg: LorisConfig) -> None:
        root = require_root(cfg.root, self.name, "LORIS <subset>/{audio,pose2d}_s<L>/ folders")
        check_split(cfg.split, self.name)
        if cfg.subset not in SUBSETS:
            raise ValueError(f"{self.name}: subset must be one of {', '.join(SUBSETS)}; got {cfg.subset!r}")
        self.subset = SUBSETS[cfg.subset]
        if cfg.seconds not in (25, 50) or (self.subset == "dance" and cfg.seconds != 25):
            raise ValueError(f"{self.name}: seconds must be 25 or 50 (dance: 25 only), got {cfg.seconds}")
        if cfg.fps is not None and cfg.fps <= 0:
            raise ValueError(f"{self.name}: fps must be positive, got {cfg.fps}")
        self.cfg: LorisConfig = cfg
        tag = f"s{cfg.seconds}"
        self.pose_dir = root / self.subset / f"pose2d_{tag}"
        self.audio_dir = root / self.subset / f"audio_{tag}"
        if not self.pose_dir.is_dir():
            raise FileNotFoundError(f"{self.name}: {self.pose_dir} does not exist")

        lists = self._lists(root, tag) if cfg.use_lists else {}
        if lists:
            if cfg.split == "val":
                raise ValueError(
                    f"{self.name}: LORIS publishes train and test lists only; use split=train|test|all"
                )
            split_of = {stem: split for split, stems in lists.items() for stem in stems}
            stems = sorted(split_of)
        else:
            stems = sorted(p.stem for p in self.pose_dir.glob("*.npy"))
            split_of = {s: hash_split(s, cfg.split_ratios, cfg.split_seed) for s in stems}
        refs = [
            ItemRef(stem, self.pose_dir / f"{stem}.npy", {"split": split_of[stem]})
            for stem in stems
            if cfg.split in ("all", split_of[stem])
        ]
        super().__init__(cfg, root, refs)

    def _list_file(self, root: Path, filename: str) -> Path | None:
        places = [root / self.subset, root / "data" / self.subset]
        if self.cfg.lists_dir:
            extra = Path(self.cfg.lists_dir).expanduser()
            places += [extra, extra / self.subset]
        return next((p / filename for p in places if (p / filename).is_file()), None)

    def _lists(self, root: Path, tag: str) -> dict[str, list[str]]:
        """``{split: [segment names]}`` from the official lists; empty when none exist."""
        out: dict[str, list[str]] = {}
        for split in ("train", "test"):
            pose_list = self._list_file(root, f"{self.subset}_pose2d_{tag}_{split}_segment.txt")
            audio_list = self._list_file(root, f"{self.subset}_audio_{tag}_{split}_segment.txt")
            if pose_list is None:
                continue
            stems = [Path(line).stem for line in read_lines(pose_list)]
            if audio_list is not None:
                audio_stems = [Path(line).stem for line in read_lines(audio_list)]
                if sorted(audio_stems) != sorted(stems):
                    extra = sorted(set(audio_stems) ^ set(stems))[:3]
                    raise DataFileError(
                        audio_list,
                        f"names different segments from {pose_list.name} (e.g. {', '.join(extra)})",
                    )
            out[split] = stems
        if out and self.cfg.split in ("train", "test") and self.cfg.split not in out:
            raise MissingDataFileError(
                root / self.subset / f"{self.subset}_pose2d_{tag}_{self.cfg.split}_segment.txt",
                "list file not found",
            )
        return out

    def load(self, ref: ItemRef) -> Clip:
        cfg = self.cfg
        joints, _ = skeleton_shape("coco17")
        raw = load_npy(ref.path)
        if raw.ndim != 3 or raw.shape[1:] != (joints, 3):
            raise DataFileError(
                ref.path,
                f"expected (T, {joints}, 3) keypoints (x, y, confidence), got shape {tuple(raw.shape)}",
            )
        conf = raw[..., 2].astype(np.float32)
        missing = ~np.isfinite(conf) | (conf <= cfg.min_confidence)
        motion, filled = clean_keypoints(
            raw[..., :2], ref.path, joints=joints, dims=2, max_gap=cfg.max_gap, missing=missing
        )
        fps = float(cfg.fps) if cfg.fps is not None else motion.shape[0] / cfg.seconds
        check_length_match(ref.path, motion.shape[0] / fps, float(cfg.seconds), cfg.length_tolerance_seconds)
        meta: dict[str, Any] = {
            "split": ref.extra["split"],
            "source": str(ref.path),
            "subset": self.subset,
            "segment_seconds": cfg.seconds,
            "confidence": np.nan_to_num(conf, nan=0.0),
            "interpolated_keypoints": filled,
        }
        audio = None
        sample_rate = None
        if cfg.load_audio:
            wav = self.audio_dir / f"{ref.id}.wav"
            audio, sample_rate = load_audio(wav, sample_rate=cfg.sample_rate)
            check_length_match(
                wav, motion.shape[0] / fps, len(audio) / sample_rate, cfg.length_tolerance_seconds
            )
            meta["audio_source"] = str(wav)
        style = None
        if self.subset == "dance":
            genre = ref.id.split("_")[0]
            style = genre if genre.startswith("g") and len(genre) == 3 else None
        return Clip(
            id=ref.id,
            motion=motion,
            fps=fps,
            audio=audio,
            sample_rate=sample_rate,
            skeleton="coco17",
            style=style,
            meta=meta,
        )


@DATASETS.register("loris", config=LorisConfig)
def build_loris(cfg: LorisConfig, **_: Any) -> LorisDataset:
    """A LORIS subset from ``cfg.root`` (see :mod:`momu.data.loris`)."""
    return LorisDataset(cfg)
