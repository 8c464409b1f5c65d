"""What the benchmark measures on one motion or one piece of music, computed once per signal.

A :class:`MotionAnalysis` holds the motion at the common rate, its kinematic beats (both BAS
definitions), its tempo (periodogram of the mean joint speed) and its realism statistics; an
:class:`AudioAnalysis` holds the music's beats (librosa), its tempo (periodogram of the onset envelope,
and the beat grid's), and its log-mel spectrogram. :func:`distance` compares two analyses of the same
kind (the input-sensitivity test).
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from momu.following.beat_align import VARIANTS, kinematic_beats
from momu.following.realism import realism_stats
from momu.following.signals import RATE, joint_speed, log_mel, motion_at_rate, onset_envelope, song_beats
from momu.following.tempo import beat_tempo, periodogram_tempo

__all__ = ["MotionAnalysis", "AudioAnalysis", "Analysis", "analyse_motion", "analyse_audio", "distance"]


@dataclass
class MotionAnalysis:
    """A motion at :data:`~momu.following.signals.RATE`: positions ``(T, J, D)``, beats (s) per BAS
    variant, tempo (BPM), duration (s), realism statistics."""

    positions: np.ndarray
    beats: dict[str, np.ndarray]
    tempo: float
    duration: float
    realism: dict[str, float] = field(default_factory=dict)

    @property
    def energy(self) -> float:
        """Mean joint speed (units/s)."""
        return float(joint_speed(self.positions).mean()) if len(self.positions) > 1 else 0.0


@dataclass
class AudioAnalysis:
    """A piece of music: beat times (s), periodogram and beat-grid tempi (BPM), duration (s), log-mel."""

    beats: np.ndarray
    tempo: float
    beat_tempo: float
    duration: float
    mel: np.ndarray

    @property
    def energy(self) -> float:
        """Mean log-mel level (dB)."""
        return float(self.mel.mean()) if self.mel.size else -80.0


Analysis = MotionAnalysis | AudioAnalysis


def analyse_motion(motion: np.ndarray, fps: float, skeleton: str | None = None) -> MotionAnalysis:
    """Analyse ``motion`` ``(T, J, D)`` at ``fps`` (global positions)."""
    x = motion_at_rate(motion, fps)
    beats: dict[str, np.ndarray] = {v: kinematic_beats(x, v) for v in VARIANTS}
    tempo = periodogram_tempo(joint_speed(x), RATE)
    return MotionAnalysis(x, beats, tempo, (len(x) - 1) / RATE, realism_stats(x, RATE, skeleton))


def analyse_audio(audio: np.ndarray, sample_rate: int) -> AudioAnalysis:
    """Analyse mono ``audio`` at ``sample_rate``."""
    y = np.asarray(audio, dtype=np.float32)
    beats = song_beats(y, sample_rate)
    return AudioAnalysis(
        beats,
        periodogram_tempo(onset_envelope(y, sample_rate), RATE),
        beat_tempo(beats),
        len(y) / sample_rate,
        log_mel(y, sample_rate),
    )


def distance(a: Analysis, b: Analysis) -> float:
    """How different two outputs are, over their common length.

    Motions: mean joint distance (units) of the poses, each frame taken relative to its own centroid:
    the body's movement, whatever path it takes over the floor (the path is reported by the realism
    statistics; issue 32 measured the shipped model's "same dance" on root-relative joints the same
    way). Music: mean absolute log-mel difference (dB).
    """
    if isinstance(a, MotionAnalysis) and isinstance(b, MotionAnalysis):
        n = min(len(a.positions), len(b.positions))
        if a.positions.shape[1:] != b.positions.shape[1:]:
            raise ValueError("distance: motions of different skeletons")
        pa = a.positions[:n] - a.positions[:n].mean(axis=1, keepdims=True)
        pb = b.positions[:n] - b.positions[:n].mean(axis=1, keepdims=True)
        return float(np.linalg.norm(pa - pb, axis=-1).mean())
    if isinstance(a, AudioAnalysis) and isinstance(b, AudioAnalysis):
        n = min(len(a.mel), len(b.mel))
        return float(np.abs(a.mel[:n] - b.mel[:n]).mean()) if n else 0.0
    raise TypeError("distance: a motion and a music analysis cannot be compared")
