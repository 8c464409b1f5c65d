"""Tempo of an envelope (motion speed or music onsets) and octave-tolerant tempo comparison.

:func:`periodogram_tempo` is the one tempo estimator of the benchmark, used alike on a motion's joint
speed and on a music's onset envelope (both at :data:`~momu.following.signals.RATE`): the strongest peak
of the Hann-windowed, zero-padded periodogram of the linearly detrended envelope between
:data:`BPM_RANGE` (20-200 BPM), refined by a parabola through the log power of the peak bin and its
neighbours.

Octave tolerance: real dancers move at a simple fraction or multiple of the beat (Dance with Melody:
cha-cha and rumba at ½ of the beat, waltz at ⅓ — the bar; the speed of a swinging limb peaks twice per
swing, so ×2 appears too), so two tempi *match* when their ratio is within ``tolerance`` (5 %) of one
of :data:`OCTAVE_RATIOS` = 1, 2, ½, 3, ⅓. ×4 / ¼ (a 4/4 bar) and ×3/2 are not counted: with them a
random pair of tempi in 60-180 BPM would match most of the time. The ratio of two tempo estimates of
outputs of the same kind (tempo following) is folded by powers of 2 only (:func:`fold_ratio`).
"""

from __future__ import annotations

import numpy as np

__all__ = [
    "BPM_RANGE",
    "OCTAVE_RATIOS",
    "TOLERANCE",
    "periodogram_tempo",
    "beat_tempo",
    "tempo_matches",
    "fold_ratio",
]

BPM_RANGE = (20.0, 200.0)
"""Tempi (BPM) the periodogram searches."""
OCTAVE_RATIOS = (1.0, 2.0, 0.5, 3.0, 1.0 / 3.0)
"""Ratios under which two tempi count as the same (see the module docstring)."""
TOLERANCE = 0.05
"""Relative tolerance of a tempo match (5 %)."""
RESOLUTION_BPM = 0.05
"""Bin spacing of the zero-padded periodogram (BPM)."""


def periodogram_tempo(envelope: np.ndarray, rate: float, bpm_range: tuple[float, float] = BPM_RANGE) -> float:
    """Dominant tempo (BPM) of ``envelope`` sampled at ``rate`` Hz; NaN for a constant envelope or one
    shorter than two periods of the slowest tempo searched."""
    x = np.asarray(envelope, dtype=np.float64)
    lo, hi = bpm_range
    if x.size < 2 or x.size / rate < 2 * 60.0 / hi:
        return float("nan")
    t = np.arange(x.size)
    x = x - np.polyval(np.polyfit(t, x, 1), t)
    if not np.any(np.abs(x) > 1e-12 * (1.0 + np.abs(envelope).max())):
        return float("nan")
    n_fft = max(x.size, int(np.ceil(rate * 60.0 / RESOLUTION_BPM)))
    power = np.abs(np.fft.rfft(x * np.hanning(x.size), n_fft)) ** 2
    bpm = np.fft.rfftfreq(n_fft, 1.0 / rate) * 60.0
    band = np.flatnonzero((bpm >= lo) & (bpm <= hi))
    k = band[int(np.argmax(power[band]))]
    if 0 < k < len(power) - 1 and np.all(power[k - 1 : k + 2] > 0):
        a, b, c = np.log(power[k - 1 : k + 2])
        den = a - 2 * b + c
        shift = 0.5 * (a - c) / den if den < 0 else 0.0
        return float((k + shift) * rate * 60.0 / n_fft)
    return float(bpm[k])


def beat_tempo(beats: np.ndarray) -> float:
    """Tempo (BPM) of a beat grid: 60 / the median inter-beat interval; NaN with fewer than 2 beats."""
    b = np.asarray(beats, dtype=np.float64)
    if b.size < 2:
        return float("nan")
    return float(60.0 / np.median(np.diff(b)))


def tempo_matches(a: float, b: float, tolerance: float = TOLERANCE) -> bool:
    """Whether tempi ``a`` and ``b`` match within ``tolerance`` up to one of :data:`OCTAVE_RATIOS`."""
    if not (np.isfinite(a) and np.isfinite(b)) or a <= 0 or b <= 0:
        return False
    return any(abs(a / (b * r) - 1.0) <= tolerance for r in OCTAVE_RATIOS)


def fold_ratio(ratio: float) -> float:
    """``ratio · 2^k`` for the integer ``k`` that brings it into ``[1/√2, √2)`` (the nearest to 1 in log).

    Used on the ratio of two tempo estimates of the *same* output kind (a stretched input's output over
    the excerpt's), where the estimator's usual error is an octave. Folding by powers of 2 ignores the
    true ratio, so it cannot bias a ratio in [1/√2, √2) — every time stretch the benchmark applies —
    towards any value. A ×3 is not folded: with both ×2 and ×3 the stretch ×1.25 under an octave error
    (2.5) would fold to 2.5/3 = 0.83, nearer 1 than 1.25.
    """
    if not np.isfinite(ratio) or ratio <= 0:
        return float("nan")
    return float(ratio * 2.0 ** (-np.round(np.log2(ratio))))
