"""The registered harmony metrics cut the audio to the motion and evaluate in windows when asked."""

from __future__ import annotations

import numpy as np
import pytest

from momu.data.types import Clip
from momu.metrics.harmony import HarmonyConfig, clip_harmony, clip_windows, harmony
from momu.registry import METRICS

SR = 16000
FPS = 15.0


def clicks(times: list[float], seconds: float) -> np.ndarray:
    audio = np.zeros(int(seconds * SR), dtype=np.float32)
    for t in times:
        i = int(t * SR)
        audio[i : i + 160] = np.hanning(160).astype(np.float32)
    return audio


def swing(seconds: float, period: float = 1.0) -> np.ndarray:
    """(T, 3, 3) motion whose speed is ``1 + cos(2πt/period)``: velocity-sum extrema every period/2."""
    t = np.arange(int(round(seconds * FPS))) / FPS
    x = np.cumsum(1 + np.cos(2 * np.pi * t / period)) / FPS
    m = np.zeros((t.size, 3, 3))
    m[:, :, 0] = x[:, None]
    m[:, :, 1] = np.arange(3)[None, :]
    return m


def test_windows_cut_both_modalities_at_the_same_seconds() -> None:
    audio, motion = (
        np.arange(SR * 13, dtype=np.float32),
        np.zeros((190, 2, 3)),
    )  # 13 s of audio, 12.67 s motion
    whole = clip_windows(audio, SR, motion, FPS)
    assert len(whole) == 1 and len(whole[0][0]) == int(round(190 * SR / FPS))  # audio cut to the motion
    pieces = clip_windows(audio, SR, motion, FPS, 6.0)
    assert [len(m) for _, m in pieces] == [90, 90]  # the 10-frame tail is dropped
    assert pieces[1][0][0] == 6 * SR and len(pieces[1][0]) == 6 * SR
    short = clip_windows(audio[: 3 * SR], SR, motion[:45], FPS, 6.0)
    assert len(short) == 1 and len(short[0][1]) == 45  # shorter than a window: one piece


def test_audio_after_the_motion_does_not_count() -> None:
    beats = [0.5, 1.0, 1.5, 2.0, 2.5, 3.0, 3.5]
    motion = swing(4.0)
    cut = Clip("c", motion, FPS, clicks(beats, 4.0), SR)
    longer = Clip("l", motion, FPS, clicks([*beats, 4.5, 5.25, 6.1, 7.3], 8.0), SR)  # extra beats after 4 s
    metric = METRICS.build("harmony")
    assert metric([cut])["harmony"] == pytest.approx(metric([longer])["harmony"])
    assert metric([longer])["harmony"] == pytest.approx(harmony(clicks(beats, 4.0), SR, motion, FPS).h)


def test_window_seconds_averages_the_windows_of_each_clip() -> None:
    beats = list(np.arange(0.5, 12.0, 0.5))
    clip = Clip("c", swing(12.0), FPS, clicks(beats, 12.0), SR)
    results = clip_harmony(clip, HarmonyConfig(window_seconds=6.0))
    assert len(results) == 2
    per_clip = METRICS.build("hit_rate", {"window_seconds": 6.0}).per_clip([clip, clip])
    assert per_clip.tolist() == pytest.approx([np.mean([r.hit_rate for r in results])] * 2)
    first = harmony(clip.audio[: 6 * SR], SR, clip.motion[:90], FPS)  # type: ignore[index]
    assert results[0].h == pytest.approx(first.h)
    with pytest.raises(ValueError, match="window_seconds"):
        HarmonyConfig(window_seconds=0.0)
    silent = Clip("s", swing(12.0), FPS, np.zeros(12 * SR, np.float32), SR)
    with pytest.raises(ValueError, match="clip 's' window 0"):
        clip_harmony(silent, HarmonyConfig(window_seconds=6.0))
