"""Time-stretch augmentation of paired clips: the same dance and song played ``factor`` times faster.

A loader's ``tempo_factors`` option (:class:`momu.data.common.LoaderConfig`) adds, for every clip of
the train split, one copy per factor made by :func:`stretch_clip`. A model trained on real pairs at
their recorded tempi only can learn each song's tempo by heart instead of following the input; with
stretched copies the same figure comes at several tempi, each with its music at the matching tempo
(issue 32, "time-stretch augmentation of paired data"; the music-following benchmark's tempo test plays
its inputs ×0.8 … ×1.25 faster, docs/following.md).

The audio is stretched by librosa's phase vocoder (:func:`librosa.effects.time_stretch`: the pitch is
kept; :func:`time_stretch_audio`, also what the music-following benchmark stretches its songs with),
the motion, its trajectory and per-frame annotations are resampled in time
(:func:`momu.data.common.resample_motion`, linear), and beat times are divided by the factor.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence

import librosa
import numpy as np

from momu.data.common import PER_FRAME_META, resample_motion
from momu.data.types import Clip

__all__ = ["stretch_clip", "time_stretch_audio", "check_tempo_factors", "stretched_id"]


def check_tempo_factors(factors: Sequence[float], dataset: str) -> list[float]:
    """``factors`` as floats; a factor that is not a positive number other than 1, or a repeated one,
    is a ``ValueError`` naming ``dataset``'s ``tempo_factors``."""
    out = []
    for value in factors:
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not np.isfinite(value):
            raise ValueError(f"{dataset}: tempo_factors must be numbers, got {value!r}")
        if value <= 0 or value == 1:
            raise ValueError(f"{dataset}: tempo_factors must be > 0 and not 1 (the clip itself), got {value}")
        if float(value) in out:
            raise ValueError(f"{dataset}: tempo_factors repeats {value}")
        out.append(float(value))
    return out


def time_stretch_audio(audio: np.ndarray, factor: float) -> np.ndarray:
    """``audio`` played ``factor`` times faster at the same pitch (tempo × ``factor``, length ÷ ``factor``;
    ``librosa.effects.time_stretch``, phase vocoder)."""
    if factor == 1.0:
        return np.asarray(audio, dtype=np.float32)
    return np.asarray(librosa.effects.time_stretch(np.asarray(audio, dtype=np.float32), rate=factor))


def stretched_id(clip_id: str, factor: float) -> str:
    """The id of ``clip_id`` played ``factor`` times faster (``DANCE_W_3@x0.8``)."""
    return f"{clip_id}@x{factor:g}"


def stretch_clip(clip: Clip, factor: float) -> Clip:
    """``clip`` played ``factor`` times faster (``factor`` > 1: faster, shorter), at the same frame and
    sample rates; ``factor == 1`` returns it unchanged."""
    if factor <= 0:
        raise ValueError(f"tempo factor must be > 0, got {factor}")
    if factor == 1:
        return clip
    out = clip
    if clip.motion is not None:
        moved = resample_motion(clip, clip.fps / factor)
        out = dataclasses.replace(moved, fps=clip.fps)
    meta = {**clip.meta, **{key: out.meta[key] for key in PER_FRAME_META if key in out.meta}}
    if "beat_times" in clip.meta:
        meta["beat_times"] = np.asarray(clip.meta["beat_times"], dtype=np.float64) / factor
    meta["tempo_factor"] = float(factor)
    audio = clip.audio
    if audio is not None:
        audio = np.clip(time_stretch_audio(audio, factor), -1.0, 1.0).astype(np.float32)
    return dataclasses.replace(out, id=stretched_id(clip.id, factor), audio=audio, meta=meta)
