"""Beats per movement of a ballroom dance, read from the motion (``momu.features.ballroom_metre``)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from momu.features.ballroom_metre import WALTZ_RATIO, ballroom_beats_per_movement, feet_body_ratio
from momu.features.skeletons import get_skeleton
from momu.following.signals import time_scale_motion

FPS = 25.0
FEET = [i for i, n in enumerate(get_skeleton("dwm21").joint_names) if n.endswith(("ankle", "heel", "toe"))]


def dips(rate_bpm: float, t: np.ndarray, depth: float, length: float) -> np.ndarray:
    """A smooth dip of ``depth`` metres over ``length`` seconds once per beat of ``rate_bpm``, held in
    between (down, then back up the next beat)."""
    period = 60.0 / rate_bpm
    u = np.clip((t % period) / length, 0.0, 1.0)
    return depth * (1 - np.cos(np.pi * u)) / 2 * np.where(np.floor(t / period) % 2 == 0, 1, -1)


def dancer(body_bpm: float, feet_bpm: float | None, seconds: float = 15.0) -> np.ndarray:
    """``(T, 21, 3)`` dwm21 positions: the body above the feet rises and falls ``body_bpm`` times a
    minute (a 30-cm, 0.5-s movement); the feet step ``feet_bpm`` times a minute (quick 2-cm, 0.15-s steps;
    ``None``: they move with the body)."""
    t = np.arange(int(seconds * FPS)) / FPS
    pose = np.random.default_rng(0).normal(size=(21, 3))
    x = np.repeat(pose[None], len(t), axis=0)
    upper = [j for j in range(21) if j not in FEET]
    x[:, upper if feet_bpm else slice(None), 1] += dips(body_bpm, t, 0.30, 0.5)[:, None]
    if feet_bpm:
        x[:, FEET, 2] += dips(feet_bpm, t, 0.02, 0.15)[:, None]
    return x


@pytest.mark.parametrize(("feet_bpm", "beats"), [(145.0, 3), (None, 2)])
def test_feet_that_step_within_a_movement_read_as_a_waltz(feet_bpm: float | None, beats: int) -> None:
    motion = dancer(29.0, feet_bpm)
    assert ballroom_beats_per_movement(motion, FPS, "dwm21") == beats
    ratio = feet_body_ratio(motion, FPS, "dwm21")
    assert ratio == pytest.approx((feet_bpm or 29.0) / 29.0, rel=0.05)
    # the ratio is a property of the dance, not of its speed
    for factor in (0.8, 1.25):
        faster = time_scale_motion(motion, FPS, factor)
        assert feet_body_ratio(faster, FPS, "dwm21") == pytest.approx(ratio, rel=0.05)
        assert ballroom_beats_per_movement(faster, FPS, "dwm21") == beats


def test_the_dance_with_melody_waltzes_and_the_others(shared_data: Path) -> None:
    from momu.data.motion_files import read_motion_file

    for dance, beats in (("DANCE_W_12", 3), ("DANCE_R_3", 2), ("DANCE_T_5", 2)):
        got = read_motion_file(shared_data / "dance_with_melody" / dance)
        excerpt = got.motion[int(2 * got.fps) : int(17 * got.fps)]
        assert ballroom_beats_per_movement(excerpt, got.fps, "dwm21") == beats, dance
    assert 1.548 < WALTZ_RATIO < 3.048
