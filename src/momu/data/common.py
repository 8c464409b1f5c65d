"""Helpers shared by the real-dataset loaders: keypoint cleaning, splits, cropping, and the lazy
dataset base class; the file readers with clear errors live in :mod:`momu.data.files` and are
re-exported here.

Every per-file problem is raised as :class:`DataFileError` (a ``ValueError``) whose message starts
with the offending file, so ``momu data check`` can list each bad file with its reason. A file
that does not exist raises :class:`MissingDataFileError`, which is also a ``FileNotFoundError``.

Loaders are lazy: building a dataset reads only index files (split lists, folder listings);
each clip is read, validated and cleaned when it is indexed.
"""

from __future__ import annotations

import dataclasses
import hashlib
import logging
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from momu.data.files import (
    DataFileError,
    MissingDataFileError,
    absent_reason,
    audio_info,
    load_audio,
    load_npy,
    npy_header,
    printable,
    read_json_file,
    read_lines,
    read_pickle,
    read_pickle_dict,
)
from momu.data.types import Clip

__all__ = [
    "DataFileError",
    "MissingDataFileError",
    "LoaderConfig",
    "ItemRef",
    "LazyClipDataset",
    "require_root",
    "read_lines",
    "read_json_file",
    "read_pickle",
    "read_pickle_dict",
    "load_npy",
    "npy_header",
    "absent_reason",
    "load_audio",
    "audio_info",
    "clean_keypoints",
    "check_length_match",
    "crop_clip",
    "resample_motion",
    "hash_split",
    "skeleton_shape",
    "SPLITS",
    "PER_FRAME_META",
    "check_split",
    "sorted_items",
    "AUDIO_SUFFIXES",
    "printable",
]

logger = logging.getLogger(__name__)

SPLITS = ("train", "val", "test", "all")

AUDIO_SUFFIXES = (".wav", ".flac", ".ogg", ".opus", ".mp3")
"""Audio files momu reads everywhere (``generate``, ``eval``, the loaders): what libsndfile decodes."""

PER_FRAME_META = ("confidence", "smpl_poses", "smpl_trans")
"""``Clip.meta`` keys holding per-motion-frame arrays (cropped with the motion by :func:`crop_clip`)."""


@dataclass
class LoaderConfig:
    """Options every real-dataset loader shares (the loaders' configs extend this).

    Attributes:
        root: the dataset folder in its published layout (required).
        split: ``train``, ``val``, ``test`` or ``all``.
        load_audio: read the audio (``False``: motion only, much faster).
        sample_rate: resample audio to this rate in Hz (``None``: keep the file's rate).
        window_seconds: crop every clip to this many seconds (``None``: whole clips). A clip
            shorter than ``window_offset_seconds + window_seconds`` is an error naming its file.
        window_offset_seconds: where the window starts, in seconds from the clip's start.
        target_fps: resample the motion to this frame rate (``None``: keep the dataset's);
            see :func:`resample_motion`. Applied before the window.
        tempo_factors: time-stretch augmentation: after the clips themselves, every clip of the
            train split again played each factor times faster (:func:`momu.data.stretch.stretch_clip`;
            id ``<id>@x<factor>``). Validation and test clips stay as recorded. Empty: none.
    """

    root: str = ""
    split: str = "all"
    load_audio: bool = True
    sample_rate: int | None = 16000
    window_seconds: float | None = None
    window_offset_seconds: float = 0.0
    target_fps: float | None = None
    tempo_factors: list[float] = field(default_factory=list)


@dataclass(frozen=True)
class ItemRef:
    """One item of a lazy dataset: its id, its main file and whatever the loader needs to read it."""

    id: str
    path: Path
    extra: dict[str, Any] = field(default_factory=dict)


def require_root(root: str | Path, dataset: str, expected: str) -> Path:
    """The dataset root as a Path; a clear error when it is unset or missing.

    Args:
        root: the user's ``root`` option.
        dataset: the registry name (for the message).
        expected: a one-line description of the layout expected under the root.
    """
    if not str(root):
        raise ValueError(f"{dataset}: 'root' is required: the folder holding {expected}")
    path = Path(root).expanduser()
    if not path.is_dir():
        raise FileNotFoundError(f"{dataset}: root folder {path} does not exist (expected {expected})")
    return path


def check_split(split: str, dataset: str, allowed: Sequence[str] = SPLITS) -> str:
    if split not in allowed:
        raise ValueError(f"{dataset}: split must be one of {', '.join(allowed)}; got {split!r}")
    return split


# ------------------------------------------------------------------------------------ readers
def skeleton_shape(name: str) -> tuple[int, int]:
    """``(joints, dims)`` of a skeleton in :mod:`momu.features.skeletons`."""
    from momu.features.skeletons import get_skeleton

    skel = get_skeleton(name)
    return len(skel.joint_names), int(skel.dims)


def clean_keypoints(
    keypoints: np.ndarray,
    path: str | Path,
    *,
    joints: int,
    dims: int,
    max_gap: int | None,
    missing: np.ndarray | None = None,
) -> tuple[np.ndarray, int]:
    """Validate ``(T, J, D)`` keypoints and fill missing ones from neighbouring frames (MoMu App. B.2).

    Missing keypoints are the non-finite ones, plus those flagged in ``missing``. They are filled
    by :func:`momu.features.preprocess.interpolate_missing` over gaps of at most ``max_gap``
    frames; anything left unfilled is an error naming the file, the joint and the frame.

    Args:
        keypoints: the raw array.
        path: the file it came from (for messages).
        joints: expected ``J``.
        dims: expected ``D`` (2 or 3).
        max_gap: longest run of missing frames that may be interpolated (``None``: any).
        missing: optional ``(T, J)`` bool, True where a keypoint is missing (e.g. zero confidence).

    Returns:
        ``(float32 keypoints (T, J, D), number of keypoints filled)``.
    """
    x = np.asarray(keypoints)
    if x.ndim != 3 or x.shape[1] != joints or x.shape[2] != dims:
        raise DataFileError(path, f"expected keypoints of shape (T, {joints}, {dims}), got {tuple(x.shape)}")
    if x.shape[0] == 0:
        raise DataFileError(path, "no frames")
    x = x.astype(np.float32, copy=True)
    gone = ~np.all(np.isfinite(x), axis=-1)
    if missing is not None:
        gone |= np.asarray(missing, dtype=bool)
    n_missing = int(gone.sum())
    if n_missing == 0:
        return x, 0
    never = np.flatnonzero(gone.all(axis=0))
    if never.size:
        raise DataFileError(
            path,
            f"NaN keypoints beyond what interpolation may fill: joint(s) {never.tolist()} "
            "missing in every frame",
        )
    from momu.features.preprocess import interpolate_missing

    x[gone] = np.nan
    filled = np.asarray(interpolate_missing(x, max_gap=max_gap, on_long_gap="leave"), dtype=np.float32)
    left = ~np.all(np.isfinite(filled), axis=-1)
    if left.any():
        frame, joint = (int(v) for v in np.argwhere(left)[0])
        raise DataFileError(
            path,
            f"NaN keypoints beyond what interpolation may fill: {int(left.sum())} keypoint(s) in runs "
            f"of more than max_gap={max_gap} missing frames (first: joint {joint}, frame {frame})",
        )
    return filled, n_missing


def check_length_match(
    path: str | Path, motion_seconds: float, audio_seconds: float, tolerance_seconds: float
) -> None:
    """Raise :class:`DataFileError` when motion and audio durations differ by more than the tolerance."""
    gap = abs(motion_seconds - audio_seconds)
    if gap > tolerance_seconds:
        raise DataFileError(
            path,
            f"motion lasts {motion_seconds:.2f} s but its audio {audio_seconds:.2f} s: "
            f"mismatch of {gap:.2f} s exceeds the tolerance of {tolerance_seconds:.2f} s",
        )


def crop_clip(clip: Clip, start: float, seconds: float) -> Clip:
    """The part of ``clip`` in ``[start, start + seconds)`` seconds (motion, trajectory, audio, beats).

    The per-frame arrays of ``meta`` named in :data:`PER_FRAME_META` are cropped with the motion;
    ``meta["beat_times"]`` is shifted and filtered.

    Raises:
        ValueError: the clip is shorter than ``start + seconds`` (names the clip id).
    """
    if seconds <= 0 or start < 0:
        raise ValueError(f"window must have start >= 0 and seconds > 0, got start={start}, seconds={seconds}")
    if clip.duration + 1e-6 < start + seconds:
        raise ValueError(
            f"clip {clip.id!r} is {clip.duration:.2f} s long, shorter than the requested window "
            f"[{start:.2f}, {start + seconds:.2f}) s"
        )
    meta = dict(clip.meta)
    motion = clip.motion
    trajectory = clip.trajectory
    if motion is not None:
        t0 = int(round(start * clip.fps))
        n = int(round(seconds * clip.fps))
        full = motion.shape[0]
        motion = motion[t0 : t0 + n]
        if trajectory is not None:
            trajectory = trajectory[t0 : t0 + n]
        for key in PER_FRAME_META:
            value = clip.meta.get(key)
            if isinstance(value, np.ndarray) and value.ndim >= 1 and value.shape[0] == full:
                meta[key] = value[t0 : t0 + n]
    audio = clip.audio
    if audio is not None and clip.sample_rate:
        s0 = int(round(start * clip.sample_rate))
        audio = audio[s0 : s0 + int(round(seconds * clip.sample_rate))]
    if "beat_times" in meta:
        beats = np.asarray(meta["beat_times"], dtype=np.float64)
        meta["beat_times"] = beats[(beats >= start) & (beats < start + seconds)] - start
    meta["window"] = (float(start), float(start + seconds))
    return dataclasses.replace(clip, motion=motion, trajectory=trajectory, audio=audio, meta=meta)


def resample_motion(clip: Clip, target_fps: float) -> Clip:
    """``clip`` with its motion (and trajectory, per-frame ``meta``) at ``target_fps``.

    Frame ``k`` of the result is the pose at ``k / target_fps`` seconds; the result covers no more
    than the original duration (``floor(T * target_fps / fps)`` frames, at least 1). When ``fps`` is an
    integer multiple of ``target_fps`` (60 -> 30, 60 -> 20) frames are subsampled exactly; otherwise
    positions, trajectory and confidences are linearly interpolated in time and SMPL parameters
    (``smpl_poses``, ``smpl_trans``: axis-angles do not interpolate linearly) take the nearest frame.
    Audio is untouched (it has its own rate).
    """
    if clip.motion is None:
        raise ValueError(f"clip {clip.id!r} has no motion to resample")
    if target_fps <= 0 or clip.fps <= 0:
        raise ValueError(f"frame rates must be positive, got fps={clip.fps}, target_fps={target_fps}")
    if target_fps == clip.fps:
        return clip
    frames = clip.motion.shape[0]
    count = max(1, int(np.floor(frames * target_fps / clip.fps + 1e-9)))
    times = np.arange(count) * (clip.fps / target_fps)  # positions in original frames
    ratio = clip.fps / target_fps
    exact = abs(ratio - round(ratio)) < 1e-9
    nearest = np.minimum(np.round(times).astype(np.int64), frames - 1)

    def interp(array: np.ndarray, linear: bool) -> np.ndarray:
        if exact or not linear:
            return array[nearest]
        lo = np.minimum(np.floor(times).astype(np.int64), frames - 1)
        hi = np.minimum(lo + 1, frames - 1)
        w = (times - lo).reshape((-1,) + (1,) * (array.ndim - 1))
        return ((1.0 - w) * array[lo] + w * array[hi]).astype(array.dtype)

    meta = dict(clip.meta)
    for key in PER_FRAME_META:
        value = clip.meta.get(key)
        if isinstance(value, np.ndarray) and value.ndim >= 1 and value.shape[0] == frames:
            meta[key] = interp(value, linear=not key.startswith("smpl_"))
    meta["source_fps"] = clip.meta.get("source_fps", clip.fps)
    trajectory = None if clip.trajectory is None else interp(clip.trajectory, linear=True)
    return dataclasses.replace(
        clip, motion=interp(clip.motion, linear=True), fps=float(target_fps), trajectory=trajectory, meta=meta
    )


def hash_split(item_id: str, ratios: Sequence[float] = (0.9, 0.05, 0.05), seed: int = 0) -> str:
    """Deterministic train/val/test assignment of one id (MoMu §5: random 90%/5%/5% splits).

    The id is hashed with the seed to a number in [0, 1), so the split of an item depends only on
    its id and the seed, not on which other items exist or their order. An id from a file name that
    is not valid UTF-8 hashes as the name's bytes.
    """
    if len(ratios) != 3 or any(r < 0 for r in ratios) or not np.isclose(sum(ratios), 1.0):
        raise ValueError(f"split ratios must be three non-negative numbers summing to 1, got {list(ratios)}")
    # surrogateescape: a file name that is not UTF-8 (os.listdir hands it back with lone surrogates)
    # hashes as its raw bytes instead of failing the whole dataset
    digest = hashlib.sha256(f"{seed}:{item_id}".encode("utf-8", "surrogateescape")).digest()
    u = int.from_bytes(digest[:8], "big") / 2.0**64
    if u < ratios[0]:
        return "train"
    if u < ratios[0] + ratios[1]:
        return "val"
    return "test"


# ------------------------------------------------------------------------------- the base class
class LazyClipDataset:
    """A :class:`~momu.data.types.ClipDataset` that reads one item per index.

    Subclasses fill ``self.items`` with :class:`ItemRef` (``extra["split"]``: its split) and implement
    :meth:`load`; indexing applies the configured window. With ``tempo_factors`` the items come first,
    then the train items played at the first factor, then at the second, ...; a stretched clip is
    computed once per dataset object (the phase vocoder takes seconds per minute of audio). Errors from
    :meth:`load` name the item's file.

    Attributes:
        name: the registry name.
        root: the dataset folder.
        items: one :class:`ItemRef` per clip, in a stable (sorted) order.
    """

    name = "dataset"

    def __init__(self, cfg: LoaderConfig, root: Path, items: Iterable[ItemRef]) -> None:
        if cfg.sample_rate is not None and cfg.sample_rate <= 0:
            raise ValueError(f"{self.name}: sample_rate must be positive or null, got {cfg.sample_rate}")
        if cfg.window_seconds is not None and cfg.window_seconds <= 0:
            raise ValueError(
                f"{self.name}: window_seconds must be positive or null, got {cfg.window_seconds}"
            )
        if cfg.target_fps is not None and cfg.target_fps <= 0:
            raise ValueError(f"{self.name}: target_fps must be positive or null, got {cfg.target_fps}")
        if cfg.window_offset_seconds < 0:
            raise ValueError(
                f"{self.name}: window_offset_seconds must be >= 0, got {cfg.window_offset_seconds}"
            )
        from momu.data.stretch import check_tempo_factors

        self.cfg = cfg
        self.root = root
        self.items: list[ItemRef] = list(items)
        train = [i for i, ref in enumerate(self.items) if ref.extra.get("split") == "train"]
        factors = check_tempo_factors(cfg.tempo_factors, self.name)
        self.plays: list[tuple[int, float]] = [(i, 1.0) for i in range(len(self.items))]
        self.plays += [(i, f) for f in factors for i in train]
        self._stretched: dict[int, Clip] = {}

    def __len__(self) -> int:
        return len(self.plays)

    def __getitem__(self, index: int) -> Clip:
        if not isinstance(index, (int, np.integer)):
            raise TypeError(f"{self.name}: index must be an int, got {type(index).__name__}")
        n = len(self)
        if not -n <= index < n:
            raise IndexError(f"{self.name}: index {index} out of range for {n} items")
        index = int(index) % n
        clip = self._play(index)
        if self.cfg.target_fps is not None and clip.motion is not None:
            clip = resample_motion(clip, self.cfg.target_fps)
        window = self.cfg.window_seconds
        if window is not None:
            try:
                clip = crop_clip(clip, self.cfg.window_offset_seconds, window)
            except ValueError as exc:
                raise DataFileError(self.items[self.plays[index][0]].path, str(exc)) from None
        return clip

    def _play(self, index: int) -> Clip:
        """Play ``index`` of :attr:`plays`: its item, stretched by its factor."""
        item, factor = self.plays[index]
        if factor == 1.0:
            return self.load(self.items[item])
        if index not in self._stretched:
            from momu.data.stretch import stretch_clip

            self._stretched[index] = stretch_clip(self.load(self.items[item]), factor)
        return self._stretched[index]

    @property
    def ids(self) -> list[str]:
        from momu.data.stretch import stretched_id

        return [self.items[i].id if f == 1.0 else stretched_id(self.items[i].id, f) for i, f in self.plays]

    def load(self, ref: ItemRef) -> Clip:  # pragma: no cover - abstract
        raise NotImplementedError

    def __repr__(self) -> str:
        return f"{type(self).__name__}(root={str(self.root)!r}, split={self.cfg.split!r}, items={len(self)})"


def sorted_items(refs: Iterable[ItemRef], keep: Callable[[ItemRef], bool]) -> list[ItemRef]:
    """The refs ``keep`` accepts, sorted by id (a stable order across file systems)."""
    return sorted((r for r in refs if keep(r)), key=lambda r: r.id)
