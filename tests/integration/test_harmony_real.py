"""Real data: on Dance with Melody, ground-truth music/motion pairs against shuffled pairs.

Reads the raw files (audio.mp3 via soundfile, skeletons.json, config.json start at 25 fps) with a
small local reader. Motion: the 21 points of the paper, root-centred, metres. Shuffled pairs: every
dance's motion with every other dance's music (cut to the shorter). Harmony: HarmoGAN's pipeline. BAS: the
motion resampled to the references' 60 fps, music beats by the fast mint recipe (start_bpm 120), Bailando
variant (σ = 3 frames). BAS does not separate GT from shuffled pairs on this subset (a strict xfail; the
measured causes are in docs/metrics_beats.md "Real-data calibration", produced by
benchmarks/dwm_alignment_study.py).
Harmony cannot, by its definition (issue 15's decision): the tests assert its calibration instead (static
pose + 0.1 mm noise, shuffled windows, clip-length dependence). What holds for the data is that the
motion's bar period follows its song's tempo.
"""

from __future__ import annotations

import json
import logging
from pathlib import Path

import librosa
import numpy as np
import pytest
import soundfile as sf
from scipy.interpolate import interp1d
from scipy.ndimage import gaussian_filter1d
from tests.helpers.shared_data import dance_with_melody_folders, shared_data_dir

from momu.metrics import bas, harmony_from_beats, music_beats
from momu.metrics.harmony import audio_beats, harmony, motion_beats_harmogan

DATA = shared_data_dir() / "dance_with_melody"
FPS = 25.0
FEET = [9, 10, 11, 18, 19, 20]  # ankles and foot points of both legs (dwm21)

pytestmark = pytest.mark.skipif(not DATA.is_dir(), reason=f"{DATA} not available")
logger = logging.getLogger(__name__)


def read_dance(folder: Path) -> tuple[np.ndarray, np.ndarray, int]:
    config = json.loads((folder / "config.json").read_text())
    skeletons = json.loads((folder / "skeletons.json").read_text())
    motion = np.asarray(skeletons["skeletons"], dtype=np.float64)[:, :21] / 100.0  # cm -> m
    info = sf.info(str(folder / "audio.mp3"))
    start = int(round(config["start_position"] / FPS * info.samplerate))
    frames = int(motion.shape[0] / FPS * info.samplerate)
    audio, sr = sf.read(
        str(folder / "audio.mp3"), start=start, frames=frames, dtype="float32", always_2d=True
    )
    return motion, audio.mean(axis=1), int(sr)


@pytest.fixture(scope="module")
def names() -> list[str]:
    """The dances of the folder (whatever version of the subset it holds), in the order of ``dances``."""
    return [d.name for d in dance_with_melody_folders(DATA)]


@pytest.fixture(scope="module")
def dances(names: list[str]) -> list[tuple[np.ndarray, np.ndarray, int]]:
    return [read_dance(DATA / name) for name in names]


def test_real_pairs_give_finite_scores_in_range(
    names: list[str], dances: list[tuple[np.ndarray, np.ndarray, int]]
) -> None:
    """Every dance: finite harmony in range, and its song's onset beats (HarmoGAN's librosa pipeline) at a
    rate of dance music.

    Onset beats per second, measured on the 23 dances: 1.2-6.0 in 22; DANCE_W_11 0.42, a legato song
    whose first note (0.37 s in: the dance starts with the song) and one accent (8.7 s) stand 6.5x above
    the 99th percentile of its onset envelope (1.4-3.4x in the other songs), so librosa's peak picking
    on the max-normalised envelope (delta 0.07) keeps few onsets (0.80/s even without the first
    second). Hence: above 0.3/s in every dance, above 1/s in at least 90 % of them.
    """
    rates = []
    for name, (motion, audio, sr) in zip(names, dances, strict=True):
        ta, sa = audio_beats(audio, sr)
        tv, sv, j0 = motion_beats_harmogan(motion, FPS)
        r = harmony_from_beats(ta, sa, tv, sv, j0)
        rates.append(len(ta) / (len(audio) / sr))  # onset beats per second of dance music
        assert 0.3 < rates[-1] < 8.0, (name, rates[-1])
        assert r.n_audio > 0 and r.n_visual > 0, name
        assert np.isfinite(r.h) and 0.0 < r.h and 0.0 < r.hit_rate <= 1.0, (name, r)
    by_dance = {name: round(rate, 2) for name, rate in zip(names, rates, strict=True)}
    logger.warning("onset beats per second: %s", by_dance)
    assert np.mean(np.asarray(rates) > 1.0) >= 0.9, by_dance
    motion, audio, sr = dances[0]
    assert 0.0 < bas(to_60fps(motion), music_beats(audio, sr, recipe="mint")) <= 1.0


def to_60fps(motion: np.ndarray) -> np.ndarray:
    t = np.arange(motion.shape[0]) / FPS
    return interp1d(t, motion, axis=0)(np.arange(int(t[-1] * 60)) / 60)


def gt_and_shuffled(scores: np.ndarray) -> tuple[float, float]:
    n = scores.shape[0]
    off = ~np.eye(n, dtype=bool)
    return float(np.mean(np.diag(scores))), float(np.mean(scores[off]))


def _windows(
    dances: list[tuple[np.ndarray, np.ndarray, int]], seconds: float
) -> list[tuple[np.ndarray, np.ndarray, int]]:
    """Consecutive ``seconds`` windows of every dance at 15 fps (HarmoGAN's rate), audio cut alike."""
    out = []
    for motion, audio, sr in dances:
        m15 = interp1d(np.arange(len(motion)) / FPS, motion, axis=0)(
            np.arange(int((len(motion) - 1) / FPS * 15)) / 15
        )
        width = int(seconds * 15)
        for k in range(len(m15) // width):
            out.append(
                (
                    m15[k * width : (k + 1) * width],
                    audio[int(k * seconds * sr) : int((k + 1) * seconds * sr)],
                    sr,
                )
            )
    return out


def test_harmony_calibration_on_6s_windows(dances: list[tuple[np.ndarray, np.ndarray, int]]) -> None:
    """What the harmony score can and cannot show (issue 15's decision; docs/papers/harmogan.md):
    ground truth does not beat shuffled pairs on these dances, so the HarmoGAN tables print calibration
    rows instead. Measured at the paper's 6-s clip length and 15 fps: a motionless mean pose with 0.1 mm
    noise scores a hit rate near 1 (the visual mask is relative to the clip's own variation), and pairing
    each window's motion with the next window's music changes h by little."""
    windows = _windows(dances, 6.0)
    rng = np.random.default_rng(0)
    gt = [harmony(a, sr, m, 15.0) for m, a, sr in windows]
    static = [harmony(a, sr, m.mean(0) + rng.normal(0, 1e-4, m.shape), 15.0).hit_rate for m, a, sr in windows]
    shuffled = [
        harmony(windows[(i + 1) % len(windows)][1], sr, m, 15.0).h for i, (m, _, sr) in enumerate(windows)
    ]
    h_gt = float(np.mean([r.h for r in gt]))
    logger.warning("6-s windows: h GT %.3f, shuffled %.3f; static hit rate %.3f vs GT %.3f", h_gt,
                   np.mean(shuffled), np.mean(static), np.mean([r.hit_rate for r in gt]))  # fmt: skip
    assert len(windows) > 80
    assert np.mean(static) > 0.9 > np.mean([r.hit_rate for r in gt])
    assert abs(h_gt - float(np.mean(shuffled))) < 0.03


def test_harmony_depends_on_the_clip_length(dances: list[tuple[np.ndarray, np.ndarray, int]]) -> None:
    """Per-clip saliency normalisation: h falls with the clip length (why every table uses 6-s clips)."""
    means = [
        np.mean([harmony(a, sr, m, 15.0).h for m, a, sr in _windows(dances, s)]) for s in (2.0, 6.0, 20.0)
    ]
    assert means[0] > means[1] > means[2]


@pytest.mark.xfail(
    strict=True,
    reason="a property of the Dance with Melody data, not of momu: Bailando BAS GT 0.156 vs shuffled 0.160 "
    "on the 23 dances. Measured on the first 8 (benchmarks/dwm_alignment_study.py, "
    "docs/metrics_beats.md 'Real-data calibration'): GT 0.162 vs shuffled 0.166 (global "
    "positions 0.149 vs 0.151; mint variant 0.188 vs 0.187). The recorded offset ranks 89th-358th of 401 "
    "shifts over ±8 s: the motion runs 1.4-2.5 % faster than its song, so no single offset aligns a dance; "
    "with the time scale fitted and the best shift within ±1 beat for every pair alike, GT 0.215 vs 0.213 "
    "(p = 0.38): the joint-speed minima of this ballroom motion are not phase-locked to the music beats.",
)
def test_bas_gt_beats_shuffled(dances: list[tuple[np.ndarray, np.ndarray, int]]) -> None:
    motions = [to_60fps(m) for m, _, _ in dances]
    beats = [music_beats(a, sr, recipe="mint") for _, a, sr in dances]
    n = len(dances)
    scores = np.array([[bas(motions[i], beats[j]) for j in range(n)] for i in range(n)])
    gt, shuffled = gt_and_shuffled(scores)
    logger.warning("Dance with Melody BAS: GT %.4f, shuffled %.4f", gt, shuffled)
    assert gt > shuffled


def bar_period(x: np.ndarray, fps: float, guess: float, horizon: float = 20.0) -> float:
    """Period (s) of ``x`` near ``guess`` s: median of ``lag/k`` over its autocorrelation peaks near
    ``k·guess`` (k ≥ 2, lags up to ``horizon`` s, parabolic refinement)."""
    x = x - x.mean()
    ac = np.fft.irfft(np.abs(np.fft.rfft(x, 2 * len(x))) ** 2)[: len(x)]
    est = []
    for k in range(2, int(horizon / guess) + 1):
        c, w = int(round(k * guess * fps)), max(2, int(0.12 * guess * fps))
        i = c - w + int(np.argmax(ac[c - w : c + w + 1]))
        if ac[i] > ac[i - 1] and ac[i] >= ac[i + 1]:
            a, b, d = ac[i - 1], ac[i], ac[i + 1]
            est.append((i + 0.5 * (a - d) / (a - 2 * b + d)) / fps / k)
    return float(np.median(est))


def test_motion_bar_period_matches_song_tempo(
    names: list[str], dances: list[tuple[np.ndarray, np.ndarray, int]]
) -> None:
    """The 25-fps time base and the start_position/25 audio cut agree with the music's tempo.

    The foot-speed bar period (3 beats for waltz, 4 otherwise) over the song's bar, measured on the 23
    dances: 0.977-1.005 in 21 (0.978-1.002 in the first 8); DANCE_W_8 0.967 and DANCE_W_16 1.056. In
    those two the foot-speed spectrum peaks at the same ratio (0.963, 1.067; W_16 also at the beat:
    0.940 motion beats per song beat), the song's beat period is the same in both halves (0.689-0.690 s)
    and the skeletons have no repeated or dropped frames: the two recordings run 3.5 % faster / 6 %
    slower than the songs they come with, a property of the data (docs/datasets.md). Data at 24 or 30 fps
    read as 25 would give ~0.96 / ~1.2 in every dance. Hence: 0.97-1.01 in at least 90 % of the dances,
    0.95-1.08 in every one. On average the motion runs slightly fast (mean 0.992; the drift
    docs/metrics_beats.md "Real-data calibration" measures).
    """
    ratios = []
    for name, (motion, audio, sr) in zip(names, dances, strict=True):
        env = librosa.onset.onset_strength(y=audio, sr=sr)
        _, frames = librosa.beat.beat_track(onset_envelope=env, sr=sr)
        beats = librosa.frames_to_time(frames, sr=sr)
        beat = float(np.polyfit(np.arange(len(beats)), beats, 1)[0])  # mean beat period (s)
        feet = np.linalg.norm(np.diff(motion[:, FEET], axis=0), axis=-1).mean(axis=1)
        per_bar = 3 if "_W_" in name else 4
        ratios.append(bar_period(gaussian_filter1d(feet, 1.0), FPS, per_bar * beat) / (per_bar * beat))
    logger.warning("Dance with Melody motion bar / song bar: %s", np.round(ratios, 4))
    by_dance = {name: round(ratio, 4) for name, ratio in zip(names, ratios, strict=True)}
    assert all(0.95 < r < 1.08 for r in ratios), by_dance
    assert np.mean([0.97 < r < 1.01 for r in ratios]) >= 0.9, by_dance
    assert np.mean(ratios) < 1.0
