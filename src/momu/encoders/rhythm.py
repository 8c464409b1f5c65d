"""Rhythm condition encoders: ``music_rhythm`` (a song's beats) and ``motion_rhythm`` (a dance's).

Fixed feature extractors (no learned parameters) that any method can use as a condition: each maps
a whole input to ``(frames, 4)`` features at a given frame rate — the beat phase as sin/cos, the
local tempo and a normalised envelope (:mod:`momu.features.rhythm`). Unlike a learned latent they
mean the same on every recording, so a model trained on ``synth_dance`` meets a real song's beats
in the form it was trained on (issue 32).

Protocol (docs/protocols.md, "Condition features"): ``out_channels`` and
``features(signal, rate, frames, frame_rate) -> np.ndarray (frames, out_channels)``, computed over
the whole input at once (beat tracking needs context), then cut into windows by the caller.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from momu.features.rhythm import (
    CHANNELS,
    ENVELOPE_RATE,
    RhythmConfig,
    RhythmTrack,
    motion_envelope,
    music_envelope,
)
from momu.registry import ENCODERS

__all__ = [
    "RhythmEncoderConfig",
    "MotionRhythmConfig",
    "MusicRhythm",
    "MotionRhythm",
    "build_music_rhythm",
    "build_motion_rhythm",
]


@dataclass
class RhythmEncoderConfig:
    """Beat tracking of a rhythm encoder (:class:`momu.features.rhythm.RhythmConfig`).

    Attributes:
        start_bpm, tightness: librosa.beat.beat_track's tempo prior and tightness.
        min_bpm, max_bpm: a tracked tempo outside the range is halved or doubled into it.
        tempo: ``"tracker"`` (librosa estimates it) or ``"periodogram"`` (the envelope's dominant
            period, which follows a time-stretch; :class:`momu.features.rhythm.RhythmConfig`).
        periodogram_bpm: ``[low, high]`` tempi (BPM) the periodogram searches (``tempo: periodogram``).
        subdivide: beats per tracked beat (:class:`momu.features.rhythm.RhythmConfig`; 1 as trained).
    """

    start_bpm: float = 120.0
    tightness: float = 100.0
    min_bpm: float = 55.0
    max_bpm: float = 160.0
    tempo: str = "tracker"
    periodogram_bpm: list[float] = field(default_factory=lambda: [20.0, 200.0])
    subdivide: int = 1

    def rhythm(self) -> RhythmConfig:
        low, high = (float(b) for b in self.periodogram_bpm)
        return RhythmConfig(
            self.start_bpm,
            self.tightness,
            self.min_bpm,
            self.max_bpm,
            self.tempo,
            (low, high),
            int(self.subdivide),
        )


@dataclass
class MotionRhythmConfig(RhythmEncoderConfig):
    """:class:`RhythmEncoderConfig` plus ``smoothing``: seconds of Gaussian smoothing of the joint speed."""

    smoothing: float = 0.03


TEMPO_ESTIMATES = ("tracker", "periodogram")
"""How a rhythm encoder estimates the tempo (:attr:`RhythmEncoderConfig.tempo`)."""


def _check(name: str, cfg: RhythmEncoderConfig) -> None:
    if not 0 < cfg.min_bpm < cfg.max_bpm:
        raise ValueError(f"{name}: need 0 < min_bpm < max_bpm, got {cfg.min_bpm} and {cfg.max_bpm}")
    if cfg.max_bpm < 2 * cfg.min_bpm:
        raise ValueError(
            f"{name}: max_bpm must be at least 2 x min_bpm to hold every tempo, got {cfg.max_bpm}"
        )
    if cfg.start_bpm <= 0 or cfg.tightness <= 0:
        raise ValueError(f"{name}: start_bpm and tightness must be > 0")
    bounds = list(cfg.periodogram_bpm)
    if len(bounds) != 2 or not 0 < float(bounds[0]) < float(bounds[1]):
        raise ValueError(f"{name}: periodogram_bpm must be [low, high] with 0 < low < high, got {bounds}")
    if isinstance(cfg.subdivide, bool) or not isinstance(cfg.subdivide, int) or cfg.subdivide < 1:
        raise ValueError(f"{name}: subdivide must be a whole number >= 1, got {cfg.subdivide!r}")
    if cfg.tempo not in TEMPO_ESTIMATES:
        raise ValueError(f"{name}: tempo must be one of {', '.join(TEMPO_ESTIMATES)}, got {cfg.tempo!r}")


class MusicRhythm:
    """A song's rhythm: onset strength → beats → ``(frames, 4)`` (:data:`.CHANNELS`)."""

    channels = CHANNELS
    out_channels = len(CHANNELS)

    def __init__(self, cfg: RhythmEncoderConfig | None = None) -> None:
        self.cfg = cfg or RhythmEncoderConfig()
        _check("music_rhythm", self.cfg)

    def track(self, audio: np.ndarray, sample_rate: float) -> RhythmTrack:
        """The song's onset envelope and beats; ``.features(frames, frame_rate, start)`` cuts any span."""
        env = music_envelope(np.asarray(audio, dtype=np.float32), sample_rate)
        return RhythmTrack.of(env, ENVELOPE_RATE, self.cfg.rhythm())

    def features(self, audio: np.ndarray, sample_rate: float, frames: int, frame_rate: float) -> np.ndarray:
        """Features of a mono waveform at ``frames`` frames of ``frame_rate`` Hz from its start."""
        return self.track(audio, sample_rate).features(frames, frame_rate)


class MotionRhythm:
    """A dance's rhythm: kinematic onsets → beats → ``(frames, 4)`` (:data:`.CHANNELS`)."""

    channels = CHANNELS
    out_channels = len(CHANNELS)

    def __init__(self, cfg: MotionRhythmConfig | None = None) -> None:
        self.cfg = cfg or MotionRhythmConfig()
        _check("motion_rhythm", self.cfg)
        if self.cfg.smoothing < 0:
            raise ValueError(f"motion_rhythm: smoothing must be >= 0, got {self.cfg.smoothing}")

    def track(self, motion: np.ndarray, fps: float) -> RhythmTrack:
        """The dance's kinematic-onset envelope and beats; ``.features(frames, frame_rate, start)``."""
        return RhythmTrack.of(
            motion_envelope(motion, fps, self.cfg.smoothing), ENVELOPE_RATE, self.cfg.rhythm()
        )

    def features(self, motion: np.ndarray, fps: float, frames: int, frame_rate: float) -> np.ndarray:
        """Features of ``(T, J, D)`` keypoints at ``fps`` at ``frames`` frames of ``frame_rate`` Hz."""
        return self.track(motion, fps).features(frames, frame_rate)


@ENCODERS.register("music_rhythm", config=RhythmEncoderConfig)
def build_music_rhythm(cfg: RhythmEncoderConfig) -> MusicRhythm:
    """Registry factory: a song's beat phase, tempo and onset envelope as condition features."""
    return MusicRhythm(cfg)


@ENCODERS.register("motion_rhythm", config=MotionRhythmConfig)
def build_motion_rhythm(cfg: MotionRhythmConfig) -> MotionRhythm:
    """Registry factory: a dance's beat phase, tempo and kinematic-onset envelope as condition features."""
    return MotionRhythm(cfg)
