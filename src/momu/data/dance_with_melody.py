"""Dance with Melody (Tang, Jia, Mao, ACM MM 2018; HarmoGAN's training data): ``dance_with_melody``.

Layout under ``root``::

    DANCE_<style>_<n>/audio.mp3        the whole song (44.1 kHz stereo MP3)
    DANCE_<style>_<n>/config.json      {"start_position": s, "end_position": e}  frames at 25 fps
    DANCE_<style>_<n>/skeletons.json   {"length": T, "center": T x 3, "skeletons": T x 23 x 3}

Motion: 25 fps, Y up, centimetres, root-centred; ``center`` is the global trajectory (returned
as ``Clip.trajectory``). Of the 23 points the paper uses the first 21 (skeleton ``dwm21``);
points 22-23 encode hand direction (``joints=23`` keeps them, skeleton ``dwm23``). Positions
are scaled by ``units_scale`` (0.01: metres). The style letter maps to cha-cha (C), rumba (R),
tango (T) and waltz (W).

Audio: the dance occupies ``[start_position / 25, start_position / 25 + T / 25)`` seconds of the
song; only that part is decoded and resampled to ``sample_rate``. The authors note that
``end_position - start_position`` is approximate: it differs from ``T`` by a few frames in most
dances (1-27 frames in the 23 dances of ``shared/data``) and by 56 frames (2.24 s) in DANCE_T_5. A difference
up to ``length_tolerance_frames`` is accepted, beyond it the item is an error. Where the song
ends before the dance (by at most the tolerance), the motion is cut to the audio.

No official split exists; ``split`` uses :func:`~momu.data.common.hash_split` (90/5/5 by default).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from momu.data.common import (
    DataFileError,
    ItemRef,
    LazyClipDataset,
    LoaderConfig,
    audio_info,
    check_split,
    clean_keypoints,
    hash_split,
    load_audio,
    read_json_file,
    require_root,
)
from momu.data.types import Clip
from momu.registry import DATASETS

__all__ = ["DanceWithMelodyConfig", "DanceWithMelodyDataset", "STYLES"]

STYLES = {"C": "cha-cha", "R": "rumba", "T": "tango", "W": "waltz"}
"""Style letter of a ``DANCE_<letter>_<n>`` folder and its dance."""


@dataclass
class DanceWithMelodyConfig(LoaderConfig):
    """Options of the ``dance_with_melody`` loader.

    Attributes:
        joints: 21 (the paper's skeleton, ``dwm21``) or 23 (with the hand-direction points, ``dwm23``).
        fps: motion frame rate (25).
        units_scale: factor applied to positions and trajectory (the files are in cm; 0.01 gives metres).
        length_tolerance_frames: accepted |(end - start) - T| in frames.
        max_gap: longest run of missing frames that is interpolated (frames).
        split_ratios: train/val/test fractions of the hash split.
        split_seed: seed of the hash split.
    """

    split: str = "all"
    joints: int = 21
    fps: float = 25.0
    units_scale: float = 0.01
    length_tolerance_frames: int = 64
    max_gap: int | None = 25
    split_ratios: list[float] = field(default_factory=lambda: [0.9, 0.05, 0.05])
    split_seed: int = 0


class DanceWithMelodyDataset(LazyClipDataset):
    """Dance-with-Melody dances as :class:`~momu.data.types.Clip` (see the module docstring)."""

    name = "dance_with_melody"

    def __init__(self, cfg: DanceWithMelodyConfig) -> None:
        root = require_root(cfg.root, self.name, "DANCE_*/{audio.mp3,config.json,skeletons.json} folders")
        check_split(cfg.split, self.name)
        if cfg.joints not in (21, 23):
            raise ValueError(f"{self.name}: joints must be 21 or 23, got {cfg.joints}")
        if cfg.fps <= 0:
            raise ValueError(f"{self.name}: fps must be positive, got {cfg.fps}")
        folders = sorted(p for p in root.iterdir() if p.is_dir() and p.name.startswith("DANCE_"))
        if not folders:
            raise FileNotFoundError(f"{self.name}: no DANCE_* folders in {root}")
        refs = []
        for folder in folders:
            split = hash_split(folder.name, cfg.split_ratios, cfg.split_seed)
            if cfg.split in ("all", split):
                refs.append(ItemRef(folder.name, folder / "skeletons.json", {"split": split}))
        super().__init__(cfg, root, refs)
        self.cfg: DanceWithMelodyConfig = cfg

    def load(self, ref: ItemRef) -> Clip:
        cfg = self.cfg
        folder = ref.path.parent
        config_path = folder / "config.json"
        positions = read_json_file(config_path)
        try:
            start = int(positions["start_position"])
            end = int(positions["end_position"])
        except (TypeError, KeyError, ValueError):
            raise DataFileError(
                config_path, "expected integer 'start_position' and 'end_position' (frames at 25 fps)"
            ) from None
        if start < 0 or end <= start:
            raise DataFileError(config_path, f"need 0 <= start_position < end_position, got {start}, {end}")

        data = read_json_file(ref.path)
        if not isinstance(data, dict) or "skeletons" not in data or "center" not in data:
            raise DataFileError(
                ref.path, "expected an object with 'skeletons' (T x 23 x 3) and 'center' (T x 3)"
            )
        try:
            skeletons = np.asarray(data["skeletons"], dtype=np.float32)
            center = np.asarray(data["center"], dtype=np.float32)
        except (TypeError, ValueError):
            raise DataFileError(
                ref.path, "'skeletons' / 'center' are not rectangular numeric arrays"
            ) from None
        if skeletons.ndim != 3 or skeletons.shape[1] < cfg.joints or skeletons.shape[2] != 3:
            raise DataFileError(
                ref.path,
                f"expected skeletons of shape (T, 23, 3) (>= {cfg.joints} points), got {skeletons.shape}",
            )
        frames = skeletons.shape[0]
        if "length" in data and int(data["length"]) != frames:
            raise DataFileError(ref.path, f"'length' is {data['length']} but 'skeletons' has {frames} frames")
        if center.shape != (frames, 3):
            raise DataFileError(ref.path, f"expected center of shape ({frames}, 3), got {center.shape}")
        if abs((end - start) - frames) > cfg.length_tolerance_frames:
            raise DataFileError(
                config_path,
                f"end_position - start_position = {end - start} frames but skeletons.json has {frames}: "
                f"mismatch of {abs(end - start - frames)} frames exceeds "
                f"length_tolerance_frames={cfg.length_tolerance_frames}",
            )
        motion, filled = clean_keypoints(
            skeletons[:, : cfg.joints], ref.path, joints=cfg.joints, dims=3, max_gap=cfg.max_gap
        )
        trajectory, _ = clean_keypoints(center[:, None], ref.path, joints=1, dims=3, max_gap=cfg.max_gap)
        scale = np.float32(cfg.units_scale)
        motion *= scale
        trajectory = trajectory[:, 0] * scale

        style_letter = ref.id.split("_")[1] if ref.id.count("_") >= 2 else ""
        meta: dict[str, Any] = {
            "split": ref.extra["split"],
            "source": str(folder),
            "start_position": start,
            "end_position": end,
            "length_mismatch_frames": (end - start) - frames,
            "interpolated_keypoints": filled,
        }
        audio = None
        sample_rate = None
        if cfg.load_audio:
            mp3 = folder / "audio.mp3"
            offset = start / cfg.fps
            file_sr, file_frames = audio_info(mp3)
            available = file_frames / file_sr - offset
            if available * cfg.fps < frames - cfg.length_tolerance_frames:
                raise DataFileError(
                    mp3,
                    f"the song ends {max(available, 0):.2f} s after start_position={start}, but the dance "
                    f"lasts {frames / cfg.fps:.2f} s (beyond length_tolerance_frames="
                    f"{cfg.length_tolerance_frames})",
                )
            audio, sample_rate = load_audio(
                mp3, sample_rate=cfg.sample_rate, offset=offset, duration=frames / cfg.fps
            )
            keep = min(frames, int(np.floor(len(audio) / sample_rate * cfg.fps + 1e-6)))
            motion, trajectory = motion[:keep], trajectory[:keep]
            meta["audio_offset_seconds"] = offset
            meta["audio_source"] = str(mp3)
        return Clip(
            id=ref.id,
            motion=motion,
            fps=float(cfg.fps),
            audio=audio,
            sample_rate=sample_rate,
            skeleton=f"dwm{cfg.joints}",
            style=STYLES.get(style_letter, style_letter or None),
            trajectory=trajectory,
            meta=meta,
        )


@DATASETS.register("dance_with_melody", config=DanceWithMelodyConfig)
def build_dance_with_melody(cfg: DanceWithMelodyConfig, **_: Any) -> DanceWithMelodyDataset:
    """Dance with Melody from ``cfg.root`` (see :mod:`momu.data.dance_with_melody`)."""
    return DanceWithMelodyDataset(cfg)
