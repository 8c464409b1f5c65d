"""HarmoGAN meter segmentation (§IV-A, Fig. 6): strong/weak beats, the mapping table, units, TI, Eq. 12."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from momu.methods.harmogan.meter import (
    MeterConfig,
    initial_pose_input,
    meter_units,
    segment_meters,
    strong_weak,
    transition_indices,
)
from momu.metrics.harmony import audio_beats
from momu.registry import DATASETS


def test_strong_beats_exceed_their_predecessor() -> None:
    assert strong_weak(np.array([3.0, 1.0, 2.0, 2.0, 0.5, 4.0])).tolist() == [1, 0, 1, 0, 0, 1]
    assert strong_weak(np.array([1.0, 1.05]), margin=0.1).tolist() == [1, 0]  # within the margin: weak
    assert strong_weak(np.zeros(0)).tolist() == []


def _accents(pattern: list[float], bars: int) -> np.ndarray:
    return np.tile(np.asarray(pattern), bars)


@pytest.mark.parametrize(
    ("pattern", "meter", "beats"),
    [
        ([1.0, 0.2], "2/4", 2),
        ([1.0, 0.3, 0.2], "3/4", 3),
        ([1.0, 0.3, 0.2, 0.1], "4/4", 4),
        ([1.0, 0.2, 0.6, 0.2], "4/4", 4),  # strong, weak, medium, weak
        ([1.0, 0.3, 0.2, 0.6, 0.3, 0.2], "6/8", 6),
        ([1.0, 0.5, 0.4, 0.3, 0.2, 0.1], "6/8", 6),
    ],
)
def test_mapping_table_recovers_single_meters(pattern: list[float], meter: str, beats: int) -> None:
    meters = segment_meters(_accents(pattern, 4))
    assert [m.meter for m in meters] == [meter] * 4
    assert [m.first_beat for m in meters] == [beats * k for k in range(4)]


def test_mixed_meters_rising_runs_and_long_groups() -> None:
    # a 3/4 bar then a 2/4 bar then a 4/4 bar: every group is mapped on its own
    meters = segment_meters(np.array([1.0, 0.3, 0.2, 0.9, 0.1, 1.0, 0.3, 0.2, 0.1]))
    assert [(m.first_beat, m.meter) for m in meters] == [(0, "3/4"), (3, "2/4"), (5, "4/4")]
    # a rising run (1, 2, 3, then falling) stays in one group: one meter from the first beat
    assert [(m.first_beat, m.num_beats) for m in segment_meters(np.array([1.0, 2.0, 3.0, 0.5]))] == [(0, 4)]
    # groups of 5 and 9 beats: 3/4 + 2/4, and 4/4 + 3/4 + 2/4
    five = segment_meters(np.array([1.0, 0.8, 0.6, 0.4, 0.2]))
    assert [m.meter for m in five] == ["3/4", "2/4"]
    nine = segment_meters(np.linspace(1.0, 0.1, 9))
    assert [m.num_beats for m in nine] == [4, 3, 2] and sum(m.num_beats for m in nine) == 9


@given(
    st.lists(st.floats(0.05, 1.0), min_size=0, max_size=40),
    st.floats(1.0, 20.0),
    st.sampled_from([0.5, 1.0, 2.0, 4.0]),
    st.integers(0, 4),
)
def test_units_tile_the_music(saliency: list[float], duration: float, unit: float, transition: int) -> None:
    fps = 15.0
    times = np.sort(np.random.default_rng(len(saliency)).uniform(0, duration, len(saliency)))
    cfg = MeterConfig(unit_seconds=unit, transition_beats=transition)
    units = meter_units(times, np.asarray(saliency), duration, fps, cfg)
    total = int(np.floor(duration * fps + 1e-6))
    covered = np.zeros(total, dtype=int)
    for u in units:
        assert 0 <= u.start < u.meter_start or u.meter_start == u.start == 0
        assert u.meter_start < u.meter_end <= u.start + u.length  # the meter fits in its unit
        assert u.length == max(2, int(round(unit * fps)))
        assert 1 <= u.transition_frames <= max(1, u.length // 2)
        covered[u.meter_start : u.meter_end] += 1
    assert (covered == 1).all()  # K units cover every frame exactly once
    assert [u.meter_start for u in units] == sorted(u.meter_start for u in units)


def test_transition_indices_and_eq12() -> None:
    units = meter_units(np.array([0.5, 1.0, 1.5, 2.0, 2.5]), np.array([1.0, 0.2, 1.0, 0.2, 1.0]), 4.0, 10.0)
    # labels 1 0 1 0 1, no weaker "medium": 2/4 meters at 0.5, 1.5 and 2.5 s (the first from 0); the
    # last runs to 4 s, longer than its 2-s unit allows after its 1-s transition, and is split at 3.5 s
    assert [u.meter_start for u in units] == [0, 15, 25, 35]  # the last meter split to fit its unit
    second = units[1]
    assert second.start == 5  # two transition beats before the meter at 1.5 s: 0.5 s
    e = transition_indices(second)
    assert e.shape == (second.length,) and e[:10].all() and not e[10:].any()
    motion = np.arange(second.length * 2, dtype=float).reshape(second.length, 1, 2)
    vf = initial_pose_input(motion, e)
    assert np.array_equal(vf[:10], motion[:10])
    assert np.allclose(vf[10:], motion[:10].mean(axis=0))  # Eq. 12: the mean of the transition poses
    with pytest.raises(ValueError, match="no transition frame"):
        initial_pose_input(motion, np.zeros(second.length))


def test_meters_on_synth_dance_start_on_music_beats() -> None:
    """On synth_dance the meter starts fall on the music's beats; which beat is strong follows the
    onset saliency, so downbeats are recovered only where the downbeat is the loudest onset
    (benchmarks/harmogan_meter_accuracy.py reports the accuracy per style)."""
    ds = DATASETS.build(
        "synth_dance",
        {
            "num_clips": 4,
            "skeleton": "dwm21",
            "fps": 15.0,
            "min_seconds": 8.0,
            "max_seconds": 8.0,
            "styles": ["ballet", "hiphop"],
        },
    )
    for clip in ds:
        times, saliency = audio_beats(clip.audio, clip.sample_rate)
        beats = np.asarray(clip.meta["beat_times"])
        meters = segment_meters(saliency)
        starts = times[[m.first_beat for m in meters]]
        on_beat = [np.min(np.abs(beats - t)) < 0.07 for t in starts[1:]]  # the first is the music's start
        assert np.mean(on_beat) >= 0.8, clip.id
        assert sum(m.num_beats for m in meters) == len(times)
