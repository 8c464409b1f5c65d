"""Signals, tempo and beat alignment of the music-following benchmark on constructed signals."""

from __future__ import annotations

import numpy as np
import pytest

from momu.following.beat_align import bas_seconds, half_beat_shift, kinematic_beats
from momu.following.signals import RATE, motion_at_rate, song_beats, time_scale_motion, time_stretch_audio
from momu.following.tempo import fold_ratio, periodogram_tempo, tempo_matches


def _swing(bpm: float, seconds: float, fps: float) -> np.ndarray:
    """A 3-joint 'dancer' whose joints swing sideways once per two beats: speed minima on every beat."""
    t = np.arange(int(seconds * fps)) / fps
    x = 0.3 * np.cos(np.pi * bpm / 60.0 * t)  # extremes (speed 0) on the beats
    motion = np.zeros((len(t), 3, 3))
    motion[:, :, 0] = x[:, None] * np.array([1.0, 0.5, 0.8])
    motion[:, :, 1] = np.array([1.0, 1.5, 0.1])
    return motion


def _clicks(bpm: float, seconds: float, sr: int = 16000) -> tuple[np.ndarray, np.ndarray]:
    import librosa

    beats = np.arange(0.5, seconds, 60.0 / bpm)
    return librosa.clicks(times=beats, sr=sr, length=int(seconds * sr)).astype(np.float32), beats


@pytest.mark.parametrize("fps", [25.0, 60.0])
def test_periodogram_finds_the_tempo_of_a_swing(fps: float) -> None:
    x = motion_at_rate(_swing(120.0, 12.0, fps), fps)
    speed = np.linalg.norm(np.diff(x, axis=0), axis=-1).mean(axis=1)
    assert periodogram_tempo(speed, RATE) == pytest.approx(120.0, rel=0.01)


def test_periodogram_of_a_constant_is_nan() -> None:
    assert np.isnan(periodogram_tempo(np.ones(1000), RATE))


@pytest.mark.parametrize("factor", [0.8, 0.9, 1.1, 1.25])
def test_time_scaling_a_motion_scales_its_tempo(factor: float) -> None:
    base = _swing(100.0, 16.0, 25.0)
    scaled = time_scale_motion(base, 25.0, factor)
    assert len(scaled) == pytest.approx(len(base) / factor, abs=1)

    def tempo(m: np.ndarray) -> float:
        x = motion_at_rate(m, 25.0)
        return periodogram_tempo(np.linalg.norm(np.diff(x, axis=0), axis=-1).mean(axis=1), RATE)

    assert tempo(scaled) / tempo(base) == pytest.approx(factor, rel=0.02)


def test_time_stretched_clicks_change_tempo() -> None:
    audio, _ = _clicks(100.0, 12.0)
    faster = time_stretch_audio(audio, 1.25)
    b0, b1 = song_beats(audio, 16000), song_beats(faster, 16000)
    assert 60.0 / np.median(np.diff(b1)) / (60.0 / np.median(np.diff(b0))) == pytest.approx(1.25, rel=0.05)


def test_octave_tolerance() -> None:
    assert tempo_matches(120.0, 60.0) and tempo_matches(120.0, 40.0) and tempo_matches(118.0, 120.0)
    assert not tempo_matches(120.0, 90.0)  # 4/3 is not counted
    assert not tempo_matches(120.0, 30.0)  # nor ×4
    assert not tempo_matches(float("nan"), 120.0)
    assert fold_ratio(2.5) == pytest.approx(1.25)
    assert fold_ratio(0.4) == pytest.approx(0.8)
    assert fold_ratio(1.1) == pytest.approx(1.1)
    assert fold_ratio(0.2) == pytest.approx(0.8)
    assert fold_ratio(4 * 1.25) == pytest.approx(1.25)


def test_bas_on_beat_beats_half_beat_off() -> None:
    bpm, seconds = 120.0, 10.0
    motion = motion_at_rate(_swing(bpm, seconds, 60.0), 60.0)
    beats = np.arange(0.0, seconds, 60.0 / bpm)
    for variant in ("bailando", "mint"):
        kin = kinematic_beats(motion, variant)  # type: ignore[arg-type]
        assert len(kin) > 10
        own = bas_seconds(beats, kin, seconds, variant)  # type: ignore[arg-type]
        off = bas_seconds(half_beat_shift(beats), kin, seconds, variant)  # type: ignore[arg-type]
        assert own > 0.85 and off < 0.1  # the beat at t = 0 has no kinematic beat (the edge)


def test_static_motion_has_no_beats_and_scores_zero() -> None:
    still = np.ones((500, 3, 3))
    assert kinematic_beats(still, "bailando").size == 0
    assert bas_seconds(np.arange(0, 5, 0.5), kinematic_beats(still, "bailando"), 5.0) == 0.0
