"""Beats per movement of a ballroom dance, read from the motion (``momu.features.ballroom_metre``)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from momu.features.ballroom_metre import (
    BAR_BPM,
    WALTZ_RATIO,
    ballroom_beats_per_movement,
    beats_for,
    feet_body_ratio,
    parse_beats_per_movement,
    read_beats,
)
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


@pytest.mark.parametrize(
    ("body_bpm", "feet_bpm", "auto", "ballroom"),
    [
        (29.0, 145.0, 3, 3),  # a waltz danced once per bar: the music's beat is a third of the movement
        (70.0, 210.0, 1, 3),  # quick feet under a body that moves on every beat: already the beat
        (29.0, None, 1, 2),  # feet moving with a slow body: a Latin half bar or the beat, same tempo up to ×2
        (110.0, None, 1, 2),
    ],
)
def test_auto_splits_only_a_waltz_bar(
    body_bpm: float, feet_bpm: float | None, auto: int, ballroom: int
) -> None:
    motion = dancer(body_bpm, feet_bpm)
    for factor in (0.8, 1.0, 1.25):  # whatever speed the dance is played at
        faster = time_scale_motion(motion, FPS, factor)
        assert beats_for("auto", faster, FPS, "dwm21") == auto, factor
        assert beats_for("ballroom", faster, FPS, "dwm21") == ballroom, factor
    n, said = read_beats("auto", motion, FPS, "dwm21")
    assert (
        n == auto
        and said.startswith(f"auto: the body moves {body_bpm:.0f}")
        and said.endswith(f"{auto} beat{'s' if auto > 1 else ''} per movement")
    )
    assert read_beats(2, motion, FPS, "dwm21") == (2, "")


def test_a_frozen_pose_keeps_the_dancers_period() -> None:
    still = np.zeros((int(10 * FPS), 21, 3))
    assert read_beats("auto", still, FPS, "dwm21") == (
        1,
        "auto: no steady movement of the body and feet found: 1 beat per movement",
    )
    assert read_beats("ballroom", still, FPS, "dwm21")[0] == 2


def test_beats_per_movement_values() -> None:
    assert [parse_beats_per_movement(t) for t in ("1", "8", "ballroom", "Auto ")] == [
        1,
        8,
        "ballroom",
        "auto",
    ]
    for bad in ("0", "9", "waltz", ""):
        with pytest.raises(ValueError, match="must be 1 to 8, ballroom or auto"):
            parse_beats_per_movement(bad)


def test_the_dance_with_melody_waltzes_and_the_others(shared_data: Path) -> None:
    from momu.data.motion_files import read_motion_file

    for dance, beats, auto in (("DANCE_W_12", 3, 3), ("DANCE_R_3", 2, 1), ("DANCE_T_5", 2, 1)):
        got = read_motion_file(shared_data / "dance_with_melody" / dance)
        excerpt = got.motion[int(2 * got.fps) : int(17 * got.fps)]
        assert ballroom_beats_per_movement(excerpt, got.fps, "dwm21") == beats, dance
        assert beats_for("auto", excerpt, got.fps, "dwm21") == auto, dance
    assert 1.548 < WALTZ_RATIO < 3.048
    assert 37.7 < BAR_BPM < 50.0
