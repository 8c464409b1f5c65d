"""The one record every dataset yields, and the protocol datasets follow.

Every dataset in ``momu.registry.DATASETS`` (built-in ``synth_dance`` and the real-data
loaders alike) is a sequence of :class:`Clip`. Metrics, features, methods and the engine
consume clips, so a new dataset needs nothing but to yield them.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field
from typing import Any, Protocol, runtime_checkable

import numpy as np

__all__ = ["Clip", "ClipDataset", "iter_clips", "split_indices"]


@dataclass
class Clip:
    """One paired (or single-modality) example.

    Attributes:
        id: unique, stable identifier within its dataset (file stem, sequence name ...).
        motion: ``(T, J, D)`` float32 joint positions, ``D`` = 2 (image-plane keypoints) or 3
            (metres, Y up); ``None`` for music-only datasets.
        fps: motion frame rate in frames per second.
        audio: ``(S,)`` float32 mono waveform in [-1, 1]; ``None`` for motion-only datasets.
        sample_rate: audio sample rate in Hz (``None`` without audio).
        skeleton: name of the joint layout in :mod:`momu.features.skeletons`.
        style: style / genre label, or ``None``.
        text: text descriptions (HumanML3D), empty when none.
        trajectory: ``(T, 3)`` global root trajectory when ``motion`` is root-centred, else ``None``.
        meta: anything else the dataset knows (split, source file, beat times ...).
    """

    id: str
    motion: np.ndarray | None
    fps: float
    audio: np.ndarray | None = None
    sample_rate: int | None = None
    skeleton: str = ""
    style: str | None = None
    text: list[str] = field(default_factory=list)
    trajectory: np.ndarray | None = None
    meta: dict[str, Any] = field(default_factory=dict)

    @property
    def num_frames(self) -> int:
        return 0 if self.motion is None else int(self.motion.shape[0])

    @property
    def duration(self) -> float:
        """Length in seconds: the motion's if any, else the audio's."""
        if self.motion is not None:
            return self.num_frames / self.fps
        if self.audio is not None and self.sample_rate:
            return len(self.audio) / self.sample_rate
        return 0.0


@runtime_checkable
class ClipDataset(Protocol):
    """What a registered dataset's factory returns: an indexable, sized collection of clips.

    A dataset may also offer ``split_at(index) -> str``, a clip's split without generating or
    loading it; offering it promises that every clip carries motion, audio and text (``synth_dance``
    does), so :func:`split_indices` answers from the index alone.
    """

    def __len__(self) -> int: ...

    def __getitem__(self, index: int) -> Clip: ...


def iter_clips(dataset: ClipDataset | Sequence[Clip]) -> Iterator[Clip]:
    """Iterate a dataset by index."""
    for i in range(len(dataset)):
        yield dataset[i]


def split_indices(
    dataset: ClipDataset | Sequence[Clip] | Any, split: str, keep: Callable[[Clip], bool]
) -> list[int]:
    """Indices of the clips of ``split`` (``Clip.meta["split"]``, ``train`` when absent) for which
    ``keep(clip)`` holds (the modalities a method needs).

    A dataset with ``split_at`` (:class:`ClipDataset`) is not generated or loaded for it: generating
    all 640 clips of the cpu preset's ``synth_dance`` took about 8 s per call, several calls per
    Table 7 unit.
    """
    split_at = getattr(dataset, "split_at", None)
    if callable(split_at):
        return [i for i in range(len(dataset)) if split_at(i) == split]
    return [i for i in range(len(dataset)) if _split(clip := dataset[i]) == split and keep(clip)]


def _split(clip: Clip) -> str:
    return str(clip.meta.get("split", "train"))
