"""Rhythm condition features (issue 32): beats, tempo and phase of clicks and of a moving body.

``momu.features.rhythm`` and the registered encoders ``music_rhythm`` / ``motion_rhythm`` describe
*when* the beats fall, so a click track at a known tempo and a body that moves once per known period
have known answers.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.signal import find_peaks

from momu.config import build_component
from momu.encoders.rhythm import MotionRhythm, MusicRhythm
from momu.features.rhythm import CHANNELS, ENVELOPE_RATE, motion_envelope, phase_features
from momu.registry import ENCODERS

SR = 22050
"""Sample rate of the synthetic clicks (not the encoder's 16 kHz: the encoder resamples)."""
FRAME_RATE = 25.0
SECONDS = 8.0


def clicks(bpm: float, seconds: float = SECONDS, offset: float = 0.25) -> np.ndarray:
    """A 1 kHz click of 10 ms every beat of ``bpm``, the first at ``offset`` seconds."""
    y = np.zeros(int(seconds * SR), dtype=np.float32)
    n = int(0.01 * SR)
    click = (np.sin(2 * np.pi * 1000 * np.arange(n) / SR) * np.hanning(n)).astype(np.float32)
    for t in np.arange(offset, seconds, 60.0 / bpm):
        i = int(t * SR)
        y[i : i + n] += click[: len(y[i : i + n])]
    return y


def stepping(period: float, seconds: float = SECONDS, fps: float = 30.0, offset: float = 0.2) -> np.ndarray:
    """``(T, 5, 3)`` keypoints of a body that dips (then, next period, rises) by 10 cm in 0.15 s once
    every ``period`` seconds from ``offset`` and holds still in between: one movement per period."""
    t = np.arange(int(seconds * fps)) / fps
    k = np.floor((t - offset) / period)
    u = np.clip((t - offset - k * period) / 0.15, 0.0, 1.0)
    step = (1 - np.cos(np.pi * u)) / 2
    y = np.where(k % 2 == 0, -0.1 * step, -0.1 * (1 - step))
    y = np.where(t < offset, 0.0, y)
    pose = np.random.default_rng(0).normal(size=(5, 3))
    motion = np.repeat(pose[None], len(t), axis=0)
    motion[:, :, 1] += y[:, None]
    return motion


def beat_cycles(features: np.ndarray) -> np.ndarray:
    """The beat phase in cycles (unwrapped) from the sin/cos channels."""
    return np.unwrap(np.arctan2(features[:, 0], features[:, 1])) / (2 * np.pi)


def tempo_of(features: np.ndarray) -> float:
    """The median tempo (BPM) of the ``log2(bpm / 120)`` channel."""
    return float(120.0 * 2.0 ** np.median(features[:, 2]))


@pytest.fixture(scope="module")
def music() -> MusicRhythm:
    return MusicRhythm()


@pytest.mark.parametrize("bpm", [120.0, 90.0, 150.0])
def test_click_track_tempo_and_beats(music: MusicRhythm, bpm: float) -> None:
    track = music.track(clicks(bpm), SR)
    period = 60.0 / bpm
    assert 60.0 / float(np.median(np.diff(track.beats))) == pytest.approx(bpm, rel=0.05)
    # every tracked beat is on a click (onset detection lags by a frame or two: < 60 ms); the last
    # second is left out, where librosa's tracker has no following beat to align to
    inner = track.beats[track.beats < SECONDS - 1.0]
    assert len(inner) >= (SECONDS - 2.5) / period  # the tracker may start a beat or two late
    lag = (inner - 0.25) % period
    assert np.all(np.minimum(lag, period - lag) < 0.06), track.beats
    features = track.features(int(SECONDS * FRAME_RATE), FRAME_RATE)
    assert tempo_of(features) == pytest.approx(bpm, rel=0.05)


@pytest.mark.parametrize("bpm", [120.0, 100.0])
def test_beat_phase_advances_one_cycle_per_beat_and_is_zero_on_the_clicks(
    music: MusicRhythm, bpm: float
) -> None:
    features = music.features(clicks(bpm), SR, int(SECONDS * FRAME_RATE), FRAME_RATE)
    cycles = beat_cycles(features)
    assert np.all(np.diff(cycles) > 0)  # the phase only moves forward
    beats_elapsed = (len(features) - 1) / FRAME_RATE * bpm / 60.0
    assert cycles[-1] - cycles[0] == pytest.approx(beats_elapsed, rel=0.05)
    # at the frames nearest the clicks (from the second on, after the tracker has locked) the phase
    # is within a tenth of a cycle of 0 (cos close to 1)
    click_times = np.arange(0.25 + 60.0 / bpm, SECONDS - 0.5, 60.0 / bpm)
    frames = np.round(click_times * FRAME_RATE - 0.5).astype(int)
    assert np.all(features[frames, 1] > np.cos(2 * np.pi * 0.1)), features[frames, :2]


def test_time_stretch_moves_the_log2_tempo_by_log2_of_the_ratio(music: MusicRhythm) -> None:
    frames = int(SECONDS * FRAME_RATE)
    slow = music.features(clicks(100.0), SR, frames, FRAME_RATE)
    fast = music.features(clicks(125.0), SR, frames, FRAME_RATE)
    shift = float(np.median(fast[:, 2]) - np.median(slow[:, 2]))
    assert shift == pytest.approx(np.log2(1.25), abs=0.03)
    assert float(np.median(slow[:, 2])) == pytest.approx(np.log2(100.0 / 120.0), abs=0.03)


def test_tempo_outside_the_range_is_folded_by_octaves() -> None:
    # documented in RhythmConfig: a tempo outside [min_bpm, max_bpm] is halved or doubled into it
    fast = np.arange(0.0, 8.0, 60.0 / 200.0)  # 200 BPM > max_bpm 160 -> 100 BPM
    slow = np.arange(0.0, 8.0, 60.0 / 40.0)  # 40 BPM < min_bpm 55 -> 80 BPM
    assert tempo_of(phase_features(fast, 100, FRAME_RATE)) == pytest.approx(100.0, rel=1e-3)
    assert tempo_of(phase_features(slow, 100, FRAME_RATE)) == pytest.approx(80.0, rel=1e-3)


def test_no_rhythm_gives_zero_phase_and_tempo(music: MusicRhythm) -> None:
    features = music.features(np.zeros(SR * 2, dtype=np.float32), SR, 50, FRAME_RATE)
    assert features.shape == (50, len(CHANNELS)) and not features.any()
    still = MotionRhythm().features(np.ones((60, 5, 3)), 30.0, 50, FRAME_RATE)
    assert still.shape == (50, len(CHANNELS)) and not still.any()


@pytest.mark.parametrize("period", [0.5, 0.75])
def test_motion_envelope_peaks_once_per_movement(period: float) -> None:
    fps = 30.0
    motion = stepping(period, fps=fps)
    env = motion_envelope(motion, fps)
    assert env.shape == (int(round(len(motion) / fps * ENVELOPE_RATE)),) and np.all(env >= 0)
    peaks, _ = find_peaks(env, height=0.5 * env.max())
    spacing = np.diff(peaks) / ENVELOPE_RATE
    assert len(peaks) == len(np.arange(0.2, SECONDS, period))  # one per movement
    np.testing.assert_allclose(spacing, period, atol=2.5 / ENVELOPE_RATE)
    # each peak is at a movement's start (the rise of the speed), not between movements
    late = (peaks / ENVELOPE_RATE - 0.2) % period
    assert np.all(late < 0.1), late
    # scale free: the same motion in centimetres gives the same envelope
    np.testing.assert_allclose(motion_envelope(motion * 100.0, fps), env, rtol=1e-9, atol=1e-12)


def test_motion_rhythm_tracks_the_movement_tempo() -> None:
    period = 0.5
    features = MotionRhythm().features(stepping(period), 30.0, int(SECONDS * FRAME_RATE), FRAME_RATE)
    assert tempo_of(features) == pytest.approx(60.0 / period, rel=0.05)
    cycles = beat_cycles(features)
    assert cycles[-1] - cycles[0] == pytest.approx((len(features) - 1) / FRAME_RATE / period, rel=0.05)


@pytest.mark.parametrize(
    ("name", "signal", "rate"),
    [("music_rhythm", clicks(120.0, seconds=3.0), SR), ("motion_rhythm", stepping(0.5, seconds=3.0), 30.0)],
)
def test_registered_encoders_features_match_out_channels(name: str, signal: np.ndarray, rate: float) -> None:
    assert name in ENCODERS
    part = build_component({"name": name, "start_bpm": 110.0}, "encoders")
    assert isinstance(part, MusicRhythm if name == "music_rhythm" else MotionRhythm)
    assert part.cfg.start_bpm == 110.0 and part.out_channels == len(CHANNELS) == 4
    features = part.features(signal, rate, 37, 12.5)
    assert features.shape == (37, part.out_channels) and features.dtype == np.float32
    assert np.isfinite(features).all()
    assert np.all((features[:, 3] >= 0) & (features[:, 3] <= 2))  # the envelope, scaled and clipped
    # the track cuts any span: a window from frame 12 equals frames 12-21 of the whole input's features
    track = part.track(signal, rate)
    np.testing.assert_allclose(track.features(37, 12.5), features)
    np.testing.assert_allclose(track.features(10, 12.5, start=12 / 12.5), features[12:22], atol=1e-6)


@pytest.mark.parametrize("name", ["music_rhythm", "motion_rhythm"])
def test_bad_tempo_range_is_named(name: str) -> None:
    with pytest.raises(ValueError, match=f"^{name}: need 0 < min_bpm < max_bpm"):
        build_component({"name": name, "min_bpm": 150.0, "max_bpm": 100.0}, "encoders")
    with pytest.raises(ValueError, match=f"^{name}: max_bpm must be at least 2 x min_bpm"):
        build_component({"name": name, "min_bpm": 80.0, "max_bpm": 120.0}, "encoders")


@pytest.mark.parametrize("period", [0.62, 0.62 / 1.25, 0.62 / 0.8])
def test_periodogram_tempo_follows_a_stretched_movement(period: float) -> None:
    """``tempo: periodogram`` gives beat_track the envelope's dominant period, so the tempo is the
    movement's at any stretch (the tracker's own estimate leans towards its 120-BPM prior)."""
    part = build_component({"name": "motion_rhythm", "tempo": "periodogram"}, "encoders")
    features = part.features(stepping(period, seconds=12.0), 30.0, int(12.0 * FRAME_RATE), FRAME_RATE)
    bpm = 60.0 / period
    while bpm > part.cfg.max_bpm:  # folded into the encoder's range, as the tracker's tempo is
        bpm /= 2
    while bpm < part.cfg.min_bpm:
        bpm *= 2
    assert tempo_of(features) == pytest.approx(bpm, rel=0.05)


def test_periodogram_searches_the_configured_tempi() -> None:
    """``periodogram_bpm`` is where the periodogram looks: a 96.8-BPM stepping searched at 250-300 BPM
    gives its third harmonic (290 BPM, folded to 145), searched at the default 20-200 its own tempo."""
    motion = stepping(0.62, seconds=12.0)
    tempi = []
    for bounds in ([20.0, 200.0], [250.0, 300.0]):
        node = {"name": "motion_rhythm", "tempo": "periodogram", "periodogram_bpm": bounds}
        part = build_component(node, "encoders")
        tempi.append(tempo_of(part.features(motion, 30.0, int(12.0 * FRAME_RATE), FRAME_RATE)))
    assert tempi[0] == pytest.approx(60.0 / 0.62, rel=0.05)
    assert tempi[1] == pytest.approx(3 * 60.0 / 0.62 / 2, rel=0.05)


@pytest.mark.parametrize("name", ["music_rhythm", "motion_rhythm"])
@pytest.mark.parametrize("bounds", [[200.0, 20.0], [0.0, 100.0], [60.0]])
def test_bad_periodogram_range_is_named(name: str, bounds: list[float]) -> None:
    with pytest.raises(ValueError, match=f"^{name}: periodogram_bpm must be \\[low, high\\]"):
        build_component({"name": name, "periodogram_bpm": bounds}, "encoders")


def test_unknown_tempo_estimate_is_named() -> None:
    with pytest.raises(
        ValueError, match="^motion_rhythm: tempo must be one of tracker, periodogram, got 'fft'"
    ):
        build_component({"name": "motion_rhythm", "tempo": "fft"}, "encoders")


@pytest.mark.parametrize("beats", [2, 3])
def test_subdivide_puts_that_many_beats_in_each_movement(beats: int) -> None:
    """A body that moves once per 2.07 s (29 movements a minute, a waltz dancer's bar) read with
    ``subdivide: beats``: the tempo is ``beats ×`` the movement's and every movement still falls on a
    beat (phase 0), the beats between dividing it evenly."""
    period, seconds = 60.0 / 29.0, 20.0
    node = {"name": "motion_rhythm", "tempo": "periodogram", "min_bpm": 20.0, "max_bpm": 200.0}
    motion = stepping(period, seconds=seconds)
    frames = int(seconds * FRAME_RATE)
    plain = build_component(node, "encoders").features(motion, 30.0, frames, FRAME_RATE)
    split = build_component({**node, "subdivide": beats}, "encoders").features(
        motion, 30.0, frames, FRAME_RATE
    )
    assert tempo_of(plain) == pytest.approx(29.0, rel=0.05)
    assert tempo_of(split) == pytest.approx(beats * 29.0, rel=0.05)
    np.testing.assert_allclose(split[:, 3], plain[:, 3])  # the envelope is the dance's, untouched
    cycles_plain, cycles_split = beat_cycles(plain), beat_cycles(split)
    middle = slice(frames // 4, 3 * frames // 4)
    np.testing.assert_allclose(
        cycles_split[middle] - cycles_split[middle][0],
        beats * (cycles_plain[middle] - cycles_plain[middle][0]),
        atol=0.02,
    )


@pytest.mark.parametrize(
    ("value", "message"),
    [
        (0, "^motion_rhythm: subdivide must be a whole number >= 1, got 0"),
        (-1, "^motion_rhythm: subdivide must be a whole number >= 1, got -1"),
        (1.5, "^motion_rhythm.subdivide: invalid value"),  # the config's type check comes first
        (True, "^motion_rhythm.subdivide: invalid value"),
    ],
)
def test_bad_subdivide_is_named(value: object, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        build_component({"name": "motion_rhythm", "subdivide": value}, "encoders")
