"""Rhythm features that transfer across recordings: beat phase, local tempo and an onset envelope.

A denoiser conditioned on a music *latent* learns what the training music sounds like; a model
trained on synthetic music then meets real songs whose latents it has never seen and ignores them
(issue 32: the shipped model danced the same for any song). The features here describe *when* the
beats fall, not what the music sounds like, so they mean the same thing on any recording:

* an **envelope** whose peaks are rhythmic events: the music's onset strength (librosa), or for
  motion the rise of the mean joint speed (a movement starting: the kinematic onset);
* **beats** tracked on that envelope by librosa's dynamic-programming beat tracker (Ellis 2007),
  extended over the whole input at the median beat period;
* per output frame: ``sin 2πφ``, ``cos 2πφ`` of the beat phase ``φ ∈ [0, 1)`` (0 on a beat),
  the local tempo ``log2(bpm / 120)`` and the envelope, max-pooled over the frame and divided by
  its 95th percentile (clipped to [0, 2]), so the loudness or the body size does not matter.

The AIST++ baseline (FACT) feeds librosa's onset envelope and beat one-hot; a one-hot beat is lost
between frames at a latent rate of 15.6 Hz, while the phase is sampled without aliasing up to
half that rate, so the phase carries the beat here. Inputs with no rhythm (silence, a frozen pose:
fewer than two beats tracked) get zero phase and tempo channels.
"""

from __future__ import annotations

from dataclasses import dataclass

import librosa
import numpy as np
from scipy.ndimage import gaussian_filter1d

__all__ = [
    "RhythmConfig",
    "CHANNELS",
    "ENVELOPE_RATE",
    "track_beats",
    "phase_features",
    "pool_envelope",
    "RhythmTrack",
    "rhythm_features",
    "music_envelope",
    "motion_envelope",
]

CHANNELS = ("beat_sin", "beat_cos", "log2_tempo", "envelope")
"""The feature channels, in order."""

ENVELOPE_RATE = 16000 / 256
"""Rate of every envelope (Hz): librosa's onset strength at 16 kHz, hop 256 (62.5 Hz)."""

_SR = 16000
_HOP = 256


@dataclass(frozen=True)
class RhythmConfig:
    """How beats are tracked on an envelope (librosa.beat.beat_track).

    Attributes:
        start_bpm: the tracker's tempo prior (librosa's default 120).
        tightness: how strictly beats follow the tempo (librosa's default 100).
        min_bpm, max_bpm: a tracked tempo outside this range is halved or doubled into it.
        tempo: ``"tracker"`` — beat_track estimates the tempo itself (its log-normal prior around
            ``start_bpm`` pulls it towards 120 BPM); ``"periodogram"`` — the envelope's dominant period
            (:func:`momu.following.tempo.periodogram_tempo` between ``periodogram_bpm``) is given to
            beat_track, which then only places the beats.
        periodogram_bpm: the tempi (BPM) the periodogram searches. On the 23 real Dance with Melody
            dances played ×0.8 … ×1.25 faster, the beats follow the stretch within 5 % in 88 of 92
            cases with 20-200 BPM, 73 with 30-300 (a kinematic-onset envelope has harmonics at
            150-300 BPM that compete with its fundamental) and 49 with the tracker
            (``benchmarks/dance_tempo_vs_song.py``).
        subdivide: beats per tracked beat: every tracked interval is split into this many equal beats
            before the grid is folded (1: the tracked beats as they are). A dancer who moves once per
            bar gives the bar; ``3`` makes a waltz's three beats of it (``momu generate music
            --beats-per-movement``).
    """

    start_bpm: float = 120.0
    tightness: float = 100.0
    min_bpm: float = 55.0
    max_bpm: float = 160.0
    tempo: str = "tracker"
    periodogram_bpm: tuple[float, float] = (20.0, 200.0)
    subdivide: int = 1


def track_beats(envelope: np.ndarray, rate: float, cfg: RhythmConfig | None = None) -> np.ndarray:
    """Beat times (s) of an envelope sampled at ``rate`` Hz; empty when it has no rhythm."""
    cfg = cfg or RhythmConfig()
    env = np.asarray(envelope, dtype=np.float64)
    if env.size < 4 or not np.isfinite(env).all() or float(env.max() - env.min()) <= 1e-12:
        return np.zeros(0)
    hop = _HOP
    sr = rate * hop  # beat_track only uses sr / hop_length: the envelope's rate
    bpm = None
    if cfg.tempo == "periodogram":
        from momu.following.tempo import periodogram_tempo  # momu.following imports this module

        bpm = periodogram_tempo(env, rate, cfg.periodogram_bpm)
        if not np.isfinite(bpm):
            return np.zeros(0)
    _, frames = librosa.beat.beat_track(
        onset_envelope=env, sr=sr, hop_length=hop, start_bpm=cfg.start_bpm, tightness=cfg.tightness, bpm=bpm
    )
    return np.asarray(frames, dtype=np.float64) / rate


def _beat_grid(beats: np.ndarray, seconds: float, cfg: RhythmConfig) -> np.ndarray:
    """``beats`` split ``cfg.subdivide`` times and extended before the first and after the last at the
    median period, covering ``[0, seconds]``; the period is folded into ``[min_bpm, max_bpm]`` by
    halving/doubling the grid."""
    if cfg.subdivide > 1:
        steps = np.arange(cfg.subdivide) / cfg.subdivide
        inner = (beats[:-1, None] + np.diff(beats)[:, None] * steps).ravel()
        beats = np.concatenate([inner, beats[-1:]])
    period = float(np.median(np.diff(beats)))
    while 60.0 / period > cfg.max_bpm and beats.size >= 4:  # keep every other beat
        beats, period = beats[::2], period * 2
    while 60.0 / period < cfg.min_bpm:  # add the beat between every two
        beats = np.sort(np.concatenate([beats, (beats[:-1] + beats[1:]) / 2]))
        period /= 2
    before = np.arange(beats[0] - period, -period, -period)[::-1]
    after = np.arange(beats[-1] + period, seconds + 2 * period, period)
    return np.concatenate([before, beats, after])


def phase_features(
    beats: np.ndarray, frames: int, frame_rate: float, cfg: RhythmConfig | None = None, start: float = 0.0
) -> np.ndarray:
    """``(frames, 3)``: sin/cos of the beat phase and ``log2(bpm / 120)`` at the centres of ``frames``
    frames of ``frame_rate`` Hz from ``start`` seconds."""
    cfg = cfg or RhythmConfig()
    out = np.zeros((frames, 3), dtype=np.float32)
    beats = np.unique(np.asarray(beats, dtype=np.float64))
    if beats.size < 2 or frames == 0:
        return out
    t = start + (np.arange(frames) + 0.5) / frame_rate
    grid = _beat_grid(beats, float(t[-1]) + 1.0 / frame_rate, cfg)
    i = np.clip(np.searchsorted(grid, t, side="right") - 1, 0, len(grid) - 2)
    span = grid[i + 1] - grid[i]
    phase = (t - grid[i]) / span
    out[:, 0] = np.sin(2 * np.pi * phase)
    out[:, 1] = np.cos(2 * np.pi * phase)
    out[:, 2] = np.log2(60.0 / span / 120.0)
    return out


def pool_envelope(
    envelope: np.ndarray,
    rate: float,
    frames: int,
    frame_rate: float,
    start: float = 0.0,
    scale: float | None = None,
) -> np.ndarray:
    """``(frames,)``: the envelope's maximum over each output frame (from ``start`` seconds), divided by
    ``scale`` (default: the envelope's 95th percentile) and clipped to [0, 2]."""
    env = np.asarray(envelope, dtype=np.float64)
    out = np.zeros(frames, dtype=np.float32)
    if env.size == 0 or frames == 0:
        return out
    scale = float(np.percentile(env, 95)) if scale is None else float(scale)
    if scale <= 1e-12:
        return out
    edges = np.round((start + np.arange(frames + 1) / frame_rate) * rate).astype(int)
    edges = np.clip(edges, 0, env.size)
    for k in range(frames):
        a, b = edges[k], max(edges[k + 1], edges[k] + 1)
        if a < env.size:
            out[k] = env[a:b].max()
    return np.clip(out / scale, 0.0, 2.0).astype(np.float32)


@dataclass(frozen=True)
class RhythmTrack:
    """An input's envelope (at ``rate`` Hz) and tracked beats (s): features of any span of it."""

    envelope: np.ndarray
    rate: float
    beats: np.ndarray
    cfg: RhythmConfig

    @classmethod
    def of(cls, envelope: np.ndarray, rate: float, cfg: RhythmConfig | None = None) -> RhythmTrack:
        cfg = cfg or RhythmConfig()
        return cls(np.asarray(envelope, dtype=np.float64), float(rate), track_beats(envelope, rate, cfg), cfg)

    def features(self, frames: int, frame_rate: float, start: float = 0.0) -> np.ndarray:
        """``(frames, 4)`` features of :data:`CHANNELS` for ``frames`` frames from ``start`` seconds (the
        envelope scaled by the whole input's 95th percentile)."""
        phase = phase_features(self.beats, frames, frame_rate, self.cfg, start)
        scale = float(np.percentile(self.envelope, 95)) if self.envelope.size else 0.0
        env = pool_envelope(self.envelope, self.rate, frames, frame_rate, start, scale)
        return np.concatenate([phase, env[:, None]], axis=1)


def rhythm_features(
    envelope: np.ndarray, rate: float, frames: int, frame_rate: float, cfg: RhythmConfig | None = None
) -> np.ndarray:
    """``(frames, 4)`` features of :data:`CHANNELS` for an envelope at ``rate`` Hz, from its start."""
    return RhythmTrack.of(envelope, rate, cfg).features(frames, frame_rate)


def music_envelope(audio: np.ndarray, sample_rate: int | float) -> np.ndarray:
    """Onset strength (librosa, 16 kHz, hop 256: :data:`ENVELOPE_RATE` Hz) of a mono waveform."""
    y = np.asarray(audio, dtype=np.float32)
    if sample_rate != _SR:
        y = librosa.resample(y, orig_sr=float(sample_rate), target_sr=_SR, res_type="soxr_hq")
    if y.size < 2048:
        y = np.pad(y, (0, 2048 - y.size))
    return np.asarray(librosa.onset.onset_strength(y=y, sr=_SR, hop_length=_HOP), dtype=np.float64)


def motion_envelope(motion: np.ndarray, fps: float, smoothing: float = 0.03) -> np.ndarray:
    """Kinematic onsets of ``(T, J, D)`` keypoints at :data:`ENVELOPE_RATE` Hz: the rise of the mean
    joint speed (Gaussian-smoothed by ``smoothing`` seconds), half-wave rectified. Scale free: the
    speed is divided by its median, so metres and pixels give the same envelope."""
    m = np.asarray(motion, dtype=np.float64)
    if m.ndim != 3 or m.shape[0] < 2:
        return np.zeros(max(1, int(round(m.shape[0] / fps * ENVELOPE_RATE))) if m.ndim else 1)
    speed = np.linalg.norm(np.diff(m, axis=0), axis=-1).mean(axis=1) * fps
    speed = np.concatenate([speed[:1], speed])
    n = max(1, int(round(m.shape[0] / fps * ENVELOPE_RATE)))
    t = np.arange(n) / ENVELOPE_RATE
    s = np.interp(t, np.arange(m.shape[0]) / fps, speed)
    s = gaussian_filter1d(s, smoothing * ENVELOPE_RATE) if smoothing > 0 else s
    median = float(np.median(s))
    if median > 1e-9:
        s = s / median
    return np.maximum(np.diff(s, prepend=s[0]), 0.0)
