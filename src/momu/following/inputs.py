"""The inputs the benchmark gives a generator: each song (or dance) excerpt, its time-stretched copies,
and the control inputs.

A :class:`Request` names an input: a song index and a tempo factor (the excerpt played ``factor`` times
faster: ×0.8 … ×1.25, :data:`FACTORS`), or a control. Controls, per direction:

* music → dance: ``silence``; ``noise`` (white noise, RMS 0.1); ``click`` (a click on each beat of a
  song's excerpt: the purest beat there is);
* dance → music: ``static`` (one pose held: the first frame of the first dance); ``noise`` (that pose
  with independent Gaussian jitter of :data:`NOISE_M` on every joint and frame); ``metronome`` (that pose
  bobbing up and down by :data:`BOB_M` at a song's tempo).

``silence`` / ``noise`` / ``static`` are one input per seed (song index -1); ``click`` / ``metronome``
one per song and seed.
"""

from __future__ import annotations

from dataclasses import dataclass

import librosa
import numpy as np

from momu.following.pairs import Pair
from momu.following.signals import time_scale_motion, time_stretch_audio

__all__ = [
    "FACTORS",
    "CONTROLS",
    "Request",
    "make_input",
    "NOISE_M",
    "BOB_M",
    "requests",
    "bobbing_pose",
]

FACTORS = (0.8, 0.9, 1.1, 1.25)
"""Tempo factors of the time-stretched inputs."""
CONTROLS = {"dance": ("silence", "noise", "click"), "music": ("static", "noise", "metronome")}
"""Control inputs per direction (``dance``: music → dance; ``music``: dance → music)."""
PER_SONG_CONTROLS = ("click", "metronome")
NOISE_RMS = 0.1
NOISE_M = 0.02
"""Jitter of the ``noise`` motion control (m, per joint coordinate and frame)."""
BOB_M = 0.05
"""Amplitude of the ``metronome`` control's vertical bob (m)."""


@dataclass(frozen=True)
class Request:
    """One input: song ``song`` (−1: a control shared by every song) at tempo ``factor``, or ``control``."""

    song: int
    seed: int
    factor: float = 1.0
    control: str | None = None


def requests(
    direction: str, songs: int, seeds: list[int], factors: tuple[float, ...], controls: bool
) -> list[Request]:
    """Every request of a generator row, in generation order."""
    out = [Request(i, s, f) for i in range(songs) for s in seeds for f in (1.0, *factors)]
    if controls:
        for c in CONTROLS[direction]:
            if c in PER_SONG_CONTROLS:
                out += [Request(i, s, control=c) for i in range(songs) for s in seeds]
            else:
                out += [Request(-1, s, control=c) for s in seeds]
    return out


def bobbing_pose(pose: np.ndarray, frames: int, fps: float, bpm: float) -> np.ndarray:
    """``pose`` ``(1, J, D)`` held for ``frames`` frames at ``fps``, bobbing up and down (axis 1) by
    :data:`BOB_M` once per beat at ``bpm`` (the ``metronome`` control; the ``input_tempo`` calibration
    row of the dance direction)."""
    t = np.arange(frames) / fps
    bob = np.repeat(pose, frames, axis=0)
    bob[..., 1] += BOB_M * np.sin(2 * np.pi * bpm / 60.0 * t)[:, None]
    return bob


def _rng(request: Request) -> np.random.Generator:
    return np.random.default_rng([request.seed, request.song + 1, 7919])


def make_input(
    direction: str, pairs: list[Pair], request: Request, beats: list[np.ndarray]
) -> tuple[np.ndarray, float]:
    """The input array and its rate: ``(audio, sample_rate)`` for ``direction="dance"``, ``(motion,
    fps)`` for ``"music"``. ``beats`` are the songs' beat times (s) in their excerpts."""
    first = pairs[0]
    if direction == "dance":
        if request.control is None:
            p = pairs[request.song]
            return time_stretch_audio(p.excerpt_audio(), request.factor), p.sample_rate
        sr, n = first.sample_rate, int(round(first.seconds * first.sample_rate))
        if request.control == "silence":
            return np.zeros(n, dtype=np.float32), sr
        if request.control == "noise":
            return (NOISE_RMS * _rng(request).standard_normal(n)).astype(np.float32), sr
        if request.control == "click":
            p = pairs[request.song]
            n = int(round(p.seconds * p.sample_rate))
            return librosa.clicks(times=beats[request.song], sr=p.sample_rate, length=n).astype(
                np.float32
            ), p.sample_rate
    else:
        if request.control is None:
            p = pairs[request.song]
            return time_scale_motion(p.excerpt_motion(), p.fps, request.factor), p.fps
        pose = first.excerpt_motion()[:1]
        frames = int(round(first.seconds * first.fps))
        held = np.repeat(pose, frames, axis=0)
        if request.control == "static":
            return held, first.fps
        if request.control == "noise":
            return held + NOISE_M * _rng(request).standard_normal(held.shape), first.fps
        if request.control == "metronome":
            b = beats[request.song]
            bpm = 60.0 / float(np.median(np.diff(b))) if len(b) > 1 else 120.0
            return bobbing_pose(pose, frames, first.fps, bpm), first.fps
    raise ValueError(f"control {request.control!r} is not one of {CONTROLS[direction]}")
