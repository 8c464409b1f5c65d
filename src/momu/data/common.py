"""Helpers shared by the real-dataset loaders: file readers with clear errors, keypoint cleaning,
splits, cropping, and the lazy dataset base class.

Every per-file problem is raised as :class:`DataFileError` (a ``ValueError``) whose message starts
with the offending file, so ``momu data check`` can list each bad file with its reason. A file
that does not exist raises :class:`MissingDataFileError`, which is also a ``FileNotFoundError``.

Loaders are lazy: building a dataset reads only index files (split lists, folder listings);
each clip is read, validated and cleaned when it is indexed.
"""

from __future__ import annotations

import dataclasses
import errno
import hashlib
import logging
import os
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from momu.data.types import Clip
from momu.io import read_json

__all__ = [
    "DataFileError",
    "MissingDataFileError",
    "LoaderConfig",
    "ItemRef",
    "LazyClipDataset",
    "require_root",
    "read_lines",
    "read_json_file",
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


def printable(text: object) -> str:
    """``text`` with any undecodable file-name bytes shown as ``\\xNN`` (safe to print or write as JSON)."""
    return str(text).encode("utf-8", "surrogateescape").decode("utf-8", "backslashreplace")


class DataFileError(ValueError):
    """A dataset file that cannot be used; ``str(err)`` is ``"<path>: <reason>"``.

    Attributes:
        path: the offending file (or folder).
        reason: what is wrong with it.
    """

    def __init__(self, path: str | Path, reason: str) -> None:
        self.path = Path(path)
        self.reason = reason
        super().__init__(f"{path}: {reason}")

    def __reduce__(self) -> tuple[Any, ...]:  # keep (path, reason) through multiprocessing
        return (type(self), (self.path, self.reason))


class MissingDataFileError(DataFileError, FileNotFoundError):
    """A file the layout requires does not exist."""


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
    """

    root: str = ""
    split: str = "all"
    load_audio: bool = True
    sample_rate: int | None = 16000
    window_seconds: float | None = None
    window_offset_seconds: float = 0.0
    target_fps: float | None = None


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
def read_lines(path: str | Path) -> list[str]:
    """The non-empty lines of a text file (split files, ignore lists, descriptions), stripped."""
    path = Path(path)
    if not path.is_file():
        raise _missing(path)
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise DataFileError(path, f"cannot read as UTF-8 text ({exc})") from None
    lines = (line.strip() for line in text.splitlines())
    return [line for line in lines if line]


def read_json_file(path: str | Path) -> Any:
    """Parse a JSON file; a missing or unreadable file raises :class:`DataFileError`."""
    path = Path(path)
    if not path.is_file():
        raise _missing(path)
    try:
        return read_json(path)
    except (OSError, ValueError) as exc:
        reason = str(exc)
        prefix = f"{path}: "
        raise DataFileError(path, reason[len(prefix) :] if reason.startswith(prefix) else reason) from None


def absent_reason(path: str | Path, what: str = "file") -> str:
    """Why ``path`` cannot be opened as a ``what``: not found, a folder, a broken link, a link loop."""
    path = Path(path)
    try:
        os.stat(path)
    except OSError as exc:
        if exc.errno == errno.ELOOP:
            return "symbolic link loop"
        if path.is_symlink():
            return f"broken symbolic link (points to {os.readlink(path)})"
        if exc.errno == errno.EACCES:
            return "permission denied"
        return f"{what} not found"
    if path.is_dir():
        return f"is a folder, expected a {what}"
    return f"{what} not found"


def _missing(path: Path, what: str = "file") -> MissingDataFileError:
    return MissingDataFileError(path, absent_reason(path, what))


def npy_header(path: str | Path) -> tuple[tuple[int, ...], np.dtype[Any], int]:
    """``(shape, dtype, data offset)`` from a ``.npy`` header, checked against the file's size.

    Nothing is allocated: a header declaring more data than the file holds (truncated or crafted)
    is refused before ``np.load`` would allocate it.

    Raises:
        DataFileError: not a ``.npy`` file, a corrupt header, an object dtype, or a size mismatch.
    """
    path = Path(path)
    size = path.stat().st_size
    with open(path, "rb") as fh:
        magic = fh.read(6)
        if magic != b"\x93NUMPY":
            raise DataFileError(
                path, "not a .npy file (no NUMPY header)" if magic else "empty file (0 bytes)"
            )
        fh.seek(0)
        try:
            version = np.lib.format.read_magic(fh)
            if version == (1, 0):
                shape, _, dtype = np.lib.format.read_array_header_1_0(fh)
            elif version in ((2, 0), (3, 0)):
                shape, _, dtype = np.lib.format.read_array_header_2_0(fh)
            else:
                raise ValueError(f"version {version}")
        except (ValueError, EOFError, OSError, SyntaxError) as exc:
            raise DataFileError(path, f"not a valid .npy file (corrupt header: {exc})") from None
        offset = fh.tell()
    if dtype.hasobject:
        raise DataFileError(path, "holds pickled Python objects; refusing to load (expected a numeric array)")
    expected = int(np.prod(shape, dtype=np.int64)) * dtype.itemsize if shape else dtype.itemsize
    if expected != size - offset:
        raise DataFileError(
            path,
            f"not a valid .npy file (truncated or corrupt: the header declares {expected} bytes of data, "
            f"the file holds {size - offset})",
        )
    return tuple(int(n) for n in shape), dtype, offset


def load_npy(path: str | Path) -> np.ndarray:
    """Load a numeric ``.npy`` array without admitting pickled objects; errors name the file.

    The header is checked first (:func:`npy_header`), so a corrupt or truncated file is "not a
    valid .npy file" and nothing larger than the file is ever allocated.
    """
    path = Path(path)
    if not path.is_file():
        raise _missing(path)
    _, dtype, _ = npy_header(path)
    if not np.issubdtype(dtype, np.number):
        raise DataFileError(path, f"expected a numeric array, got dtype {dtype}")
    try:
        array = np.load(path, allow_pickle=False)
    except (ValueError, OSError, EOFError) as exc:
        raise DataFileError(path, f"not a valid .npy file ({exc})") from None
    return array


def audio_info(path: str | Path) -> tuple[int, int]:
    """``(sample_rate, num_frames)`` of an audio file without decoding it."""
    import soundfile as sf

    path = Path(path)
    if not path.is_file():
        raise _missing(path, "audio file")
    if path.stat().st_size == 0:
        raise DataFileError(path, "empty audio file (0 bytes)")
    try:
        info = sf.info(os.fsencode(path))  # bytes: names that are not UTF-8 open too
    except Exception as exc:  # libsndfile raises its own error types (LibsndfileError, RuntimeError)
        raise DataFileError(path, f"cannot decode audio ({_sf_reason(exc)})") from None
    return int(info.samplerate), int(info.frames)


def _sf_reason(exc: BaseException) -> str:
    text = str(exc).strip().splitlines()[-1] if str(exc).strip() else type(exc).__name__
    return text.replace("Error opening", "error opening")


def load_audio(
    path: str | Path,
    *,
    sample_rate: int | None = None,
    offset: float = 0.0,
    duration: float | None = None,
) -> tuple[np.ndarray, int]:
    """Decode a mono float32 waveform in [-1, 1] (channels averaged), optionally resampled.

    Only ``[offset, offset + duration)`` seconds are decoded (soundfile seeks, also in MP3s).
    When the file ends before ``offset + duration`` the available part is returned; callers
    compare lengths with :func:`check_length_match`.

    Args:
        path: wav / flac / ogg / mp3 file (anything libsndfile decodes).
        sample_rate: target rate in Hz (soxr HQ resampling); ``None`` keeps the file's rate.
        offset: start, seconds from the beginning of the file (>= 0).
        duration: seconds to read (``None``: to the end).

    Returns:
        ``(audio (S,), sample_rate)``.

    Raises:
        MissingDataFileError: no such file.
        DataFileError: undecodable or empty file, ``offset`` past the end, non-finite samples.
    """
    import soundfile as sf

    path = Path(path)
    if not path.is_file():
        raise _missing(path, "audio file")
    if offset < 0:
        raise DataFileError(path, f"negative audio offset {offset} s")
    if path.stat().st_size == 0:
        raise DataFileError(path, "empty audio file (0 bytes)")
    try:
        with sf.SoundFile(os.fsencode(path)) as f:
            sr = int(f.samplerate)
            total = int(f.frames)
            if total <= 0:
                raise DataFileError(path, "empty audio (0 samples)")
            start = int(round(offset * sr))
            if start >= total:
                raise DataFileError(
                    path, f"audio is {total / sr:.2f} s long; cannot start reading at {offset:.2f} s"
                )
            count = total - start if duration is None else min(total - start, int(round(duration * sr)))
            if start:
                f.seek(start)
            data = f.read(count, dtype="float32", always_2d=True)
    except DataFileError:
        raise
    except Exception as exc:  # LibsndfileError / RuntimeError / ValueError from the decoder
        raise DataFileError(path, f"cannot decode audio ({_sf_reason(exc)})") from None
    if data.shape[0] == 0:
        raise DataFileError(path, "empty audio (no samples could be decoded)")
    audio = data.mean(axis=1, dtype=np.float32)
    if not np.all(np.isfinite(audio)):
        raise DataFileError(path, f"{int(np.count_nonzero(~np.isfinite(audio)))} non-finite audio samples")
    if sample_rate is not None and int(sample_rate) != sr:
        if sample_rate <= 0:
            raise ValueError(f"sample_rate must be positive, got {sample_rate}")
        from momu.features.audio import resample

        audio = resample(audio, sr, int(sample_rate))
        sr = int(sample_rate)
    return np.ascontiguousarray(audio, dtype=np.float32), sr


# --------------------------------------------------------------------------------- keypoints
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

    Subclasses fill ``self.items`` with :class:`ItemRef` and implement :meth:`load`; indexing
    applies the configured window. Errors from :meth:`load` name the item's file.

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
        self.cfg = cfg
        self.root = root
        self.items: list[ItemRef] = list(items)

    def __len__(self) -> int:
        return len(self.items)

    def __getitem__(self, index: int) -> Clip:
        if not isinstance(index, (int, np.integer)):
            raise TypeError(f"{self.name}: index must be an int, got {type(index).__name__}")
        n = len(self.items)
        if not -n <= index < n:
            raise IndexError(f"{self.name}: index {index} out of range for {n} items")
        ref = self.items[int(index)]
        clip = self.load(ref)
        if self.cfg.target_fps is not None and clip.motion is not None:
            clip = resample_motion(clip, self.cfg.target_fps)
        window = self.cfg.window_seconds
        if window is not None:
            try:
                clip = crop_clip(clip, self.cfg.window_offset_seconds, window)
            except ValueError as exc:
                raise DataFileError(ref.path, str(exc)) from None
        return clip

    @property
    def ids(self) -> list[str]:
        return [ref.id for ref in self.items]

    def load(self, ref: ItemRef) -> Clip:  # pragma: no cover - abstract
        raise NotImplementedError

    def __repr__(self) -> str:
        return f"{type(self).__name__}(root={str(self.root)!r}, split={self.cfg.split!r}, items={len(self)})"


def sorted_items(refs: Iterable[ItemRef], keep: Callable[[ItemRef], bool]) -> list[ItemRef]:
    """The refs ``keep`` accepts, sorted by id (a stable order across file systems)."""
    return sorted((r for r in refs if keep(r)), key=lambda r: r.id)
