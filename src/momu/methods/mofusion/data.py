"""MoFusion data plumbing: motion at the model's rate, the mel condition, normalisers, training items.

* Rates (A1/A2 of docs/papers/mofusion.md): the model runs at ``fps`` = 20 (§4.4: 40 frames = 2 s);
  clips at another rate (AIST++ and ``synth_dance`` at 60 fps) are resampled linearly in time
  (:func:`resample_motion`; 60 → 20 keeps every third frame exactly). Metrics resample to 60 fps.
* Motion is the §3 pose vector (:mod:`momu.features.mofusion_pose`) of global joint positions
  (root-centred clips get their ``trajectory`` added back), standardised per channel.
* Music is MoFusion's log-mel (§3.3: 16 kHz, 80 bands, hop 512: 31.25 frames/s), standardised per
  band; the mel of ``[t0, t1)`` s is frames ``round(t0·31.25) … round(t1·31.25)``.
"""

from __future__ import annotations

import dataclasses
import json
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import torch
from torch.utils.data import Dataset

from momu.data.synth.captions import caption_window
from momu.data.types import Clip
from momu.data.types import split_indices as clips_of_split
from momu.features.audio import MoFusionMelConfig, check_waveform, mofusion_mel
from momu.features.mofusion_pose import decode_pose, encode_pose
from momu.features.preprocess import Normalizer
from momu.features.skeletons import get_skeleton
from momu.io import write_json

__all__ = [
    "MEL_CONFIG",
    "MEL_FPS",
    "split_indices",
    "resample_motion",
    "global_positions",
    "clip_pose",
    "clip_mel",
    "mel_frames",
    "crop",
    "clip_caption",
    "MoFusionNormalizers",
    "MusicWindows",
    "TextItems",
    "collate_music",
    "collate_text",
]

MEL_CONFIG = MoFusionMelConfig()
MEL_FPS = MEL_CONFIG.sample_rate / MEL_CONFIG.hop_length  # 31.25 frames per second


def split_indices(dataset: Any, split: str, task: str) -> list[int]:
    """Clips of ``split`` with motion and the task's condition (audio for music, text for text)."""

    def keep(clip: Clip) -> bool:
        return clip.motion is not None and (clip.audio is not None if task == "music" else bool(clip.text))

    return clips_of_split(dataset, split, keep)


def resample_motion(motion: np.ndarray, src_fps: float, dst_fps: float) -> np.ndarray:
    """``(T, ...)`` motion at ``src_fps`` resampled linearly in time to ``dst_fps`` (frame k at k/dst_fps).

    The output covers the same span: ``floor((T − 1) · dst/src) + 1`` frames.
    """
    x = np.asarray(motion, dtype=np.float64)
    if abs(src_fps - dst_fps) < 1e-9:
        return x.copy()
    n_out = int(np.floor((x.shape[0] - 1) * dst_fps / src_fps + 1e-9)) + 1
    pos = np.arange(n_out) * (src_fps / dst_fps)
    lo = np.clip(np.floor(pos).astype(int), 0, x.shape[0] - 1)
    hi = np.clip(lo + 1, 0, x.shape[0] - 1)
    w = (pos - lo).reshape(-1, *([1] * (x.ndim - 1)))
    return (1.0 - w) * x[lo] + w * x[hi]


def global_positions(clip: Clip) -> np.ndarray:
    """``(T, J, 3)`` global positions of a 3D clip (root-centred motion + its trajectory)."""
    if clip.motion is None or clip.motion.ndim != 3 or clip.motion.shape[-1] != 3:
        raise ValueError(f"clip {clip.id!r}: MoFusion needs 3D joint positions (T, J, 3)")
    m = np.asarray(clip.motion, dtype=np.float64)
    if clip.trajectory is not None:
        m = m + np.asarray(clip.trajectory, dtype=np.float64)[:, None, :]
    return m


def clip_pose(clip: Clip, fps: float, root: int) -> np.ndarray:
    """The clip's pose vectors ``(T', 3J)`` at the model's ``fps`` (MoFusion §3)."""
    return encode_pose(resample_motion(global_positions(clip), clip.fps, fps), root)


def clip_mel(clip: Clip) -> np.ndarray:
    """MoFusion's log-mel of the clip's audio, ``(frames, 80)`` at 31.25 frames/s."""
    audio = check_waveform(clip.audio, clip.sample_rate or 0, name=f"clip {clip.id!r} audio")
    return mofusion_mel(audio, int(clip.sample_rate or 0), MEL_CONFIG).T.astype(np.float32)


def mel_frames(seconds: float) -> int:
    return max(1, int(round(seconds * MEL_FPS)))


def crop(clip: Clip, start: float, seconds: float, suffix: str = "") -> Clip:
    """``clip`` cut to ``[start, start + seconds)``: motion, trajectory, audio, moves and caption."""
    f0 = int(round(start * clip.fps))
    f1 = min(clip.num_frames, int(round((start + seconds) * clip.fps)))
    audio = clip.audio
    if audio is not None and clip.sample_rate:
        audio = np.asarray(
            audio[int(round(start * clip.sample_rate)) : int(round((start + seconds) * clip.sample_rate))]
        )
    meta = dict(clip.meta)
    for key in ("beat_times", "downbeat_times", "motion_beat_times", "onset_times"):
        if key in meta:
            t = np.asarray(meta[key], dtype=np.float64) - start
            meta[key] = t[(t >= 0) & (t < seconds)].tolist()
    text = list(clip.text)
    if "moves" in meta:
        text = [caption_window(meta["moves"], start, start + seconds, clip.style)]
        meta["moves"] = [
            {**m, "start": max(0.0, m["start"] - start), "end": min(seconds, m["end"] - start)}
            for m in meta["moves"]
            if m["end"] > start and m["start"] < start + seconds
        ]
    meta["source_id"] = clip.id
    return dataclasses.replace(
        clip,
        id=clip.id + suffix,
        motion=None if clip.motion is None else np.asarray(clip.motion[f0:f1]),
        trajectory=None if clip.trajectory is None else np.asarray(clip.trajectory[f0:f1]),
        audio=audio,
        text=text,
        meta=meta,
    )


def clip_caption(clip: Clip) -> str:
    if not clip.text:
        raise ValueError(f"clip {clip.id!r} has no text")
    return str(clip.text[0])


@dataclass
class MoFusionNormalizers:
    """Per-channel z-scores of the pose vector and (music) of the mel bands, fitted on train (A5)."""

    pose: Normalizer
    mel: Normalizer | None = None

    @classmethod
    def fit(cls, poses: Sequence[np.ndarray], mels: Sequence[np.ndarray] | None) -> MoFusionNormalizers:
        return cls(Normalizer.fit(list(poses)), Normalizer.fit(list(mels)) if mels else None)

    def save(self, folder: Path) -> None:
        self.pose.save(folder / "pose_normalizer.json")
        if self.mel is not None:
            self.mel.save(folder / "mel_normalizer.json")

    @classmethod
    def load(cls, folder: Path) -> MoFusionNormalizers:
        mel = folder / "mel_normalizer.json"
        return cls(
            Normalizer.load(folder / "pose_normalizer.json"), Normalizer.load(mel) if mel.is_file() else None
        )


class MusicWindows(Dataset[dict[str, torch.Tensor]]):
    """Training items: standardised pose vectors ``x (N, 3J)`` and mel ``cond (M, 80)``.

    A clip at least ``seconds`` long gives windows of ``seconds`` every ``hop`` seconds; a shorter clip
    gives one item, the whole clip (§3.3: the fully convolutional U-Net "allows us to train the
    network with motions of various lengths"; AIST++ runs 7.4–48 s, so 20-s windows alone would drop
    every sequence under 20 s). :func:`collate_music` pads a batch of unequal items and masks the
    padding (``x_mask``, ``cond_mask``).
    """

    def __init__(
        self,
        clips: Sequence[Clip],
        norms: MoFusionNormalizers,
        fps: float,
        seconds: float,
        hop: float,
        root: int,
    ) -> None:
        assert norms.mel is not None
        n, m = int(round(seconds * fps)), mel_frames(seconds)
        self.items: list[dict[str, torch.Tensor]] = []
        self.whole_clips = 0
        for clip in clips:
            pose = norms.pose.transform(clip_pose(clip, fps, root)).astype(np.float32)
            mel = norms.mel.transform(clip_mel(clip)).astype(np.float32)
            if clip.duration + 1e-6 < seconds:
                self._add_whole(pose, mel, fps)
                continue
            start = 0.0
            while start + seconds <= clip.duration + 1e-6:
                f0, c0 = int(round(start * fps)), int(round(start * MEL_FPS))
                if f0 + n <= len(pose) and c0 + m <= len(mel):
                    self.items.append(
                        {"x": torch.from_numpy(pose[f0 : f0 + n]), "cond": torch.from_numpy(mel[c0 : c0 + m])}
                    )
                start += hop
        if not self.items:
            raise ValueError(f"no training item fits the training clips (windows of {seconds} s)")

    def _add_whole(self, pose: np.ndarray, mel: np.ndarray, fps: float) -> None:
        """One item of a clip shorter than the window: the frames its music covers."""
        frames = min(len(pose), int(np.floor(len(mel) / MEL_FPS * fps + 1e-6)))
        if frames < 2:
            return
        cond = mel[: min(len(mel), mel_frames(frames / fps))]
        self.items.append({"x": torch.from_numpy(pose[:frames]), "cond": torch.from_numpy(cond)})
        self.whole_clips += 1

    def __len__(self) -> int:
        return len(self.items)

    def __getitem__(self, index: int) -> dict[str, torch.Tensor]:
        return self.items[index]


def _pad_stack(items: list[torch.Tensor]) -> tuple[torch.Tensor, torch.Tensor | None]:
    """``(B, T_max, C)`` zero-padded, and the ``(B, T_max)`` valid-frame mask (``None``: equal lengths)."""
    lengths = [int(x.shape[0]) for x in items]
    if len(set(lengths)) == 1:
        return torch.stack(items), None
    out = items[0].new_zeros(len(items), max(lengths), items[0].shape[-1])
    mask = torch.zeros(len(items), max(lengths), dtype=torch.bool)
    for i, x in enumerate(items):
        out[i, : x.shape[0]] = x
        mask[i, : x.shape[0]] = True
    return out, mask


def collate_music(batch: list[dict[str, torch.Tensor]]) -> dict[str, torch.Tensor]:
    """Stack :class:`MusicWindows` items; items of unequal length are padded, with ``x_mask (B, T)``
    and ``cond_mask (B, M)`` (absent when every item has the same length: a plain stack)."""
    out: dict[str, torch.Tensor] = {}
    for key, mask_key in (("x", "x_mask"), ("cond", "cond_mask")):
        out[key], mask = _pad_stack([b[key] for b in batch])
        if mask is not None:
            out[mask_key] = mask
    return out


class TextItems(Dataset[dict[str, Any]]):
    """Text→motion items: the first ``seconds`` of every clip, its caption(s), padded to ``seconds``."""

    def __init__(
        self, clips: Sequence[Clip], norms: MoFusionNormalizers, fps: float, seconds: float, root: int
    ):
        self.length = int(round(seconds * fps))
        self.items: list[dict[str, Any]] = []
        for clip in clips:
            cut = crop(clip, 0.0, min(seconds, clip.duration)) if clip.duration > seconds else clip
            pose = norms.pose.transform(clip_pose(cut, fps, root)).astype(np.float32)[: self.length]
            self.items.append({"x": torch.from_numpy(pose), "texts": list(cut.text)})

    def __len__(self) -> int:
        return len(self.items)

    def __getitem__(self, index: int) -> dict[str, Any]:
        item = self.items[index]
        pick = int(torch.randint(len(item["texts"]), ()).item()) if len(item["texts"]) > 1 else 0
        return {"x": item["x"], "text": item["texts"][pick]}


def collate_text(batch: list[dict[str, Any]]) -> dict[str, Any]:
    """Pad ``x`` to the batch's longest item; ``x_mask (B, T)``; captions as a list."""
    longest = max(int(b["x"].shape[0]) for b in batch)
    x = torch.zeros(len(batch), longest, batch[0]["x"].shape[-1])
    mask = torch.zeros(len(batch), longest, dtype=torch.bool)
    for i, b in enumerate(batch):
        x[i, : b["x"].shape[0]] = b["x"]
        mask[i, : b["x"].shape[0]] = True
    return {"x": x, "x_mask": mask, "text": [b["text"] for b in batch]}


def positions_from_pose(norms: MoFusionNormalizers, z: np.ndarray, skeleton: str) -> np.ndarray:
    """Standardised pose vectors ``(T, 3J)`` -> positions ``(T, J, 3)`` in metres."""
    sk = get_skeleton(skeleton)
    return np.asarray(decode_pose(norms.pose.inverse(z), sk.num_joints, sk.root), dtype=np.float32)


def write_meta(folder: Path, meta: dict[str, Any]) -> None:
    write_json(folder / "mofusion.json", json.loads(json.dumps(meta)))
