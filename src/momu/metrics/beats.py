"""Music beats and motion beats at the reference frame rate (METRICS.md §1.5–1.7).

Frame conventions: the AIST++ references analyse audio at 30720 Hz with hop 512, i.e. **60 frames per
second**, the motion frame rate of AIST++; beat positions are integer frame indices at that rate.

* :func:`music_beats` / :func:`music_beat_onehot` — both recipes of §1.5:
  ``"bailando"`` (HPSS percussive part, median-aggregated onset strength, ``beat_track`` start_bpm 120)
  and ``"mint"`` (full signal, mean-aggregated onset strength, ``beat_track`` with a genre tempo prior,
  see :func:`aistpp_tempo`; also the GCDG/Ruilong ``music_beat_onehot`` with a given bpm).
* :func:`motion_envelope` / :func:`motion_beats` — the two kinematic-beat detectors of §1.6:
  ``"bailando"`` (mean joint speed over T-1 frames, Gaussian σ=5 frames, strict local minima of order 1)
  and ``"mint"`` (summed joint speed over T frames with a leading zero, strict minima of order 10).
"""

from __future__ import annotations

import re
from typing import Literal

import librosa
import numpy as np
from scipy.ndimage import gaussian_filter
from scipy.signal import argrelextrema

from momu.metrics._audio import prepare_audio
from momu.metrics._checks import EmptyBeatsError, as_frames, as_motion

__all__ = [
    "EmptyBeatsError",
    "MUSIC_SR",
    "MUSIC_HOP",
    "MUSIC_FPS",
    "aistpp_tempo",
    "music_onset_envelope",
    "music_beats",
    "music_beat_onehot",
    "motion_envelope",
    "motion_beats",
    "frames_to_onehot",
    "resample_beat_frames",
]

MUSIC_SR = 30720
"""Sample rate (Hz) of the AIST++ music features: 60 fps × hop 512."""
MUSIC_HOP = 512
"""Hop length (samples) of the AIST++ music features."""
MUSIC_FPS = MUSIC_SR / MUSIC_HOP
"""Frame rate of the music features and of AIST++ motion: 60.0 fps."""

MusicRecipe = Literal["bailando", "mint"]
MotionVariant = Literal["bailando", "mint"]

_TEMPO_80 = ("mBR", "mPO", "mLO", "mMH", "mLH", "mWA", "mKR", "mJS", "mJB")
_MUSIC_NAME = re.compile(r"m[A-Z]{2}\d")


def aistpp_tempo(name: str) -> int:
    """The tempo prior (BPM) mint's ``_get_tempo`` derives from an AIST++ music name.

    ``name`` is a music id (``"mBR0"``) or any AIST++ sequence name containing one
    (``"gBR_sBM_cAll_d04_mBR0_ch01"``). ``int(name[3])·10 + 80`` for mBR/mPO/mLO/mMH/mLH/mWA/mKR/mJS/mJB,
    ``int(name[3])·5 + 110`` for mHO.

    Raises:
        ValueError: no AIST++ music id in ``name`` or an unknown genre.
    """
    found = _MUSIC_NAME.findall(name)
    if not found:
        raise ValueError(f"aistpp_tempo: no AIST++ music id (like 'mBR0') in {name!r}")
    music = found[-1]
    genre, digit = music[:3], int(music[3])
    if genre in _TEMPO_80:
        return digit * 10 + 80
    if genre == "mHO":
        return digit * 5 + 110
    raise ValueError(f"aistpp_tempo: unknown AIST++ music genre {genre!r} in {name!r}")


def music_onset_envelope(audio: np.ndarray, sr: int, *, recipe: MusicRecipe = "bailando") -> np.ndarray:
    """Onset-strength envelope ``(F,)`` at 60 fps (30720 Hz, hop 512) following ``recipe``.

    ``"bailando"``: ``onset_strength(y=hpss(y)[1], aggregate=np.median)``; ``"mint"``:
    ``onset_strength(y)`` (mean aggregate). ``audio`` is mono ``(S,)`` or ``(C, S)``, any sample rate
    (averaged to mono, then resampled with soxr_hq like ``librosa.load``).
    """
    y = prepare_audio(audio, sr, MUSIC_SR)
    if recipe == "bailando":
        _, percussive = librosa.effects.hpss(y)
        return np.asarray(librosa.onset.onset_strength(y=percussive, aggregate=np.median, sr=MUSIC_SR))
    if recipe == "mint":
        return np.asarray(librosa.onset.onset_strength(y=y, sr=MUSIC_SR))
    raise ValueError(f"recipe: expected 'bailando' or 'mint', got {recipe!r}")


def _track(envelope: np.ndarray, start_bpm: float | None) -> np.ndarray:
    bpm = 120.0 if start_bpm is None else float(start_bpm)
    if not bpm > 0:
        raise ValueError(f"start_bpm: must be > 0, got {start_bpm!r}")
    _, beats = librosa.beat.beat_track(
        onset_envelope=envelope, sr=MUSIC_SR, hop_length=MUSIC_HOP, start_bpm=bpm, tightness=100
    )
    return np.asarray(beats, dtype=np.int64)


def music_beat_onehot(
    audio: np.ndarray, sr: int, *, recipe: MusicRecipe = "bailando", start_bpm: float | None = None
) -> np.ndarray:
    """Boolean beat vector ``(F,)`` at 60 fps, one entry per onset-envelope frame (§1.5).

    This is Bailando's ``music_array[:, 53]`` (``recipe="bailando"``) or mint's ``audio_feature[:, -1]``
    (``recipe="mint"``, pass ``start_bpm=aistpp_tempo(name)`` for AIST++ music; GCDG uses the given
    bpm, default 120).
    """
    envelope = music_onset_envelope(audio, sr, recipe=recipe)
    onehot = np.zeros(envelope.shape[0], dtype=bool)
    onehot[_track(envelope, start_bpm)] = True
    return onehot


def music_beats(
    audio: np.ndarray, sr: int, *, recipe: MusicRecipe = "bailando", start_bpm: float | None = None
) -> np.ndarray:
    """Music beat frame indices (int64, increasing) at 60 fps — MoFusion §4.1 / METRICS.md §1.5.

    Args:
        audio: waveform ``(S,)`` or ``(C, S)`` in [-1, 1].
        sr: its sample rate in Hz (resampled to 30720 Hz internally).
        recipe: ``"bailando"`` (HPSS + median onset strength, start_bpm 120) or ``"mint"``
            (full-signal onset strength, ``start_bpm`` prior).
        start_bpm: tempo prior of ``beat_track`` (default 120).

    Beat time in seconds = frame / 60. Note librosa's ``beat_track`` moves the first and last beats
    between librosa versions (METRICS.md §2.8).
    """
    return np.flatnonzero(music_beat_onehot(audio, sr, recipe=recipe, start_bpm=start_bpm)).astype(np.int64)


def motion_envelope(motion: np.ndarray, *, variant: MotionVariant = "bailando") -> np.ndarray:
    """The kinematic envelope whose local minima are motion beats (§1.6).

    ``"bailando"``: ``v_t = mean_j ‖p_{t+1,j} − p_{t,j}‖`` for t = 0..T−2, then
    ``gaussian_filter(v, 5)`` (σ = 5 frames, reflect) → shape ``(T−1,)``.
    ``"mint"``: ``e_0 = 0``, ``e_t = Σ_j ‖p_{t,j} − p_{t−1,j}‖`` in float32 → shape ``(T,)``.
    Units: position units per frame (no division by the frame time).
    """
    joints = as_motion(motion, "motion", min_frames=2)
    if variant == "bailando":
        speed = np.mean(np.sqrt(np.sum((joints[1:] - joints[:-1]) ** 2, axis=2)), axis=1)
        return np.asarray(gaussian_filter(speed, 5))
    if variant == "mint":
        velocity = np.zeros_like(joints, dtype=np.float32)
        velocity[1:] = joints[1:] - joints[:-1]
        return np.sum(np.linalg.norm(velocity, axis=2), axis=1)
    raise ValueError(f"variant: expected 'bailando' or 'mint', got {variant!r}")


def motion_beats(motion: np.ndarray, *, variant: MotionVariant = "bailando") -> np.ndarray:
    """Motion (kinematic) beat frame indices at the motion's frame rate (§1.6).

    ``"bailando"``: ``argrelextrema(envelope, np.less)`` (order 1) of the smoothed ``(T−1,)`` envelope;
    ``"mint"``: ``argrelextrema(envelope, np.less, order=10)`` of the ``(T,)`` envelope (frames 0..10
    can never be beats because ``e_0 = 0``). A static motion has no beats (empty array).
    """
    envelope = motion_envelope(motion, variant=variant)
    order = 1 if variant == "bailando" else 10
    return np.asarray(argrelextrema(envelope, np.less, order=order)[0], dtype=np.int64)


def frames_to_onehot(frames: np.ndarray, length: int) -> np.ndarray:
    """Boolean vector of ``length`` with ``True`` at ``frames`` (frames >= length are dropped)."""
    idx = as_frames(frames, "frames")
    out = np.zeros(int(length), dtype=bool)
    out[idx[idx < length]] = True
    return out


def resample_beat_frames(frames: np.ndarray, from_fps: float, to_fps: float) -> np.ndarray:
    """Beat frame indices at ``from_fps`` mapped to the nearest frames at ``to_fps`` (unique, sorted)."""
    idx = as_frames(frames, "frames")
    if from_fps <= 0 or to_fps <= 0:
        raise ValueError(f"frame rates must be > 0, got {from_fps} -> {to_fps}")
    if from_fps == to_fps:
        return idx
    return np.unique(np.round(idx * (to_fps / from_fps)).astype(np.int64))
