"""``momu eval``'s inputs: folders paired by stem, checked once, read lazily clip by clip.

:func:`load_pairs` walks the pairs once (with a progress bar), checking every file — a readable
numeric ``(T, J, D)`` motion, decodable audio — and every pair: the generated and reference motion
must share a skeleton (``(J, D)`` and, when given, its name) and a frame rate. It keeps only file
names and sizes: the clips it returns are :class:`LazyClip` records that read their arrays from
disk each time a metric asks, so evaluating 500 pairs holds one pair in memory, not 500.

A motion is a ``.npy`` of joint positions or a momu motion ``.npz`` (what ``momu generate`` writes,
:mod:`momu.export.npz`), which carries its own frame rate and skeleton. A ``.npy`` motion's frame
rate and skeleton come from a sidecar ``<stem>.json`` (``{"fps": .., "skeleton": ..}``) when there is
one, else from ``--fps`` and the joint layout.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import soundfile as sf

from momu.data.common import AUDIO_SUFFIXES, DataFileError, absent_reason, load_npy
from momu.data.motion_files import MAX_MOTION_BYTES
from momu.data.npz_arrays import npz_keys, read_npz_array
from momu.data.types import Clip
from momu.io import read_json

__all__ = ["EvalInputError", "LazyClip", "collect_folder", "load_pairs", "MOTION_SUFFIXES", "AUDIO_SUFFIXES"]

MOTION_SUFFIXES = (".npy", ".npz")
_SMALL_BYTES = 1 << 16  # an npz's fps / skeleton
# Joint layouts inferred from (J, D) when --skeleton is not given.
_SKELETONS = {
    (24, 3): "smpl24",
    (14, 2): "openpose14",
    (21, 3): "dwm21",
    (23, 3): "dwm23",
    (22, 3): "humanml22",
    (17, 3): "coco17",
}


class EvalInputError(ValueError):
    """Missing folders, unpaired, unreadable or mismatched files."""


def collect_folder(folder: Path) -> dict[str, dict[str, Path]]:
    """``stem -> {"motion": path, "audio": path}`` for the motion and audio files of ``folder``."""
    if not folder.is_dir():
        reason = absent_reason(folder, "folder") if not folder.exists() else "not a folder"
        raise EvalInputError(f"{folder}: {reason}")
    items: dict[str, dict[str, Path]] = {}
    for path in sorted(folder.iterdir()):
        suffix = path.suffix.lower()
        kind = "motion" if suffix in MOTION_SUFFIXES else "audio" if suffix in AUDIO_SUFFIXES else None
        if kind is None or not path.is_file():
            continue
        entry = items.setdefault(path.stem, {})
        if kind in entry:
            raise EvalInputError(
                f"{folder}: two {kind} files for '{path.stem}': {entry[kind].name}, {path.name}"
            )
        entry[kind] = path
    if not items:
        raise EvalInputError(
            f"{folder}: no motion ({', '.join(MOTION_SUFFIXES)}) or audio ({', '.join(AUDIO_SUFFIXES)}) files"
        )
    return items


def _npz_value(path: Path, key: str) -> Any:
    value = np.asarray(read_npz_array(path, key, _SMALL_BYTES))
    if value.size != 1:
        raise EvalInputError(f"{path}: {key!r} must hold one value, got shape {value.shape}")
    return value.reshape(()).item()


def _load_motion(path: Path) -> tuple[np.ndarray, dict[str, Any] | None]:
    """The joint array, and a .npz's own ``fps`` and ``skeleton`` (``None`` for a .npy).

    Only the arrays needed are read, each within :data:`~momu.data.motion_files.MAX_MOTION_BYTES`
    (:mod:`momu.data.npz_arrays`, :func:`~momu.data.files.load_npy`): a small file cannot inflate.
    """
    try:
        if path.suffix.lower() == ".npz":
            keys = npz_keys(path)
            missing = [k for k in ("joints", "fps", "skeleton") if k not in keys]
            if missing:
                raise EvalInputError(f"{path}: missing array {missing[0]!r} (has {sorted(keys)})")
            own = {"fps": float(_npz_value(path, "fps")), "skeleton": str(_npz_value(path, "skeleton"))}
            return read_npz_array(path, "joints", MAX_MOTION_BYTES), own
        return load_npy(path, MAX_MOTION_BYTES), None
    except (DataFileError, TypeError, ValueError) as exc:
        if isinstance(exc, EvalInputError):
            raise
        raise EvalInputError(str(exc)) from None


def _read_motion(path: Path) -> np.ndarray:
    return _checked_motion(path, _load_motion(path)[0])


def _checked_motion(path: Path, arr: np.ndarray) -> np.ndarray:
    if arr.ndim != 3 or arr.shape[2] not in (2, 3):
        raise EvalInputError(
            f"{path}: expected joint positions (T, J, D) with D = 2 or 3, got shape {arr.shape}"
        )
    if np.iscomplexobj(arr) or not np.issubdtype(arr.dtype, np.number):
        raise EvalInputError(f"{path}: motion must hold real numbers, got dtype {arr.dtype}")
    if not np.all(np.isfinite(arr)):
        raise EvalInputError(f"{path}: motion must hold finite numbers")
    return np.asarray(arr, dtype=np.float32)


def _read_audio(path: Path) -> tuple[np.ndarray, int]:
    from momu.metrics._audio import read_audio  # loads every metric: not for `momu eval`'s input checks

    try:
        return read_audio(path)
    except (FileNotFoundError, ValueError) as exc:
        raise EvalInputError(str(exc)) from None


@dataclass(frozen=True)
class _MotionInfo:
    path: Path
    frames: int
    joints: int
    dims: int
    fps: float
    skeleton: str


def _sidecar(path: Path) -> dict[str, Any]:
    side = path.with_suffix(".json")
    if not side.is_file():
        return {}
    try:
        record = read_json(side)
    except (OSError, ValueError) as exc:
        raise EvalInputError(str(exc)) from None
    return record if isinstance(record, dict) else {}


def _motion_info(path: Path, fps: float, skeleton: str | None) -> _MotionInfo:
    """Check ``path`` (reading it once, keeping nothing) and return its shape, fps and skeleton."""
    raw, own = _load_motion(path)
    motion = _checked_motion(path, raw)
    side = own if own is not None else _sidecar(path)  # a .npy's sidecar is read here only, once
    frames, joints, dims = (int(n) for n in motion.shape)
    rate = float(side.get("fps", fps))
    if not rate > 0:
        where = path if path.suffix.lower() == ".npz" else path.with_suffix(".json")
        raise EvalInputError(f"{where}: fps must be > 0, got {rate}")
    name = skeleton or str(side.get("skeleton") or _SKELETONS.get((joints, dims), ""))
    return _MotionInfo(path, frames, joints, dims, rate, name)


def _audio_seconds(path: Path) -> float:
    try:
        info = sf.info(os.fsencode(path))
    except Exception as exc:  # libsndfile raises its own error types
        raise EvalInputError(f"{path}: cannot decode audio: {exc}") from None
    if info.frames <= 0:
        raise EvalInputError(f"{path}: the audio file holds no samples")
    return float(info.frames) / float(info.samplerate)


class LazyClip(Clip):
    """A :class:`Clip` whose motion and audio are read from their files on every access."""

    def __init__(
        self,
        stem: str,
        motion: _MotionInfo | None,
        audio_path: Path | None,
        meta: dict[str, Any],
        fps: float,
    ) -> None:
        # Clip's own fields, except motion/audio/sample_rate (properties here)
        self.id = stem
        self.fps = motion.fps if motion is not None else fps
        self.skeleton = motion.skeleton if motion is not None else ""
        self.style = None
        self.text = []
        self.trajectory = None
        self.meta = meta
        self._motion = motion
        self._audio_path = audio_path

    @property
    def motion(self) -> np.ndarray | None:  # type: ignore[override]
        return None if self._motion is None else _read_motion(self._motion.path)

    @property
    def audio(self) -> np.ndarray | None:  # type: ignore[override]
        return None if self._audio_path is None else _read_audio(self._audio_path)[0]

    @property
    def sample_rate(self) -> int | None:  # type: ignore[override]
        return None if self._audio_path is None else int(sf.info(os.fsencode(self._audio_path)).samplerate)

    @property
    def num_frames(self) -> int:
        return 0 if self._motion is None else self._motion.frames

    @property
    def duration(self) -> float:
        if self._motion is not None:
            return self._motion.frames / self._motion.fps
        return _audio_seconds(self._audio_path) if self._audio_path is not None else 0.0

    @property
    def generated_modalities(self) -> tuple[str, ...]:
        """The modalities read from the generated folder itself (not filled in from the reference)."""
        return tuple(self.meta.get("generated", ()))

    def __repr__(self) -> str:
        return (
            f"LazyClip({self.id!r}, motion={self._motion is not None}, audio={self._audio_path is not None})"
        )


def _check_pair(stem: str, gen: _MotionInfo | None, ref: _MotionInfo | None) -> None:
    if gen is None or ref is None:
        return
    if (gen.joints, gen.dims) != (ref.joints, ref.dims) or (
        gen.skeleton and ref.skeleton and gen.skeleton != ref.skeleton
    ):
        raise EvalInputError(
            f"{gen.path}: skeleton {gen.skeleton or '?'} ({gen.joints} joints x {gen.dims}D) does not match "
            f"its reference {ref.path}: {ref.skeleton or '?'} ({ref.joints} joints x {ref.dims}D)"
        )
    if abs(gen.fps - ref.fps) > 1e-6:
        raise EvalInputError(
            f"{gen.path}: {gen.fps:g} fps but its reference {ref.path} is {ref.fps:g} fps "
            "(resample one of them, or fix the fps in its <stem>.json)"
        )


def load_pairs(
    gen_dir: Path,
    gt_dir: Path,
    fps: float,
    skeleton: str | None = None,
    *,
    progress: bool = False,
) -> tuple[list[Clip], list[Clip]]:
    """Generated and reference clips paired by stem (sorted); missing generated modalities from the reference.

    Every file is read and checked once here; the returned clips read their data lazily.

    Raises:
        EvalInputError: a folder is missing or empty, a stem is unpaired, a file is unreadable, or a
            pair's skeletons or frame rates differ.
    """
    from tqdm import tqdm

    if not fps > 0:
        raise EvalInputError(f"--fps: must be > 0, got {fps}")
    gen, gt = collect_folder(gen_dir), collect_folder(gt_dir)
    only_gen, only_gt = sorted(set(gen) - set(gt)), sorted(set(gt) - set(gen))
    if only_gen or only_gt:
        parts = []
        if only_gen:
            parts.append(
                f"{len(only_gen)} generated without a reference in {gt_dir}: {', '.join(only_gen[:10])}"
            )
        if only_gt:
            parts.append(
                f"{len(only_gt)} references without a generated item in {gen_dir}: {', '.join(only_gt[:10])}"
            )
        raise EvalInputError("unpaired files (pairs are matched by file stem): " + "; ".join(parts))
    generated: list[Clip] = []
    reference: list[Clip] = []
    for stem in tqdm(sorted(gen), desc="checking pairs", unit="pair", disable=None if progress else True):
        g, r = gen[stem], gt[stem]
        ref_motion = _motion_info(r["motion"], fps, skeleton) if "motion" in r else None
        gen_motion = _motion_info(g["motion"], fps, skeleton) if "motion" in g else ref_motion
        _check_pair(stem, gen_motion if "motion" in g else None, ref_motion)
        for path in (g.get("audio"), r.get("audio")):
            if path is not None:
                _audio_seconds(path)
        gen_audio = g.get("audio") or r.get("audio")
        meta = {
            "motion_file": str(gen_motion.path) if gen_motion else None,
            "audio_file": str(gen_audio) if gen_audio else None,
            "generated": tuple(m for m in ("motion", "audio") if m in g),
        }
        generated.append(LazyClip(stem, gen_motion, gen_audio, meta, fps))
        ref_meta = {
            "motion_file": str(ref_motion.path) if ref_motion else None,
            "audio_file": str(r["audio"]) if "audio" in r else None,
        }
        reference.append(LazyClip(stem, ref_motion, r.get("audio"), ref_meta, fps))
    return generated, reference


def generated_modalities(clips: Sequence[Clip]) -> set[str]:
    """Modalities every generated clip has from the generated folder itself."""
    sets = [set(getattr(c, "generated_modalities", ("motion", "audio"))) for c in clips]
    return set.intersection(*sets) if sets else set()
