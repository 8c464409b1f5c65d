"""Signal helpers of ``benchmarks/dwm_alignment_study.py``: motion speed and periodicity, song and
motion beats, phase locking, resampling, and the GT-vs-shuffled summary of a pair-score matrix."""

from __future__ import annotations

import itertools
from collections.abc import Callable

import librosa
import numpy as np
from scipy.interpolate import interp1d
from scipy.ndimage import gaussian_filter1d
from scipy.signal import argrelextrema

from momu.metrics.beats import MUSIC_FPS

SR = 22050  # the study's audio rate (librosa's default)


def speed(motion: np.ndarray) -> np.ndarray:
    """Mean joint speed per frame transition, ``(T-1,)`` (units/frame)."""
    return np.linalg.norm(np.diff(motion, axis=0), axis=-1).mean(axis=1)


def acf_period(x: np.ndarray, fps: float, lo: float, hi: float) -> tuple[float, float]:
    """Lag (s) and value of the highest autocorrelation peak in ``[lo, hi]`` s (parabolic refinement)."""
    x = x - x.mean()
    n = len(x)
    spec = np.fft.rfft(x, 2 * n)
    ac = np.fft.irfft(np.abs(spec) ** 2)[:n]
    ac = ac / ac[0]
    i0, i1 = int(np.ceil(lo * fps)), int(np.floor(hi * fps))
    peaks = [i for i in range(max(i0, 1), min(i1, n - 2) + 1) if ac[i] > ac[i - 1] and ac[i] >= ac[i + 1]]
    if not peaks:
        return float("nan"), float("nan")
    i = max(peaks, key=lambda k: ac[k])
    a, b, c = ac[i - 1], ac[i], ac[i + 1]
    shift = 0.5 * (a - c) / (a - 2 * b + c) if (a - 2 * b + c) != 0 else 0.0
    return (i + shift) / fps, float(b)


def long_lag_period(x: np.ndarray, fps: float, period: float, horizon: float = 20.0) -> tuple[float, float]:
    """Period (s) of ``x`` near ``period`` from its autocorrelation peaks at ``k·period`` (k = 2.. up to
    ``horizon`` s; parabolic refinement, median of ``lag_k / k``) and the mean peak value.

    Long lags make the estimate ~k times finer than the frame spacing (0.04 s at 25 fps).
    """
    x = x - x.mean()
    n = len(x)
    spec = np.fft.rfft(x, 2 * n)
    ac = np.fft.irfft(np.abs(spec) ** 2)[:n]
    ac = ac / ac[0]
    est, vals = [], []
    for k in range(2, int(horizon / period) + 1):
        c, w = int(round(k * period * fps)), max(2, int(0.12 * period * fps))
        if c + w + 1 >= n:
            break
        i = c - w + int(np.argmax(ac[c - w : c + w + 1]))
        if not (ac[i] > ac[i - 1] and ac[i] >= ac[i + 1]):
            continue
        a, b, d = ac[i - 1], ac[i], ac[i + 1]
        den = a - 2 * b + d
        est.append((i + (0.5 * (a - d) / den if den else 0.0)) / fps / k)
        vals.append(b)
    if not est:
        return float("nan"), float("nan")
    return float(np.median(est)), float(np.mean(vals))


def song_beats(audio: np.ndarray) -> np.ndarray:
    """Beat times (s) of ``audio`` (librosa defaults: onset strength + beat_track, 22050 Hz, hop 512)."""
    env = librosa.onset.onset_strength(y=audio, sr=SR, hop_length=512)
    _, frames = librosa.beat.beat_track(onset_envelope=env, sr=SR, hop_length=512)
    return np.asarray(librosa.frames_to_time(frames, sr=SR, hop_length=512), dtype=np.float64)


def motion_beat_times(motion: np.ndarray, fps: float, sigma: float = 2.0) -> np.ndarray:
    """Kinematic beats (s): strict minima of the σ-frame smoothed mean joint speed."""
    env = gaussian_filter1d(speed(motion), sigma)
    return (argrelextrema(env, np.less)[0] + 0.5) / fps


def motion_beat_grid(motion: np.ndarray, fps: float) -> np.ndarray:
    """A constant-tempo beat grid (s) tracked on the motion: ``beat_track`` on its kinetic novelty.

    Novelty = the positive part of −z(smoothed speed) (peaks at the pauses of the movement), at the
    motion frame rate (``sr = fps · 512``, hop 512).
    """
    env = gaussian_filter1d(speed(motion), 2.0)
    novelty = np.maximum(0.0, -(env - env.mean()) / (env.std() + 1e-12))
    _, frames = librosa.beat.beat_track(onset_envelope=novelty, sr=int(round(fps * 512)), hop_length=512)
    return (np.asarray(frames, dtype=np.float64) + 0.5) / fps


def vector_strength(times: np.ndarray, beats: np.ndarray) -> tuple[float, int]:
    """``|mean exp(2πiφ)|`` of the phases φ of ``times`` inside the beat intervals, and their count."""
    i = np.searchsorted(beats, times) - 1
    ok = (i >= 0) & (i < len(beats) - 1)
    if not ok.any():
        return float("nan"), 0
    phase = (times[ok] - beats[i[ok]]) / (beats[i[ok] + 1] - beats[i[ok]])
    return float(np.abs(np.exp(2j * np.pi * phase).mean())), int(ok.sum())


def beat_coherence(envelope: np.ndarray, times: np.ndarray, beats: np.ndarray, period_beats: int) -> float:
    """Phase-insensitive lock of a motion envelope to a song's beat grid, in [0, 1].

    ``|Σ x_k exp(2πi φ_k)| / sqrt(N Σ x_k²)`` with ``x`` the centred envelope at ``times`` (s) and ``φ_k``
    the position of ``times[k]`` in the song's beat grid in units of ``period_beats`` beats (beat index +
    fraction of the interval, so tempo changes the tracker follows are followed). A constant offset
    between motion and music does not change it; a time-scale error makes the phase wrap and lowers it.
    """
    i = np.searchsorted(beats, times) - 1
    ok = (i >= 0) & (i < len(beats) - 1)
    if ok.sum() < 2:
        return float("nan")
    phase = (i[ok] + (times[ok] - beats[i[ok]]) / (beats[i[ok] + 1] - beats[i[ok]])) / period_beats
    x = envelope[ok] - envelope[ok].mean()
    return float(np.abs(np.sum(x * np.exp(2j * np.pi * phase))) / np.sqrt(np.sum(x**2) * ok.sum()))


def to_60fps(motion: np.ndarray, fps: float) -> np.ndarray:
    t = np.arange(motion.shape[0]) / fps
    return interp1d(t, motion, axis=0)(np.arange(int(t[-1] * MUSIC_FPS)) / MUSIC_FPS)


def resample(motion: np.ndarray, fps: float, target: float) -> np.ndarray:
    t = np.arange(motion.shape[0]) / fps
    return interp1d(t, motion, axis=0)(np.arange(int(t[-1] * target) + 1) / target)


def gt_vs_shuffled(m: np.ndarray, mask: np.ndarray | None = None) -> tuple[float, float, int, float, float]:
    """Summary of a (motion i, song j) score matrix.

    Returns: mean of the diagonal (GT), mean off the diagonal (shuffled), how many motions score best
    with their own song, the off-diagonal mean over ``mask`` (pairs of different tempi; NaN without a
    mask), and the permutation p-value: the fraction of all derangements σ (every motion with another
    song) whose mean ``m[i, σ(i)]`` is at least the GT mean.
    """
    n = m.shape[0]
    off = ~np.eye(n, dtype=bool)
    own_best = int(sum(m[i, i] > np.max(np.delete(m[i], i)) for i in range(n)))
    other = float(np.mean(m[off & mask])) if mask is not None and (off & mask).any() else float("nan")
    gt = float(np.mean(np.diag(m)))
    perms = np.array(list(itertools.permutations(range(n)))) if n <= 8 else None
    p_value = float("nan")
    if perms is not None:
        perms = perms[np.all(perms != np.arange(n), axis=1)]
        means = m[np.arange(n), perms].mean(axis=1)
        p_value = float(np.mean(means >= gt - 1e-12))
    return gt, float(np.mean(m[off])), own_best, other, p_value


def pair_matrix(n: int, score: Callable[[int, int], float]) -> np.ndarray:
    return np.array([[score(i, j) for j in range(n)] for i in range(n)])
