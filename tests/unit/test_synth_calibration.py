"""Calibration of synth_dance: the properties the papers' metrics and ablations rely on.

Self-contained scoring (no momu metric code): beat F-measure with one-to-one matching within
70 ms (as mir_eval), a nearest-beat alignment score for motion velocity minima, and a
nearest-centroid style classifier on simple motion statistics. Run with ``-s`` to see the numbers.
"""

from __future__ import annotations

from dataclasses import replace

import librosa
import numpy as np
import pytest
from scipy.ndimage import gaussian_filter1d
from scipy.optimize import linear_sum_assignment
from scipy.signal import argrelextrema, find_peaks

from momu.data.synth import STYLE_NAMES, SynthConfig, generate_clip
from momu.data.synth.styles_ballroom import BALLROOM_STYLES
from momu.data.types import Clip

CFG = SynthConfig(num_clips=24, min_seconds=8.0, max_seconds=12.0, styles=list(STYLE_NAMES), fps=30.0)
# MoMu-Diffusion §5 / LORIS: the onset-detection call MoMu quotes.
MOMU_ONSET = {"wait": 1, "delta": 0.2, "pre_avg": 3, "post_avg": 3, "pre_max": 3, "post_max": 3}


def f_measure(estimated: np.ndarray, reference: np.ndarray, window: float = 0.07) -> float:
    """F-measure of a maximum one-to-one matching of events within ``window`` seconds."""
    if len(estimated) == 0 or len(reference) == 0:
        return 0.0
    hit = np.abs(np.asarray(reference)[:, None] - np.asarray(estimated)[None, :]) <= window
    rows, cols = linear_sum_assignment(-hit.astype(float))
    matched = int(hit[rows, cols].sum())
    precision, recall = matched / len(estimated), matched / len(reference)
    return 0.0 if matched == 0 else 2 * precision * recall / (precision + recall)


def velocity_minima(clip: Clip, sigma: float = 5 / 60, prominence: float = 0.0) -> np.ndarray:
    """Times (s) of local minima of the summed joint speed (HarmoGAN Eq. 2-3 style kinematic beats).

    ``sigma``: Gaussian smoothing of the speed in seconds (Bailando's BAS: 5 frames at 60 fps);
    ``prominence``: keep minima at least this fraction of the clip's peak speed below their
    neighbouring maxima (0 keeps every minimum at least 0.1 s from a lower one).
    """
    assert clip.motion is not None
    speed = np.linalg.norm(np.diff(clip.motion, axis=0), axis=-1).sum(-1)
    if sigma > 0:
        speed = gaussian_filter1d(speed, sigma * clip.fps)
    if prominence > 0:
        idx = find_peaks(-speed, prominence=prominence * speed.max())[0]
    else:
        idx = argrelextrema(speed, np.less, order=max(1, round(0.1 * clip.fps)))[0]
    return (idx + 0.5) / clip.fps  # speed between frames i and i+1


def alignment(music_beats: np.ndarray, motion_beats: np.ndarray, sigma: float = 0.1) -> float:
    """Mean over music beats of exp(-d^2 / 2 sigma^2), d = distance to the nearest motion beat (s)."""
    if len(motion_beats) == 0:
        return 0.0
    d = np.min(np.abs(np.asarray(music_beats)[:, None] - np.asarray(motion_beats)[None, :]), axis=1)
    return float(np.mean(np.exp(-(d**2) / (2 * sigma**2))))


@pytest.fixture(scope="module")
def clips() -> list[Clip]:
    return [generate_clip(CFG, i) for i in range(CFG.num_clips)]


def test_librosa_onsets_recover_the_beat_grid(clips: list[Clip]) -> None:
    scores: dict[str, list[float]] = {s: [] for s in STYLE_NAMES}
    for clip in clips:
        onsets = librosa.onset.onset_detect(y=clip.audio, sr=clip.sample_rate, units="time", **MOMU_ONSET)
        scores[str(clip.style)].append(f_measure(onsets, np.asarray(clip.meta["onset_times"])))
    per_style = {s: float(np.mean(v)) for s, v in scores.items()}
    print("onset F-measure (70 ms) per style:", {s: round(v, 3) for s, v in per_style.items()})
    assert min(per_style.values()) >= 0.9
    assert np.mean([f for v in scores.values() for f in v]) >= 0.95


def test_motion_velocity_minima_sit_on_the_motion_beats(clips: list[Clip]) -> None:
    clean = replace(CFG, motion_noise=0.0)
    for i in range(4):
        clip = generate_clip(clean, i)
        minima = velocity_minima(clip, sigma=0.0)
        beats = np.asarray(clip.meta["motion_beat_times"])
        beats = beats[(beats > 0.2) & (beats < clip.duration - 0.2)]
        d = np.min(np.abs(beats[:, None] - minima[None, :]), axis=1)
        assert np.all(d <= 1.5 / clip.fps), (clip.style, d.max())


def test_ground_truth_pairs_beat_shuffled_pairs(clips: list[Clip]) -> None:
    n = len(clips)
    minima = [velocity_minima(c) for c in clips]
    gt = [alignment(np.asarray(c.meta["onset_times"]), m) for c, m in zip(clips, minima, strict=True)]
    shuffled = []
    for i in range(n):
        for shift in (5, 11):  # music of another clip (different style and tempo), cut to the motion length
            other = clips[(i + shift) % n]
            beats = np.asarray(other.meta["onset_times"])
            shuffled.append(alignment(beats[beats < clips[i].duration], minima[i]))
    print(f"beat alignment: ground truth {np.mean(gt):.3f}, shuffled {np.mean(shuffled):.3f}")
    assert np.mean(gt) >= 0.8
    assert np.mean(gt) - np.mean(shuffled) >= 0.3
    assert min(gt) > np.median(shuffled)


def second_bins(times: np.ndarray, duration: float) -> np.ndarray:
    """LORIS-style beat vector: one boolean per started second, True where an event falls."""
    bins = np.zeros(int(np.ceil(duration)), bool)
    idx = np.asarray(times, dtype=np.float64).astype(int)
    bins[idx[(idx >= 0) & (idx < bins.size)]] = True
    return bins


def test_breaks_make_one_second_bin_scores_discriminative(clips: list[Clip]) -> None:
    """Music breaks leave onset-free seconds, so 1-s-bin scores (MoMu B.4-B.5, LORIS) separate pairs."""
    onsets = [
        second_bins(
            librosa.onset.onset_detect(y=c.audio, sr=c.sample_rate, units="time", **MOMU_ONSET), c.duration
        )
        for c in clips
    ]
    moves = [second_bins(velocity_minima(c, prominence=0.1), c.duration) for c in clips]
    assert np.mean([1 - o.mean() for o in onsets]) >= 0.1  # at least 10 % of the seconds are silent

    def f1(motion_bins: np.ndarray, music_bins: np.ndarray) -> float:
        n = min(motion_bins.size, music_bins.size)
        a, b = motion_bins[:n], music_bins[:n]
        hit = float((a & b).sum())
        return 0.0 if hit == 0 else 2 * hit / (a.sum() + b.sum())

    n = len(clips)
    gt = np.mean([f1(moves[i], onsets[i]) for i in range(n)])
    shuffled = np.mean([f1(moves[i], onsets[(i + s) % n]) for i in range(n) for s in (5, 11)])
    print(f"1-s-bin F1 of motion beats vs music onsets: ground truth {gt:.3f}, shuffled {shuffled:.3f}")
    assert gt - shuffled >= 0.05


def _tempo_feature(clip: Clip) -> np.ndarray:
    """The motion's beat period: median interval (s) between its kinematic beats."""
    intervals = np.diff(velocity_minima(clip))
    return np.array([np.median(intervals[intervals < 1.1])])  # longer intervals: breaks


def _pose_features(clip: Clip) -> np.ndarray:
    """Tempo-free movement-vocabulary statistics (smpl24 joints, relative to the pelvis)."""
    assert clip.motion is not None
    m = clip.motion.astype(np.float64)
    rel = m - m[:, :1]
    joints = [15, 18, 19, 20, 21, 4, 5, 7, 8]  # head, elbows, wrists, knees, ankles
    height = rel[:, joints, 1]
    reach = np.linalg.norm(rel[:, joints][..., [0, 2]], axis=-1)
    travel = np.ptp(m[:, 0, 0]) + np.ptp(m[:, 0, 2])
    return np.concatenate([height.mean(0), height.std(0), reach.mean(0), [travel]])


def _nearest_centroid_accuracy(x: np.ndarray, y: np.ndarray, train: np.ndarray) -> float:
    """Held-out accuracy of a nearest-centroid classifier on train-standardised features."""
    mu, sd = x[train].mean(0), x[train].std(0) + 1e-9
    z = (x - mu) / sd
    names = sorted(set(y[train]))
    centroids = np.stack([z[train & (y == s)].mean(0) for s in names])
    pred = np.array(names)[np.linalg.norm(z[:, None] - centroids[None], axis=-1).argmin(1)]
    return float(np.mean(pred[~train] == y[~train]))


BALLROOM = tuple(s.name for s in BALLROOM_STYLES)
IN_PLACE = tuple(s for s in STYLE_NAMES if s not in BALLROOM)


@pytest.mark.parametrize("family", [IN_PLACE, BALLROOM], ids=["in_place", "ballroom"])
def test_styles_are_separable_on_held_out_clips(family: tuple[str, ...]) -> None:
    """Within each family (disjoint tempo ranges) tempo alone identifies the style, and so does the
    movement vocabulary without tempo."""
    cfg = replace(CFG, num_clips=120, min_seconds=5.0, max_seconds=6.0, styles=list(family))
    data = [generate_clip(cfg, i) for i in range(cfg.num_clips)]
    y = np.array([c.style for c in data])
    train = np.array([c.meta["split"] == "train" for c in data])
    assert (~train).sum() >= 20 and set(y[~train]) == set(family)
    tempo = _nearest_centroid_accuracy(np.stack([_tempo_feature(c) for c in data]), y, train)
    vocab = _nearest_centroid_accuracy(np.stack([_pose_features(c) for c in data]), y, train)
    n = int((~train).sum())
    print(f"held-out style accuracy ({n} clips, chance 0.25): tempo {tempo:.3f}, vocabulary {vocab:.3f}")
    assert tempo >= 0.9
    assert vocab >= 0.75
