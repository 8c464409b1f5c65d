"""HarmoGAN's data (§IV-A, §V-A): dances at 15 fps, a temporal split, meter units, evaluation windows.

* **Dances** (:func:`prepare_dances`): every clip of the configured dataset (Dance with Melody, read by
  the ``dance_with_melody`` loader with ``target_fps: 15`` — linear interpolation from 25 fps, §V-A
  "resampled at 15 fps" — or the ``synth_dance`` stand-in at 15 fps), root-centred 21 joints in
  metres, its audio cut to the motion, and its MFCCs A_f resampled to the motion frames.
* **Temporal split**: the first ``1 − test_fraction`` of every dance trains, the rest is held out
  (the paper's split of its 61 dances is not published, ≈ 75/19 min; a split by dance leaves one test
  dance of the 8-dance subset). Nothing of a dance's held-out part is seen in training.
* **V_2d** (:func:`project_2d`): the orthographic projection that drops z (DwM is Y-up, so the camera
  looks along z); the generator's V′ = (V′_2d, z′) follows the same convention.
* **Meter units** (:func:`meter_unit_arrays`, :class:`MeterUnitDataset`): the training part of each dance
  cut by
  :func:`momu.methods.harmogan.meter.meter_units`; each item holds A_f, V_f (Eq. 12), V, V_2d, TI and
  the salient audio beats of the unit's own audio (the harmony loss's targets, computed with the
  metric's functions, :func:`momu.losses.harmony.audio_targets`).
* **Evaluation windows** (:func:`eval_windows`): consecutive ``clip_seconds`` windows of the held-out
  parts (6 s: the paper's Ballroom clip length, §V-A).
"""

from __future__ import annotations

import dataclasses
import logging
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import torch
from torch.utils.data import Dataset

from momu.data.types import Clip
from momu.features.audio import MfccConfig, mfcc
from momu.losses.harmony import AudioTargets, audio_targets
from momu.methods.harmogan.meter import MeterConfig, initial_pose_input, meter_units, transition_indices
from momu.metrics._checks import EmptyBeatsError

__all__ = [
    "Dance",
    "project_2d",
    "dance_mfcc",
    "prepare_dances",
    "MfccStats",
    "mfcc_stats",
    "UNIT_KEYS",
    "meter_unit_arrays",
    "MeterUnitDataset",
    "collate_units",
    "Window",
    "eval_windows",
    "window_clip",
    "replace_motion",
]

log = logging.getLogger(__name__)


@dataclass
class Dance:
    """One dance at the method's frame rate.

    Attributes:
        id, style: the clip's id and style. motion: ``(T, J, 3)`` float32 root-centred positions (m).
        audio: ``(S,)`` float32 waveform cut to the motion; sample_rate: its rate. fps: motion rate.
        mfcc: ``(T, C)`` float32 A_f, frame ``t`` at ``t / fps`` s. split_frame: first held-out frame.
    """

    id: str
    style: str | None
    motion: np.ndarray
    audio: np.ndarray
    sample_rate: int
    fps: float
    mfcc: np.ndarray
    split_frame: int

    def frames(self, split: str) -> tuple[int, int]:
        """``[start, end)`` frames of ``split`` (``train``, ``test`` or ``all``)."""
        if split == "train":
            return 0, self.split_frame
        if split == "test":
            return self.split_frame, int(self.motion.shape[0])
        if split == "all":
            return 0, int(self.motion.shape[0])
        raise ValueError(f"split must be 'train', 'test' or 'all', got {split!r}")

    def samples(self, start: int, end: int) -> tuple[int, int]:
        """Audio sample range of motion frames ``[start, end)``."""
        per = self.sample_rate / self.fps
        return int(round(start * per)), min(len(self.audio), int(round(end * per)))


def project_2d(motion: np.ndarray) -> np.ndarray:
    """V_2d: the orthographic projection of ``(..., J, 3)`` Y-up positions onto the x–y image plane."""
    return np.asarray(motion)[..., :2]


def dance_mfcc(audio: np.ndarray, sr: int, cfg: MfccConfig, fps: float, frames: int) -> np.ndarray:
    """A_f: MFCCs ``(frames, n_mfcc)`` at motion frame ``t``'s time ``t / fps`` (linear interpolation of
    librosa's centred frames, so no drift accumulates from a hop that is not a whole number of samples)."""
    coeffs = mfcc(audio, sr, cfg)  # (C, F) at k · hop / cfg.sample_rate seconds
    times = np.arange(coeffs.shape[1]) * cfg.hop / cfg.sample_rate
    target = np.arange(frames) / fps
    return np.stack([np.interp(target, times, row) for row in coeffs], axis=1).astype(np.float32)


def prepare_dances(dataset: Any, fps: float, test_fraction: float, mfcc_cfg: MfccConfig) -> list[Dance]:
    """Every clip of ``dataset`` as a :class:`Dance` (see the module docstring).

    Raises:
        ValueError: a clip without audio or motion, at another frame rate, not 3D, or too short to split.
    """
    if not 0.0 < test_fraction < 1.0:
        raise ValueError(f"method.test_fraction must be in (0, 1), got {test_fraction}")
    dances = []
    for i in range(len(dataset)):
        clip: Clip = dataset[i]
        if clip.motion is None or clip.audio is None or not clip.sample_rate:
            raise ValueError(f"clip {clip.id!r}: HarmoGAN needs paired motion and audio")
        if abs(clip.fps - fps) > 1e-6:
            raise ValueError(
                f"clip {clip.id!r} is at {clip.fps} fps; HarmoGAN runs at {fps} fps (set the loader's "
                "target_fps / synth_dance's fps)"
            )
        motion = np.asarray(clip.motion, dtype=np.float32)
        if motion.ndim != 3 or motion.shape[2] != 3:
            raise ValueError(f"clip {clip.id!r}: expected 3D joints (T, J, 3), got {motion.shape}")
        frames = int(motion.shape[0])
        split = int(round(frames * (1.0 - test_fraction)))
        if split < 2 or frames - split < 2:
            raise ValueError(f"clip {clip.id!r}: {frames} frames are too few for a temporal split")
        sr = int(clip.sample_rate)
        audio = np.asarray(clip.audio, dtype=np.float32)[: int(round(frames * sr / fps))]
        dances.append(
            Dance(
                id=clip.id,
                style=clip.style,
                motion=motion,
                audio=audio,
                sample_rate=sr,
                fps=float(fps),
                mfcc=dance_mfcc(audio, sr, mfcc_cfg, fps, frames),
                split_frame=split,
            )
        )
    if not dances:
        raise ValueError("the dataset has no clips")
    return dances


@dataclass(frozen=True)
class MfccStats:
    """Per-coefficient mean and standard deviation of A_f over the training frames."""

    mean: np.ndarray
    std: np.ndarray

    def apply(self, x: np.ndarray) -> np.ndarray:
        return ((x - self.mean) / self.std).astype(np.float32)


def mfcc_stats(dances: Sequence[Dance]) -> MfccStats:
    """:class:`MfccStats` of the training parts of ``dances``."""
    frames = np.concatenate([d.mfcc[: d.split_frame] for d in dances], axis=0)
    return MfccStats(frames.mean(axis=0), np.maximum(frames.std(axis=0), 1e-5))


def _unit_targets(audio: np.ndarray, sr: int, lambda1: float, normalize: bool) -> AudioTargets:
    try:
        return audio_targets(audio, sr, lambda1=lambda1, normalize_saliency=normalize)
    except EmptyBeatsError:  # a silent unit: no harmony term
        return AudioTargets(np.zeros(0), np.zeros(0))


UNIT_KEYS = ("mfcc", "initial_poses", "motion", "pose_2d", "transition")


def meter_unit_arrays(
    dances: Sequence[Dance],
    meter: MeterConfig,
    stats: MfccStats,
    *,
    lambda1: float = 0.1,
    normalize_saliency: bool = True,
    split: str = "train",
) -> dict[str, np.ndarray]:
    """The meter units of ``split`` of every dance as stacked arrays (HarmoGAN Fig. 7, left).

    Keys: ``mfcc`` ``(N, F, C)`` (standardised A_f), ``initial_poses`` ``(N, F, J, 3)`` (V_f, Eq. 12),
    ``motion`` (V), ``pose_2d`` ``(N, F, J, 2)`` (V_2d), ``transition`` ``(N, F)`` (TI), ``meter`` ``(N,)``
    (its type), and the salient audio beats of each unit's own audio, zero-padded: ``audio_times``,
    ``audio_saliency`` ``(N, K)`` and ``audio_count`` ``(N,)``.

    Raises:
        ValueError: no unit fits in the split.
    """
    from momu.metrics.harmony import audio_beats

    rows: dict[str, list[Any]] = {k: [] for k in (*UNIT_KEYS, "meter", "targets")}
    for dance in dances:
        lo, hi = dance.frames(split)
        a0, a1 = dance.samples(lo, hi)
        times, saliency = audio_beats(dance.audio[a0:a1], dance.sample_rate)
        for unit in meter_units(times, saliency, (hi - lo) / dance.fps, dance.fps, meter):
            s, e = lo + unit.start, lo + unit.start + unit.length
            if e > hi:
                continue
            motion = dance.motion[s:e]
            ti = transition_indices(unit)
            u0, u1 = dance.samples(s, e)
            rows["mfcc"].append(stats.apply(dance.mfcc[s:e]))
            rows["initial_poses"].append(initial_pose_input(motion, ti))
            rows["motion"].append(motion)
            rows["pose_2d"].append(project_2d(motion))
            rows["transition"].append(ti)
            rows["meter"].append(unit.meter)
            rows["targets"].append(
                _unit_targets(dance.audio[u0:u1], dance.sample_rate, lambda1, normalize_saliency)
            )
    if not rows["motion"]:
        raise ValueError(f"no meter unit of {meter.unit_seconds} s fits in the {split} parts of the dances")
    out = {k: np.stack(rows[k]).astype(np.float32) for k in UNIT_KEYS}
    out["meter"] = np.asarray(rows["meter"])
    width = max([1, *(len(t.times) for t in rows["targets"])])
    out["audio_times"] = np.zeros((len(rows["targets"]), width), np.float32)
    out["audio_saliency"] = np.zeros((len(rows["targets"]), width), np.float32)
    out["audio_count"] = np.asarray([len(t.times) for t in rows["targets"]], np.int64)
    for i, t in enumerate(rows["targets"]):
        out["audio_times"][i, : len(t.times)] = t.times
        out["audio_saliency"][i, : len(t.times)] = t.saliency
    return out


class MeterUnitDataset(Dataset[dict[str, torch.Tensor]]):
    """Meter units (:func:`meter_unit_arrays`) as a torch dataset; items are dicts of tensors, with the
    audio targets as ``audio_times`` / ``audio_saliency`` / ``audio_mask`` (padded)."""

    def __init__(self, arrays: dict[str, np.ndarray]) -> None:
        self.arrays = arrays
        self.tensors = {
            k: torch.from_numpy(np.ascontiguousarray(arrays[k]))
            for k in (*UNIT_KEYS, "audio_times", "audio_saliency")
        }
        count = torch.from_numpy(arrays["audio_count"])
        self.tensors["audio_mask"] = torch.arange(arrays["audio_times"].shape[1])[None, :] < count[:, None]

    @property
    def meters(self) -> list[str]:
        return [str(m) for m in self.arrays["meter"]]

    def __len__(self) -> int:
        return int(self.arrays["motion"].shape[0])

    def __getitem__(self, index: int) -> dict[str, torch.Tensor]:
        return {k: v[index] for k, v in self.tensors.items()}


def collate_units(items: list[dict[str, torch.Tensor]]) -> dict[str, torch.Tensor]:
    """Stack unit items (every field has a fixed shape)."""
    return {k: torch.stack([it[k] for it in items]) for k in items[0]}


@dataclass(frozen=True)
class Window:
    """An evaluation window: dance ``dance`` (index), motion frames ``[start, start + frames)``."""

    dance: int
    start: int
    frames: int


def eval_windows(
    dances: Sequence[Dance], split: str, seconds: float, hop_seconds: float | None = None
) -> list[Window]:
    """Consecutive windows of ``seconds`` (every ``hop_seconds``, default: no overlap) in ``split``."""
    out = []
    for i, dance in enumerate(dances):
        lo, hi = dance.frames(split)
        width = int(round(seconds * dance.fps))
        hop = int(round((hop_seconds or seconds) * dance.fps))
        start = lo
        while start + width <= hi:
            out.append(Window(i, start, width))
            start += hop
    return out


def window_clip(dance: Dance, window: Window, motion: np.ndarray | None = None, suffix: str = "") -> Clip:
    """The window as a :class:`Clip` (its audio and, unless given, its ground-truth motion)."""
    a0, a1 = dance.samples(window.start, window.start + window.frames)
    pose = dance.motion[window.start : window.start + window.frames] if motion is None else motion
    return Clip(
        id=f"{dance.id}@{window.start}{suffix}",
        motion=np.asarray(pose, dtype=np.float32),
        fps=dance.fps,
        audio=dance.audio[a0:a1],
        sample_rate=dance.sample_rate,
        skeleton="dwm21",
        style=dance.style,
        meta={"dance": dance.id, "start_frame": window.start},
    )


def replace_motion(clip: Clip, motion: np.ndarray, suffix: str) -> Clip:
    """``clip`` with another motion (a calibration perturbation or a generated sample)."""
    return dataclasses.replace(clip, id=clip.id + suffix, motion=np.asarray(motion, dtype=np.float32))
