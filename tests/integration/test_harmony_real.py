"""Real data: on Dance with Melody, ground-truth music/motion pairs against shuffled pairs.

Reads the raw files (audio.mp3 via soundfile, skeletons.json, config.json start at 25 fps) with a
small local reader. Motion: the 21 points of the paper, root-centred, metres. Shuffled pairs: every
dance's motion with every other dance's music (cut to the shorter). Harmony: HarmoGAN's pipeline at the
native 25 fps. BAS: the motion resampled to the references' 60 fps, music beats by the fast mint recipe
(start_bpm 120), Bailando variant (σ = 3 frames).
"""

from __future__ import annotations

import json
import logging
from pathlib import Path

import numpy as np
import pytest
import soundfile as sf
from scipy.interpolate import interp1d

from momu.metrics import bas, harmony_from_beats, music_beats
from momu.metrics.harmony import audio_beats, motion_beats_harmogan

DATA = Path(__file__).resolve().parents[2].parent / "shared" / "data" / "dance_with_melody"
FPS = 25.0

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
def dances() -> list[tuple[np.ndarray, np.ndarray, int]]:
    return [read_dance(d) for d in sorted(DATA.iterdir()) if (d / "skeletons.json").is_file()]


def test_real_pairs_give_finite_scores_in_range(dances: list[tuple[np.ndarray, np.ndarray, int]]) -> None:
    for motion, audio, sr in dances:
        ta, sa = audio_beats(audio, sr)
        tv, sv, j0 = motion_beats_harmogan(motion, FPS)
        r = harmony_from_beats(ta, sa, tv, sv, j0)
        assert 1.0 < len(ta) / (len(audio) / sr) < 8.0  # onset beats per second of dance music
        assert r.n_audio > 0 and r.n_visual > 0
        assert np.isfinite(r.h) and 0.0 < r.h and 0.0 < r.hit_rate <= 1.0
    motion, audio, sr = dances[0]
    assert 0.0 < bas(to_60fps(motion), music_beats(audio, sr, recipe="mint")) <= 1.0


def to_60fps(motion: np.ndarray) -> np.ndarray:
    t = np.arange(motion.shape[0]) / FPS
    return interp1d(t, motion, axis=0)(np.arange(int(t[-1] * 60)) / 60)


def gt_and_shuffled(scores: np.ndarray) -> tuple[float, float]:
    n = scores.shape[0]
    off = ~np.eye(n, dtype=bool)
    return float(np.mean(np.diag(scores))), float(np.mean(scores[off]))


@pytest.mark.xfail(
    strict=True,
    reason="measured on this 8-dance subset: HarmoGAN's harmony does not separate GT from shuffled pairs "
    "when both are cut to the same duration (h: GT 0.2454 vs shuffled 0.2458; hit rate 0.741 vs 0.758). "
    "Visual beats are dense (6.6/s: every local extremum of the 25-fps velocity sum), so hit rates "
    "saturate near chance, and scanning the audio offset over ±8 s shows no peak at the recorded start.",
)
def test_harmony_gt_beats_shuffled(dances: list[tuple[np.ndarray, np.ndarray, int]]) -> None:
    audio = [audio_beats(a, sr) for _, a, sr in dances]
    visual = [motion_beats_harmogan(m, FPS) for m, _, _ in dances]
    n = len(dances)
    h = np.zeros((n, n))
    for i in range(n):  # motion i
        tv, sv, j0 = visual[i]
        for j in range(n):  # music j
            end = min(dances[i][0].shape[0] / FPS, len(dances[j][1]) / dances[j][2])
            ta, sa = audio[j]
            keep_a, keep_v = ta < end, tv < end
            h[i, j] = harmony_from_beats(ta[keep_a], sa[keep_a], tv[keep_v], sv[keep_v], j0).h
    gt, shuffled = gt_and_shuffled(h)
    logger.warning("Dance with Melody harmony score: GT %.4f, shuffled %.4f", gt, shuffled)
    assert gt > shuffled


@pytest.mark.xfail(
    strict=True,
    reason="measured on this 8-dance subset: Bailando BAS does not separate GT from shuffled pairs "
    "(GT 0.162 vs shuffled 0.166 with root-centred motion; 0.144 vs 0.152 with global positions). "
    "BAS against the music-beat shift is periodic with the beat, without a peak at zero shift: "
    "the phase between velocity minima and music beats differs per dance (approximate start offsets).",
)
def test_bas_gt_beats_shuffled(dances: list[tuple[np.ndarray, np.ndarray, int]]) -> None:
    motions = [to_60fps(m) for m, _, _ in dances]
    beats = [music_beats(a, sr, recipe="mint") for _, a, sr in dances]
    n = len(dances)
    scores = np.array([[bas(motions[i], beats[j]) for j in range(n)] for i in range(n)])
    gt, shuffled = gt_and_shuffled(scores)
    logger.warning("Dance with Melody BAS: GT %.4f, shuffled %.4f", gt, shuffled)
    assert gt > shuffled
