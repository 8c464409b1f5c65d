"""What the clip-level metrics share: reading a clip's modalities, the generated-clip check, provenance."""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from typing import Any

import numpy as np

from momu.data.types import Clip

__all__ = ["ClipMetric", "clip_motion", "clip_audio", "check_pairs", "clip_beat_times", "require_clips"]


def clip_motion(clip: Clip, metric: str) -> np.ndarray:
    """The clip's motion ``(T, J, D)``; a clear error when it has none."""
    if clip.motion is None:
        raise ValueError(f"{metric}: clip {clip.id!r} has no motion")
    if not clip.fps or clip.fps <= 0:
        raise ValueError(f"{metric}: clip {clip.id!r} has an invalid frame rate {clip.fps!r}")
    return np.asarray(clip.motion)


def require_clips(generated: Sequence[Clip], metric: str) -> list[Clip]:
    """The generated clips as a list; a clear error when there are none."""
    clips = list(generated)
    if not clips:
        raise ValueError(f"{metric}: no generated clips to evaluate")
    return clips


def clip_audio(clip: Clip, metric: str) -> tuple[np.ndarray, int]:
    """The clip's waveform and sample rate; a clear error when it has none."""
    if clip.audio is None or not clip.sample_rate:
        raise ValueError(f"{metric}: clip {clip.id!r} has no audio (or no sample rate)")
    return np.asarray(clip.audio), int(clip.sample_rate)


def clip_beat_times(clip: Clip, metric: str) -> np.ndarray:
    """``clip.meta["beat_times"]`` (music beat times in seconds, as synthetic data carries them)."""
    times = clip.meta.get("beat_times")
    if times is None:
        raise ValueError(f"{metric}: clip {clip.id!r} has no meta['beat_times'] (use music_beats='audio')")
    return np.asarray(times, dtype=np.float64)


def check_pairs(generated: Sequence[Clip], reference: Sequence[Clip] | None, metric: str) -> list[Clip]:
    """The reference clips, checked to pair one-to-one (by position) with the generated clips."""
    if reference is None:
        raise ValueError(f"{metric}: needs reference clips (ground truth) paired with the generated clips")
    ref = list(reference)
    if len(ref) != len(generated):
        raise ValueError(f"{metric}: {len(generated)} generated clips but {len(ref)} reference clips")
    return ref


def _plain_config(cfg: Any) -> Any:
    if dataclasses.is_dataclass(cfg) and not isinstance(cfg, type):
        return dataclasses.asdict(cfg)
    return cfg


@dataclasses.dataclass
class ClipMetric:
    """Base of the beat/harmony metrics: a name, a config dataclass instance and provenance."""

    cfg: Any
    name: str = ""
    needs_reference: bool = False
    spec: str = ""

    def provenance(self) -> dict[str, Any]:
        """The metric's config and the specification it implements."""
        return {
            "name": self.name,
            "config": _plain_config(self.cfg),
            "spec": self.spec,
        }

    def _require(self, generated: Sequence[Clip]) -> list[Clip]:
        return require_clips(generated, self.name)
