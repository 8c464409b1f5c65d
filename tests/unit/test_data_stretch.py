"""Time-stretch augmentation of paired clips (``tempo_factors``, :mod:`momu.data.stretch`)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from tests.fixtures.layouts import write_dance_with_melody

from momu.config import build_component
from momu.data.stretch import stretch_clip
from momu.data.types import Clip
from momu.following.signals import onset_envelope
from momu.following.tempo import periodogram_tempo

SR, FPS = 16000, 25.0


def _clip(seconds: float = 8.0, bpm: float = 120.0) -> Clip:
    """A dancer swinging a joint at ``bpm`` to a click track at ``bpm``."""
    t = np.arange(int(seconds * FPS)) / FPS
    motion = np.zeros((t.size, 2, 3), np.float32)
    motion[:, 1, 0] = np.sin(2 * np.pi * bpm / 60 * t)
    audio = np.zeros(int(seconds * SR), np.float32)
    for beat in np.arange(0, seconds, 60 / bpm):
        i = int(beat * SR)
        audio[i : i + 400] = np.sin(2 * np.pi * 1000 * np.arange(400) / SR)[: audio[i : i + 400].size]
    beats = np.arange(0, seconds, 60 / bpm)
    return Clip(
        "song",
        motion,
        FPS,
        audio,
        SR,
        trajectory=np.zeros((t.size, 3), np.float32),
        meta={"beat_times": beats},
    )


def _motion_bpm(clip: Clip) -> float:
    return periodogram_tempo(np.abs(np.diff(clip.motion[:, 1, 0])), clip.fps, (40.0, 400.0)) / 2


@pytest.mark.parametrize("factor", [0.8, 1.25])
def test_a_stretched_clip_is_the_same_dance_and_song_played_faster(factor: float) -> None:
    clip = _clip()
    fast = stretch_clip(clip, factor)
    assert fast.id == f"song@x{factor:g}" and fast.fps == FPS and fast.sample_rate == SR
    assert fast.meta["tempo_factor"] == factor
    assert abs(fast.num_frames - clip.num_frames / factor) <= 1
    assert fast.trajectory is not None and fast.trajectory.shape[0] == fast.num_frames
    assert fast.audio is not None and abs(fast.audio.size - clip.audio.size / factor) <= SR * 0.01
    assert fast.audio.dtype == np.float32 and np.abs(fast.audio).max() <= 1.0
    # motion frame k is the original pose at k * factor frames; both tempi move by the factor
    k = np.arange(fast.num_frames)
    expected = np.interp(k * factor, np.arange(clip.num_frames), clip.motion[:, 1, 0])
    np.testing.assert_allclose(fast.motion[:, 1, 0], expected, atol=1e-5)
    assert _motion_bpm(fast) == pytest.approx(120 * factor, rel=0.03)
    song = periodogram_tempo(onset_envelope(fast.audio, SR), 100.0, (60.0, 200.0))
    assert song == pytest.approx(120 * factor, rel=0.03)
    np.testing.assert_allclose(fast.meta["beat_times"], clip.meta["beat_times"] / factor)


def test_factor_one_is_the_clip_itself() -> None:
    clip = _clip()
    assert stretch_clip(clip, 1.0) is clip


def test_a_loader_adds_one_stretched_copy_per_factor_of_each_training_clip(tmp_path: Path) -> None:
    write_dance_with_melody(tmp_path, seconds=6.0)
    node = {
        "name": "dance_with_melody",
        "root": str(tmp_path),
        "sample_rate": 8000,
        "split_ratios": [0.5, 0.5, 0],
    }
    plain = build_component(node, "datasets")
    ds = build_component({**node, "tempo_factors": [0.8, 1.25]}, "datasets")
    train = [i for i in range(len(plain)) if plain[i].meta["split"] == "train"]
    assert train and len(train) < len(plain)  # validation clips are never stretched
    assert ds.ids == [
        *plain.ids,
        *(f"{plain.ids[i]}@x0.8" for i in train),
        *(f"{plain.ids[i]}@x1.25" for i in train),
    ]
    assert len(ds) == len(plain) + 2 * len(train)
    for k, i in enumerate(train):
        base, slow = plain[i], ds[len(plain) + k]
        assert slow.id == f"{base.id}@x0.8" and slow.meta["split"] == "train"
        assert abs(slow.num_frames - base.num_frames / 0.8) <= 1
        np.testing.assert_array_equal(ds[i].motion, base.motion)
        assert ds[len(plain) + k] is slow  # computed once
    assert ds[-1].id == f"{plain.ids[train[-1]]}@x1.25"


@pytest.mark.parametrize("bad", [[1.0], [0.0], [-0.5], [0.8, 0.8], ["fast"]])
def test_bad_tempo_factors_name_the_option(tmp_path: Path, bad: list[object]) -> None:
    write_dance_with_melody(tmp_path)
    with pytest.raises(ValueError, match=r"dance_with_melody[:.] ?tempo_factors"):
        build_component(
            {"name": "dance_with_melody", "root": str(tmp_path), "tempo_factors": bad}, "datasets"
        )
