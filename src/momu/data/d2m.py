"""Dancing2Music "BHS Dance" (Lee et al., NeurIPS 2019; MoMu Tables 5-6); registered as ``d2m``.

BHS Dance holds ballet, hip-hop and zumba dances as 2D OpenPose keypoints and per-frame audio
features; it ships no raw audio (MoMu App. B: "it only provides the MFCC audio features"), so
clips have ``audio=None`` and the features in ``meta``. Layout under ``root`` (as the Dancing2Music
code reads it)::

    {zumba,ballet,hiphop}/<video>/<clip>/unit*/<n>.npy   (32, 14, 2) one dance unit, or
                                                         (S, 32, 14, 2) a sequence of S units
    {zumba,ballet,hiphop}/<video>/<clip>/aud/c<clip>_fps15.npy   (N, 28) audio features, 15 fps
    stats/all_onbeat_{mean,std}.npy    (28,) pose statistics (x, y of 14 keypoints, flattened)
    stats/all_aud_{mean,std}.npy       (28,) audio-feature statistics

Each ``unit*`` file is one clip (a unit sequence is concatenated to ``S * 32`` frames); motion is
14 keypoints (skeleton ``openpose14``: nose, neck, right/left shoulder, elbow, wrist, hip, knee,
ankle) in pixels at 15 fps. ``meta["audio_features"]`` holds the whole ``<clip>``'s audio
features (``meta["audio_features_fps"]`` = 15): the layout does not record where a unit starts
within its clip. The statistics are exposed as ``dataset.stats`` (for
:class:`momu.features.preprocess.Normalizer`).

No official split exists (MoMu: random 90/5/5); :func:`~momu.data.common.hash_split` assigns
whole videos, so units of one video never straddle splits.
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
    check_split,
    clean_keypoints,
    hash_split,
    load_npy,
    require_root,
    skeleton_shape,
)
from momu.data.types import Clip
from momu.registry import DATASETS

__all__ = ["D2MConfig", "D2MDataset", "D2M_STYLES"]

D2M_STYLES = ("ballet", "hiphop", "zumba")
"""The three BHS Dance genres (folder names)."""

_STATS = {
    "pose_mean": "all_onbeat_mean.npy",
    "pose_std": "all_onbeat_std.npy",
    "audio_mean": "all_aud_mean.npy",
    "audio_std": "all_aud_std.npy",
}


@dataclass
class D2MConfig(LoaderConfig):
    """Options of the ``d2m`` loader. ``load_audio`` loads the audio features (there is no waveform);
    ``sample_rate`` is unused.

    Attributes:
        styles: genres to load (folder names).
        unit_glob: which unit folders inside each clip folder hold clips (``unit*``: ``unit``,
            ``unitseq3``, ``unitseq4`` ...).
        fps: motion and audio-feature frame rate (15).
        audio_dim: expected audio-feature width (``None``: any).
        unit_frames: frames per dance unit (32).
        max_gap: longest run of missing frames that is interpolated (frames).
        split_ratios: train/val/test fractions of the hash split.
        split_seed: seed of the hash split.
    """

    split: str = "all"
    styles: list[str] = field(default_factory=lambda: list(D2M_STYLES))
    unit_glob: str = "unit*"
    fps: float = 15.0
    audio_dim: int | None = 28
    unit_frames: int = 32
    max_gap: int | None = 15
    split_ratios: list[float] = field(default_factory=lambda: [0.9, 0.05, 0.05])
    split_seed: int = 0


class D2MDataset(LazyClipDataset):
    """BHS Dance units as :class:`~momu.data.types.Clip` (see the module docstring).

    Attributes:
        stats: the ``stats/`` arrays present (``pose_mean``, ``pose_std``, ``audio_mean``, ``audio_std``).
    """

    name = "d2m"

    def __init__(self, cfg: D2MConfig) -> None:
        root = require_root(cfg.root, self.name, "{zumba,ballet,hiphop}/<video>/<clip>/unit*/*.npy")
        check_split(cfg.split, self.name)
        unknown = sorted(set(cfg.styles) - set(D2M_STYLES))
        if unknown:
            raise ValueError(f"{self.name}: unknown styles {unknown}; choose from {', '.join(D2M_STYLES)}")
        if cfg.fps <= 0 or cfg.unit_frames <= 0:
            raise ValueError(f"{self.name}: fps and unit_frames must be positive")
        refs = []
        for style in cfg.styles:
            style_dir = root / style
            if not style_dir.is_dir():
                continue
            for path in style_dir.glob(f"*/*/{cfg.unit_glob}/*.npy"):
                video = path.parents[2].name
                split = hash_split(f"{style}/{video}", cfg.split_ratios, cfg.split_seed)
                if cfg.split in ("all", split):
                    item_id = path.relative_to(root).with_suffix("").as_posix()
                    refs.append(ItemRef(item_id, path, {"split": split, "style": style, "video": video}))
        if not refs and not any((root / s).is_dir() for s in cfg.styles):
            raise FileNotFoundError(f"{self.name}: none of the style folders {cfg.styles} exist in {root}")
        refs.sort(key=lambda r: r.id)
        super().__init__(cfg, root, refs)
        self.cfg: D2MConfig = cfg
        self.stats = self._stats(root)

    def _stats(self, root: Path) -> dict[str, np.ndarray]:
        out: dict[str, np.ndarray] = {}
        joints, dims = skeleton_shape("openpose14")
        for key, filename in _STATS.items():
            path = root / "stats" / filename
            if not path.is_file():
                continue
            value = load_npy(path).astype(np.float32).reshape(-1)
            width = joints * dims if key.startswith("pose") else self.cfg.audio_dim
            if width is not None and value.shape != (width,):
                raise DataFileError(path, f"expected {width} values, got shape {value.shape}")
            if key.endswith("std") and np.any(value <= 0):
                raise DataFileError(path, "standard deviations must be positive")
            out[key] = value
        return out

    def _audio_features(self, clip_dir: Path) -> tuple[np.ndarray, Path]:
        aud_dir = clip_dir / "aud"
        preferred = aud_dir / f"c{clip_dir.name}_fps15.npy"
        if preferred.is_file():
            path = preferred
        else:
            candidates = sorted(aud_dir.glob("*.npy")) if aud_dir.is_dir() else []
            if len(candidates) != 1:
                found = "none" if not candidates else ", ".join(p.name for p in candidates)
                raise MissingDataFileError(preferred, f"audio features not found (aud/ holds {found})")
            path = candidates[0]
        feats = load_npy(path).astype(np.float32)
        if feats.ndim != 2 or (self.cfg.audio_dim is not None and feats.shape[1] != self.cfg.audio_dim):
            raise DataFileError(
                path, f"expected audio features of shape (N, {self.cfg.audio_dim}), got {feats.shape}"
            )
        if feats.shape[0] == 0:
            raise DataFileError(path, "no audio-feature frames")
        if not np.all(np.isfinite(feats)):
            raise DataFileError(
                path, f"{int(np.count_nonzero(~np.isfinite(feats)))} non-finite audio-feature values"
            )
        return feats, path

    def load(self, ref: ItemRef) -> Clip:
        cfg = self.cfg
        joints, dims = skeleton_shape("openpose14")
        raw = load_npy(ref.path)
        if raw.ndim == 4:  # a unit sequence (S, L, J, D)
            if raw.shape[1] != cfg.unit_frames:
                raise DataFileError(
                    ref.path, f"expected units of {cfg.unit_frames} frames, got shape {raw.shape}"
                )
            units = raw.shape[0]
            raw = raw.reshape(units * raw.shape[1], *raw.shape[2:])
        elif raw.ndim == 3:
            units = 1
        else:
            raise DataFileError(
                ref.path,
                f"expected ({cfg.unit_frames}, {joints}, {dims}) or (S, {cfg.unit_frames}, {joints}, {dims}) "
                f"keypoints, got shape {tuple(raw.shape)}",
            )
        motion, filled = clean_keypoints(raw, ref.path, joints=joints, dims=dims, max_gap=cfg.max_gap)
        meta: dict[str, Any] = {
            "split": ref.extra["split"],
            "source": str(ref.path),
            "video": ref.extra["video"],
            "unit_dir": ref.path.parent.name,
            "num_units": units,
            "interpolated_keypoints": filled,
        }
        if cfg.load_audio:
            feats, aud_path = self._audio_features(ref.path.parents[1])
            meta.update(audio_features=feats, audio_features_fps=float(cfg.fps), audio_source=str(aud_path))
        return Clip(
            id=ref.id,
            motion=motion,
            fps=float(cfg.fps),
            skeleton="openpose14",
            style=ref.extra["style"],
            meta=meta,
        )


@DATASETS.register("d2m", config=D2MConfig)
def build_d2m(cfg: D2MConfig, **_: Any) -> D2MDataset:
    """BHS Dance from ``cfg.root`` (see :mod:`momu.data.d2m`)."""
    return D2MDataset(cfg)
