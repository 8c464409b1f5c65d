"""MoMu-Diffusion data plumbing: normalisers, fixed-length training windows, evaluation crops.

Rates (MoMu App. B.2): music is a 16 kHz waveform whose log-mel spectrogram has 62.5 frames/s
(hop 256); the BiCoR-VAE downsamples it by 2, so one latent frame covers 32 ms (31.25 Hz). Motion
keypoints (``openpose14``, pixels) come at the dataset's frame rate (60 fps for ``synth_dance``) and
are aligned to the latent rate by even frame dropping/repetition (MoMu §3.2,
:func:`momu.encoders.bicor_vae.align_frames`).

* :class:`MoMuNormalizers` — the statistics a trained MoMu needs at generation time: per-bin mel
  standardisation and an *isotropic* motion standardisation (one centre per coordinate axis shared
  by every joint, one scale for all coordinates: a similarity transform, so bone directions — the
  representation of Table 7 #1 — survive normalisation). Saved as JSON through
  :class:`momu.features.preprocess.Normalizer`.
* :class:`WindowDataset` — the training windows: ``window_seconds`` of music (normalised mel and/or
  waveform) and the motion aligned to the same number of latent frames, with a hop of
  ``window_hop_seconds``; an item is a dict of tensors (default collation).
* :func:`eval_crops` — ground-truth evaluation clips cut from the start of the test clips.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import torch
from torch.utils.data import Dataset

from momu.data.types import Clip, split_indices
from momu.encoders.bicor_vae import align_frames
from momu.features.audio import MoMuMelConfig, check_waveform, momu_mel, resample
from momu.features.preprocess import Normalizer

__all__ = [
    "MEL_CONFIG",
    "MoMuNormalizers",
    "Rates",
    "WindowDataset",
    "select_split",
    "eval_crops",
    "crop_clip",
]

MEL_CONFIG = MoMuMelConfig()
"""MoMu App. B.2 mel: 16 kHz, 80 bins, n_fft 1024, hop 256, Hann 1024 (62.5 frames/s)."""


@dataclass(frozen=True)
class Rates:
    """Frame bookkeeping of one MoMu model.

    Attributes:
        sample_rate: music sample rate (Hz).
        hop_length: samples per mel frame.
        music_frames_per_latent: music *input* frames per latent frame (mel frames, or samples for
            the waveform branch).
        motion_frames_per_latent: motion frames per latent frame (after alignment).
        music_input: ``"mel"`` or ``"waveform"``.
    """

    sample_rate: int
    hop_length: int
    music_frames_per_latent: int
    motion_frames_per_latent: int
    music_input: str

    @property
    def samples_per_latent(self) -> int:
        if self.music_input == "waveform":
            return self.music_frames_per_latent
        return self.music_frames_per_latent * self.hop_length

    @property
    def latent_rate(self) -> float:
        """Latent frames per second (31.25 Hz at MoMu's settings)."""
        return self.sample_rate / self.samples_per_latent

    @property
    def motion_fps(self) -> float:
        """Frame rate of decoded motion (62.5 fps at MoMu's settings)."""
        return self.latent_rate * self.motion_frames_per_latent

    def latent_frames(self, seconds: float) -> int:
        """Latent frames covering ``seconds`` of music (at least 1)."""
        return max(1, int(math.floor(seconds * self.latent_rate + 1e-9)))

    def seconds(self, latent_frames: int) -> float:
        return latent_frames / self.latent_rate


def count_split(dataset: Sequence[Clip] | Any, split: str) -> int:
    """How many clips of ``split`` carry motion and audio (:func:`select_split`)."""
    return len(select_split(dataset, split))


def select_split(dataset: Sequence[Clip] | Any, split: str) -> list[int]:
    """Indices of the clips of ``split`` that carry both motion and audio."""
    return split_indices(dataset, split, lambda clip: clip.motion is not None and clip.audio is not None)


def _waveform(clip: Clip, sample_rate: int) -> np.ndarray:
    audio = check_waveform(clip.audio, clip.sample_rate or 0, name=f"clip {clip.id!r} audio")
    if clip.sample_rate != sample_rate:
        audio = resample(audio, clip.sample_rate or 0, sample_rate)
    return np.asarray(audio, dtype=np.float32)


class MoMuNormalizers:
    """Mel and motion standardisation fitted on the training clips (saved as JSON).

    Attributes:
        mel: per-bin statistics, feature shape ``(80,)`` (applied to ``(T, 80)``).
        motion: isotropic statistics, feature shape ``(J, D)``: the same centre for every joint
            and the same scale for every coordinate.
    """

    def __init__(self, mel: Normalizer, motion: Normalizer) -> None:
        self.mel = mel
        self.motion = motion

    @classmethod
    def fit(
        cls, clips: Sequence[Clip], sample_rate: int, motion_of: Callable[[Clip], np.ndarray] | None = None
    ) -> MoMuNormalizers:
        """Fit on ``clips`` (their whole motion and music); ``motion_of(clip)`` gives the motion in the
        model's representation (default ``clip.motion``)."""
        if not clips:
            raise ValueError("MoMuNormalizers.fit: no training clips")
        mels = [momu_mel(_waveform(c, sample_rate), sample_rate, MEL_CONFIG).T for c in clips]
        mel = Normalizer.fit(mels, feature_ndim=1)
        motions = [
            np.asarray(c.motion if motion_of is None else motion_of(c), dtype=np.float64) for c in clips
        ]
        j, d = motions[0].shape[1:]
        for c, m in zip(clips, motions):
            if m.shape[1:] != (j, d):
                raise ValueError(
                    f"clip {c.id!r}: motion is {m.shape}, expected (T, {j}, {d}) like the others"
                )
        flat = np.concatenate([m.reshape(-1, d) for m in motions])
        centre = flat.mean(axis=0)
        scale = float(np.sqrt(((flat - centre) ** 2).sum(axis=1).mean() / d)) or 1.0
        motion = Normalizer(np.tile(centre, (j, 1)), np.full((j, d), scale))
        return cls(mel, motion)

    def save(self, folder: str | Path) -> None:
        folder = Path(folder)
        self.mel.save(folder / "mel_normalizer.json")
        self.motion.save(folder / "motion_normalizer.json")

    @classmethod
    def load(cls, folder: str | Path) -> MoMuNormalizers:
        folder = Path(folder)
        return cls(
            Normalizer.load(folder / "mel_normalizer.json"),
            Normalizer.load(folder / "motion_normalizer.json"),
        )

    def mel_of(self, audio: np.ndarray, sample_rate: int) -> np.ndarray:
        """Normalised MoMu mel ``(80, T)`` float32 of a waveform at ``sample_rate``."""
        mel = momu_mel(audio, sample_rate, MEL_CONFIG)
        return np.ascontiguousarray(self.mel.transform(mel.T).T, dtype=np.float32)

    def mel_inverse(self, mel: np.ndarray) -> np.ndarray:
        """``(80, T)`` normalised -> log-mel."""
        return np.ascontiguousarray(self.mel.inverse(np.asarray(mel, dtype=np.float64).T).T, dtype=np.float32)


def _motion_window(motion: np.ndarray, fps: float, start_s: float, seconds: float, frames: int) -> np.ndarray:
    """Motion of ``[start_s, start_s + seconds)`` aligned to ``frames`` frames (MoMu §3.2)."""
    first = int(round(start_s * fps))
    count = max(1, int(round(seconds * fps)))
    piece = motion[first : first + count]
    if piece.shape[0] < count:  # the clip ends early: hold the last pose
        pad = np.repeat(piece[-1:], count - piece.shape[0], axis=0)
        piece = np.concatenate([piece, pad])
    return np.asarray(align_frames(torch.from_numpy(np.ascontiguousarray(piece)), frames, dim=0))


class WindowDataset(Dataset[dict[str, torch.Tensor]]):
    """Fixed-length training windows of paired music and motion (normalised).

    Item: ``{"motion": (T_m, J, D)}`` plus ``{"mel": (80, T_mel)}`` and/or ``{"wave": (S,)}``, with
    ``T_mel = n_z · music_frames_per_latent`` (or ``S = n_z · samples_per_latent``) and
    ``T_m = n_z · motion_frames_per_latent`` for ``n_z = rates.latent_frames(window_seconds)``.
    With ``conditions`` (:class:`~momu.methods.momu.conditions.Conditions`) the motion is in its
    representation and items carry the condition features ``"f_music"`` (θ_m's, from the music) and
    ``"f_motion"`` (θ_a's, from the motion), ``(n_z, C)`` each, tracked over the whole clip.
    With ``music_beats`` items carry the window's salient music beats (HarmoGAN's, found over the
    whole clip): ``"beat_times"`` (s from the window start), ``"beat_saliency"``, ``"beat_mask"``,
    ``(K,)`` each, zero-padded to the most beats of any window.
    """

    def __init__(
        self,
        clips: Sequence[Clip],
        norms: MoMuNormalizers,
        rates: Rates,
        window_seconds: float,
        hop_seconds: float,
        *,
        need_mel: bool = True,
        need_wave: bool = False,
        conditions: Any = None,
        music_beats: bool = False,
    ) -> None:
        if window_seconds <= 0 or hop_seconds <= 0:
            raise ValueError(
                f"window_seconds and window_hop_seconds must be > 0, got {window_seconds}, {hop_seconds}"
            )
        self.rates = rates
        self.latent_frames = rates.latent_frames(window_seconds)
        seconds = rates.seconds(self.latent_frames)
        self.window_seconds = seconds
        n_motion = self.latent_frames * rates.motion_frames_per_latent
        n_samples = self.latent_frames * rates.samples_per_latent
        n_mel = n_samples // rates.hop_length
        self.items: list[dict[str, torch.Tensor]] = []
        beats: list[Any] = []
        for clip in clips:
            audio = _waveform(clip, rates.sample_rate)
            duration = min(len(audio) / rates.sample_rate, clip.num_frames / clip.fps)
            if duration + 1e-6 < seconds:
                continue
            mel = norms.mel_of(audio, rates.sample_rate) if need_mel else None
            raw = clip.motion if conditions is None else conditions.clip_motion(clip)
            motion = norms.motion.transform(np.asarray(raw, dtype=np.float32))
            tracks = _condition_tracks(conditions, clip, audio, rates.sample_rate)
            clip_beats = _music_beats(audio, rates.sample_rate) if music_beats else None
            starts = np.arange(0.0, duration - seconds + 1e-6, hop_seconds)
            for start_s in starts:
                first = int(round(start_s * rates.sample_rate / rates.hop_length))
                item = {
                    "motion": torch.from_numpy(
                        _motion_window(
                            motion, clip.fps, first * rates.hop_length / rates.sample_rate, seconds, n_motion
                        ).astype(np.float32)
                    )
                }
                if mel is not None:
                    piece = mel[:, first : first + n_mel]
                    if piece.shape[1] < n_mel:
                        piece = np.pad(piece, ((0, 0), (0, n_mel - piece.shape[1])), mode="edge")
                    item["mel"] = torch.from_numpy(np.ascontiguousarray(piece))
                if need_wave:
                    s0 = first * rates.hop_length
                    wave = audio[s0 : s0 + n_samples]
                    wave = np.pad(wave, (0, n_samples - len(wave)))
                    item["wave"] = torch.from_numpy(np.ascontiguousarray(wave, dtype=np.float32))
                t0 = first * rates.hop_length / rates.sample_rate
                for key, track in tracks.items():
                    f = track.features(self.latent_frames, rates.latent_rate, start=t0)
                    item[key] = torch.from_numpy(np.ascontiguousarray(f, dtype=np.float32))
                if clip_beats is not None:
                    beats.append(clip_beats.window(t0, seconds))
                self.items.append(item)
        if not self.items:
            raise ValueError(
                f"no training window of {seconds:.2f} s fits in the {len(clips)} training clip(s); "
                f"lower method.window_seconds"
            )
        if beats:  # one width K for every window, so the items stack
            from momu.losses.harmony import pad_targets

            times, saliency, mask = pad_targets(beats)
            for i, item in enumerate(self.items):
                item.update(beat_times=times[i], beat_saliency=saliency[i], beat_mask=mask[i])

    def __len__(self) -> int:
        return len(self.items)

    def __getitem__(self, index: int) -> dict[str, torch.Tensor]:
        return self.items[index]


def _music_beats(audio: np.ndarray, sample_rate: int) -> Any:
    """The salient music beats of a whole clip (HarmoGAN's, :func:`momu.losses.harmony.audio_targets`;
    none for a clip without onsets)."""
    from momu.losses.harmony import AudioTargets, audio_targets
    from momu.metrics._checks import EmptyBeatsError

    try:
        return audio_targets(audio, sample_rate)
    except EmptyBeatsError:
        return AudioTargets(np.zeros(0), np.zeros(0))


def _condition_tracks(conditions: Any, clip: Clip, audio: np.ndarray, sample_rate: int) -> dict[str, Any]:
    """The clip's condition feature tracks: ``f_music`` from its music, ``f_motion`` from its dance."""
    if conditions is None:
        return {}
    from momu.methods.momu.conditions import world_positions

    tracks = {
        "f_music": conditions.music_track(audio, sample_rate),
        "f_motion": conditions.motion_track(world_positions(clip), clip.fps),
    }
    return {k: v for k, v in tracks.items() if v is not None}


def crop_clip(clip: Clip, seconds: float, *, start: float = 0.0, suffix: str = "") -> Clip:
    """``clip`` cut to ``[start, start + seconds)`` (audio and motion), ``meta`` beats shifted."""
    if clip.motion is None or clip.audio is None or not clip.sample_rate:
        raise ValueError(f"clip {clip.id!r}: needs motion and audio")
    if start + seconds > clip.duration + 1e-6:
        raise ValueError(
            f"clip {clip.id!r}: {clip.duration:.2f} s is shorter than the {start + seconds:.2f} s asked"
        )
    f0, f1 = int(round(start * clip.fps)), int(round((start + seconds) * clip.fps))
    s0, s1 = int(round(start * clip.sample_rate)), int(round((start + seconds) * clip.sample_rate))
    meta = dict(clip.meta)
    for key in ("beat_times", "downbeat_times", "motion_beat_times"):
        if key in meta:
            times = np.asarray(meta[key], dtype=np.float64) - start
            meta[key] = times[(times >= 0) & (times < seconds)].tolist()
    meta["source_id"] = clip.id
    return dataclasses.replace(
        clip,
        id=clip.id + suffix,
        motion=np.asarray(clip.motion[f0:f1]),
        audio=np.asarray(clip.audio[s0:s1]),
        trajectory=None if clip.trajectory is None else clip.trajectory[f0:f1],
        meta=meta,
    )


def eval_crops(dataset: Sequence[Clip] | Any, split: str, count: int, seconds: Sequence[float]) -> list[Clip]:
    """Ground-truth evaluation clips: the first ``count`` clips of ``split`` cut to ``seconds[i]``.

    ``seconds`` holds one length per clip (cycled when shorter than ``count``); clips shorter than
    their length are cut to their own duration.
    """
    indices = select_split(dataset, split)[: max(0, count)]
    if not indices:
        raise ValueError(f"the dataset has no '{split}' clips with motion and audio to evaluate on")
    out = []
    for k, i in enumerate(indices):
        clip = dataset[i]
        length = min(float(seconds[k % len(seconds)]), clip.duration)
        out.append(crop_clip(clip, length))
    return out
