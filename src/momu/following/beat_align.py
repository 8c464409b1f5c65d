"""Beat alignment of a motion with a music's beats, both BAS definitions, with widths in seconds.

The two definitions of METRICS.md §1.6 (:mod:`momu.metrics.beat_align`), restated at the common rate
(:data:`~momu.following.signals.RATE`) so that they mean the same on 25-, 60- or 62.5-fps motion:

* ``"bailando"`` (MoFusion Eq. 10): kinematic beats are the strict local minima of the mean joint
  speed smoothed by a Gaussian of :data:`BAILANDO_SMOOTH_S` (Bailando's 5 frames at 60 fps); the score
  is averaged over the **music** beats, ``exp(−Δ²/2σ²)`` of each one's nearest kinematic beat.
* ``"mint"`` (FACT): kinematic beats are the minima of the unsmoothed summed joint speed over a
  window of ±:data:`MINT_ORDER_S` (mint's order 10 at 60 fps); averaged over the **motion** beats.

σ = :data:`SIGMA_S` (Bailando's 3 frames at 60 fps). The arithmetic is
:func:`momu.metrics.beat_align.beat_align_score` on frame indices at ``RATE``. Where a side has no beats
(a static motion, silent music) the score is 0: nothing aligns.
"""

from __future__ import annotations

from typing import Literal

import numpy as np
from scipy.ndimage import gaussian_filter1d
from scipy.signal import argrelextrema

from momu.following.signals import RATE, joint_speed
from momu.metrics.beat_align import beat_align_score

__all__ = ["VARIANTS", "SIGMA_S", "kinematic_beats", "bas_seconds", "half_beat_shift"]

Variant = Literal["bailando", "mint"]
VARIANTS: tuple[Variant, ...] = ("bailando", "mint")
SIGMA_S = 0.05
"""Gaussian width σ of both scores (s): 3 frames at 60 fps."""
BAILANDO_SMOOTH_S = 5.0 / 60.0
"""Smoothing σ of the Bailando speed envelope (s): 5 frames at 60 fps."""
MINT_ORDER_S = 10.0 / 60.0
"""Half-window of mint's minima (s): order 10 at 60 fps."""


def kinematic_beats(motion: np.ndarray, variant: Variant = "bailando", rate: float = RATE) -> np.ndarray:
    """Kinematic beat times (s) of ``motion`` ``(T, J, D)`` sampled at ``rate`` (see the module docstring)."""
    speed = joint_speed(motion, rate)
    if speed.size < 3 or not np.any(speed > 1e-9):
        return np.zeros(0)
    if variant == "bailando":
        env = gaussian_filter1d(speed, BAILANDO_SMOOTH_S * rate)
        idx = argrelextrema(env, np.less)[0]
    elif variant == "mint":
        idx = argrelextrema(speed, np.less, order=max(1, int(round(MINT_ORDER_S * rate))))[0]
    else:
        raise ValueError(f"variant: expected 'bailando' or 'mint', got {variant!r}")
    return (idx + 0.5) / rate  # the speed between frames t and t+1 sits at t + ½


def bas_seconds(
    music_beats: np.ndarray,
    motion_beats: np.ndarray,
    duration: float,
    variant: Variant = "bailando",
    sigma: float = SIGMA_S,
    rate: float = RATE,
) -> float:
    """BAS of beat times (s) within ``[0, duration)`` with σ in seconds; 0.0 when a side has no beats."""
    music = np.asarray(music_beats, dtype=np.float64)
    dance = np.asarray(motion_beats, dtype=np.float64)
    music = music[(music >= 0) & (music < duration)]
    dance = dance[(dance >= 0) & (dance < duration)]
    if music.size == 0 or dance.size == 0:
        return 0.0
    m = np.round(music * rate).astype(np.int64)
    d = np.round(dance * rate).astype(np.int64)
    return beat_align_score(m, d, sigma=sigma * rate, over="music" if variant == "bailando" else "motion")


def half_beat_shift(beats: np.ndarray) -> np.ndarray:
    """``beats`` moved later by half their median interval (the grid most out of phase with them)."""
    b = np.asarray(beats, dtype=np.float64)
    if b.size < 2:
        return b
    return b + 0.5 * float(np.median(np.diff(b)))
