"""Signals of the music-following benchmark, all at one common rate (:data:`RATE`, 100 Hz).

Motion and music are compared only after both are brought to :data:`RATE`: motion by a cubic spline
through its frames (linear interpolation would make the speed piecewise constant, and its local minima —
the kinematic beats — ill-defined), music by an onset-strength envelope computed at :data:`AUDIO_RATE`
with hop ``AUDIO_RATE / RATE``. Every width (smoothing, σ, shifts) is given in seconds.
"""

from __future__ import annotations

import librosa
import numpy as np
from scipy.interpolate import make_interp_spline

from momu.data.stretch import time_stretch_audio
from momu.features.audio import resample as resample_audio

__all__ = [
    "RATE",
    "AUDIO_RATE",
    "motion_at_rate",
    "joint_speed",
    "onset_envelope",
    "song_beats",
    "log_mel",
    "time_stretch_audio",
    "time_scale_motion",
    "delay_motion",
    "delay_audio",
    "to_audio_rate",
]

RATE = 100.0
"""The common rate (Hz) of every envelope and beat grid of the benchmark."""
AUDIO_RATE = 16000
"""Audio is analysed at this rate (hop ``AUDIO_RATE / RATE`` = 160 samples: exactly :data:`RATE`)."""
HOP = int(AUDIO_RATE / RATE)


def motion_at_rate(motion: np.ndarray, fps: float, rate: float = RATE) -> np.ndarray:
    """``motion`` ``(T, J, D)`` at ``fps`` resampled to ``rate`` by a cubic spline: ``(T', J, D)`` float64,
    ``T' = floor((T - 1) / fps · rate) + 1`` (the same time span)."""
    x = np.asarray(motion, dtype=np.float64)
    if x.ndim != 3 or x.shape[0] < 2:
        raise ValueError(f"motion: expected (T >= 2, J, D) joint positions, got shape {x.shape}")
    if not fps > 0:
        raise ValueError(f"fps: must be > 0, got {fps}")
    t = np.arange(x.shape[0]) / fps
    out_t = np.arange(int(np.floor(t[-1] * rate + 1e-9)) + 1) / rate
    k = min(3, x.shape[0] - 1)
    return np.asarray(make_interp_spline(t, x, k=k, axis=0)(out_t))


def joint_speed(motion: np.ndarray, rate: float = RATE, joints: np.ndarray | None = None) -> np.ndarray:
    """Mean joint speed per frame transition ``(T - 1,)`` in units per second (over ``joints``: all)."""
    x = motion if joints is None else motion[:, joints]
    return np.linalg.norm(np.diff(x, axis=0), axis=-1).mean(axis=1) * rate


def to_audio_rate(audio: np.ndarray, sample_rate: int) -> np.ndarray:
    """Mono ``audio`` at :data:`AUDIO_RATE` (soxr HQ through librosa)."""
    return np.asarray(resample_audio(np.asarray(audio, dtype=np.float32), sample_rate, AUDIO_RATE))


def onset_envelope(audio: np.ndarray, sample_rate: int) -> np.ndarray:
    """librosa onset strength (mean over mel bands) at :data:`RATE` frames per second."""
    y = to_audio_rate(audio, sample_rate)
    return np.asarray(librosa.onset.onset_strength(y=y, sr=AUDIO_RATE, hop_length=HOP), dtype=np.float64)


def song_beats(audio: np.ndarray, sample_rate: int) -> np.ndarray:
    """Beat times (s) of ``audio``: ``librosa.beat.beat_track`` on :func:`onset_envelope` (start 120 BPM)."""
    env = onset_envelope(audio, sample_rate)
    if not np.any(env > 0):
        return np.zeros(0)
    _, frames = librosa.beat.beat_track(onset_envelope=env, sr=AUDIO_RATE, hop_length=HOP)
    return np.asarray(frames, dtype=np.float64) / RATE


def log_mel(audio: np.ndarray, sample_rate: int, n_mels: int = 64) -> np.ndarray:
    """``(frames, n_mels)`` log-mel spectrogram (dB, floor −80 dB re 1) at :data:`RATE` frames per second."""
    y = to_audio_rate(audio, sample_rate)
    mel = librosa.feature.melspectrogram(y=y, sr=AUDIO_RATE, n_fft=1024, hop_length=HOP, n_mels=n_mels)
    return np.asarray(librosa.power_to_db(mel, ref=1.0, top_db=None), dtype=np.float64).clip(-80.0).T


def time_scale_motion(motion: np.ndarray, fps: float, factor: float) -> np.ndarray:
    """``motion`` played ``factor`` times faster, at the same ``fps`` (tempo × ``factor``; cubic spline)."""
    x = np.asarray(motion, dtype=np.float64)
    if factor == 1.0:
        return x
    t = np.arange(x.shape[0]) / fps
    n = int(np.floor(t[-1] / factor * fps + 1e-9)) + 1
    return np.asarray(make_interp_spline(t, x, k=min(3, x.shape[0] - 1), axis=0)(np.arange(n) / fps * factor))


def delay_motion(motion: np.ndarray, fps: float, seconds: float) -> np.ndarray:
    """``motion`` delayed by ``seconds`` (frame ``t`` shows the pose of ``t − seconds``; the first pose is
    held before the start), same length."""
    x = np.asarray(motion, dtype=np.float64)
    t = np.clip(np.arange(x.shape[0]) / fps - seconds, 0.0, (x.shape[0] - 1) / fps)
    return np.asarray(make_interp_spline(np.arange(x.shape[0]) / fps, x, k=1, axis=0)(t))


def delay_audio(audio: np.ndarray, sample_rate: int, seconds: float) -> np.ndarray:
    """``audio`` delayed by ``seconds`` (silence before), same length."""
    n = int(round(seconds * sample_rate))
    out = np.zeros_like(np.asarray(audio, dtype=np.float32))
    if n < len(out):
        out[n:] = audio[: len(out) - n]
    return out
