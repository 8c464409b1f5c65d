"""Read a user's motion file: BVH, ``.npy``, ``.npz`` or a Dance with Melody dance.

:func:`read_motion_file` returns joint positions of a *registered* skeleton with their frame rate, ready
for :func:`momu.features.convert.convert_motion`:

* ``.bvh``: any file whose joint names include every joint of a registered 3D skeleton (files written by
  :func:`momu.export.write_bvh` do), or a rig exported by an animation tool whose joints name a body
  (Mixamo, CMU, SMPL, Unreal: :mod:`momu.features.rig_names`), posed on :data:`RIG_SKELETON`;
  world positions by forward kinematics. BVH has no unit field: a
  figure taller than 10 units is read as centimetres (× 0.01), else as metres.
* ``.npz``: a momu motion file (:mod:`momu.export.npz`: ``joints``, ``fps``, ``skeleton``), or any archive
  with one of the arrays ``joints`` / ``motion`` / ``positions`` / ``keypoints``.
* ``.npy``: a ``(T, J, D)`` array.
* a Dance with Melody dance: its ``DANCE_*`` folder or that folder's ``skeletons.json`` (read by the
  ``dance_with_melody`` loader: ``dwm21``, 25 fps, metres).

Where the file does not say, the skeleton is the registered one with that joint count and dimension
(``skeleton=`` chooses when several fit) and the frame rate is ``fps=`` (else the skeleton's usual rate,
with a warning). Every error is one ``ValueError`` / ``FileNotFoundError`` line naming the file.

A small file cannot make momu allocate much: a BVH's ``Frames:`` must equal the rows it holds (checked
by a scan before it is parsed), a ``.npy`` header must match the file's size, a ``.npz`` member is read
alone and within :data:`MAX_MOTION_BYTES` (:mod:`momu.data.npz_arrays`), and ``max_seconds`` refuses
a longer motion before it is converted. Complex arrays are refused (their imaginary part would be
dropped), and the frame rate must lie in :data:`FPS_RANGE`.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from momu.data.files import DataFileError, load_npy, npy_header
from momu.data.npz_arrays import npz_keys, read_npz_array
from momu.features.skeletons import SKELETON_NAMES, get_skeleton

__all__ = [
    "MotionInput",
    "read_motion_file",
    "guess_skeleton",
    "MOTION_SUFFIXES",
    "MAX_MOTION_BYTES",
    "FPS_RANGE",
]

log = logging.getLogger(__name__)

MOTION_SUFFIXES = (".bvh", ".npy", ".npz", ".json")
"""File types :func:`read_motion_file` reads (``.json``: a Dance with Melody ``skeletons.json``)."""

_ARRAY_KEYS = ("joints", "motion", "positions", "keypoints")
_CM_HEIGHT = 10.0
RIG_SKELETON = "smpl24"
"""The skeleton a BVH rig that names no registered skeleton's joints is posed on (its landmarks)."""
MAX_MOTION_BYTES = 256 << 20
"""Largest motion array read (256 MiB: 10 minutes at 240 fps of 60 joints in float64 is 207 MB)."""
_SMALL_BYTES = 1 << 16
"""Largest ``fps`` / ``skeleton`` member of an ``.npz``."""
FPS_RANGE = (1.0, 1000.0)
"""Frame rates accepted (frames per second)."""
_MAX_BVH_LINE = 1 << 20


@dataclass(frozen=True)
class MotionInput:
    """A motion read from a file.

    Attributes:
        motion: ``(T, J, D)`` float32 joint positions of ``skeleton``.
        fps: frames per second.
        skeleton: registered skeleton name.
        trajectory: ``(T, 3)`` root path when ``motion`` is root-centred, else ``None``.
        source: the file it came from.
    """

    motion: np.ndarray
    fps: float
    skeleton: str
    trajectory: np.ndarray | None
    source: str


def guess_skeleton(num_joints: int, dims: int, path: Path, skeleton: str | None = None) -> str:
    """The registered skeleton for ``(J, D)`` data (``skeleton`` when given and consistent)."""
    if skeleton is not None:
        try:
            skel = get_skeleton(skeleton)
        except KeyError as exc:
            raise ValueError(f"{path}: {exc.args[0]}") from None
        if skel.num_joints != num_joints:
            raise ValueError(
                f"{path}: has {num_joints} joints but skeleton {skeleton!r} has {skel.num_joints}"
            )
        return skel.name
    fits = [
        n for n in SKELETON_NAMES if get_skeleton(n).num_joints == num_joints and get_skeleton(n).dims == dims
    ]
    if not fits:
        known = ", ".join(
            f"{n} ({get_skeleton(n).num_joints}x{get_skeleton(n).dims})" for n in SKELETON_NAMES
        )
        raise ValueError(
            f"{path}: no registered skeleton has {num_joints} joints in {dims}D (known: {known})"
        )
    if len(fits) > 1:
        raise ValueError(
            f"{path}: {num_joints} joints in {dims}D fit skeletons {fits}; choose one with --skeleton"
        )
    return fits[0]


def _check_shape(shape: tuple[int, ...], path: Path) -> None:
    if len(shape) != 3 or shape[0] < 2 or shape[2] not in (2, 3):
        raise ValueError(f"{path}: motion must be a (T, J, 2|3) array with T >= 2, got shape {tuple(shape)}")


def _check_array(x: np.ndarray, path: Path) -> np.ndarray:
    _check_shape(x.shape, path)
    if np.iscomplexobj(x):
        raise ValueError(f"{path}: motion holds complex numbers (dtype {x.dtype}); give real joint positions")
    if not np.issubdtype(x.dtype, np.number):
        raise ValueError(f"{path}: motion must be numeric, got dtype {x.dtype}")
    if not np.all(np.isfinite(x)):
        raise ValueError(f"{path}: motion contains NaN or infinite values")
    return x.astype(np.float32)


def _frame_rate(fps: float | None, skeleton: str, path: Path) -> float:
    if fps is not None:
        _check_fps(fps, path)
        return float(fps)
    usual = get_skeleton(skeleton).fps
    log.warning(
        "%s: the file gives no frame rate; assuming %g fps (%s's usual rate; set --fps)",
        path,
        usual,
        skeleton,
    )
    return float(usual)


def _check_fps(fps: float, path: Path) -> None:
    if not np.isfinite(fps) or not FPS_RANGE[0] <= fps <= FPS_RANGE[1]:
        raise ValueError(
            f"{path}: frame rate {fps:g} fps is outside {FPS_RANGE[0]:g}-{FPS_RANGE[1]:g} fps"
            if np.isfinite(fps) and fps > 0
            else f"{path}: frame rate must be > 0, got {fps}"
        )


def _check_seconds(frames: int, fps: float, path: Path, max_seconds: float | None) -> None:
    if max_seconds is not None and frames / fps > max_seconds:
        raise ValueError(
            f"{path}: {frames / fps:.0f} s of motion ({frames} frames at {fps:g} fps) is longer than the "
            f"{max_seconds:g} s limit; pass --seconds to use its beginning"
        )


def _number(line: bytes, path: Path, what: str) -> float:
    try:
        return float(line.split(b":", 1)[1].strip())
    except (IndexError, ValueError):
        text = line.strip()[:60].decode(errors="replace")
        raise ValueError(f"{path}: not a readable BVH file (bad {what} line {text!r})") from None


def scan_bvh(path: Path) -> tuple[int, float, int]:
    """``(Frames:, Frame Time:, rows of motion data)`` of a BVH file, read line by line (nothing else is
    kept): a declared frame count that the file does not hold is caught before any array is made."""
    frames: float | None = None
    frame_time: float | None = None
    rows = 0
    with open(path, "rb") as fh:
        while line := fh.readline(_MAX_BVH_LINE):
            if len(line) >= _MAX_BVH_LINE:
                raise ValueError(
                    f"{path}: not a readable BVH file (a line longer than {_MAX_BVH_LINE} bytes)"
                )
            if frame_time is not None:
                rows += bool(line.strip())
                continue
            text = line.strip()
            if text.startswith(b"Frames:") and frames is None:
                frames = _number(text, path, "Frames:")
            elif text.startswith(b"Frame Time:"):
                frame_time = _number(text, path, "Frame Time:")
    if frames is None or frame_time is None:
        raise ValueError(f"{path}: not a readable BVH file (no 'Frames:' and 'Frame Time:' lines)")
    if not np.isfinite(frames) or frames != int(frames) or frames < 1:
        raise ValueError(f"{path}: BVH 'Frames:' must be a whole number >= 1, got {frames:g}")
    if not np.isfinite(frame_time) or frame_time <= 0:
        raise ValueError(f"{path}: Frame Time must be > 0, got {frame_time:g}")
    return int(frames), float(frame_time), rows


def _read_bvh(path: Path, skeleton: str | None, fps: float | None, max_seconds: float | None) -> MotionInput:
    from momu.export.bvh import read_bvh

    frames, frame_time, rows = scan_bvh(path)
    if rows != frames:
        raise ValueError(
            f"{path}: declares {frames} frames ('Frames:') but holds {rows} rows of motion data; the file is "
            "truncated or corrupt"
        )
    rate = float(fps or 1.0 / frame_time)
    _check_fps(rate, path)
    _check_seconds(frames, rate, path, max_seconds)
    bvh = read_bvh(path)
    names = set(bvh.names)
    choices = [skeleton] if skeleton else [n for n in SKELETON_NAMES if get_skeleton(n).dims == 3]
    fits = [n for n in choices if set(get_skeleton(n).joint_names) <= names]
    if fits:
        name = max(fits, key=lambda n: get_skeleton(n).num_joints)  # dwm23 over dwm21 when both fit
        pos = bvh.positions[:, [bvh.names.index(j) for j in get_skeleton(name).joint_names]]
    else:
        name, pos = _rig_positions(bvh.names, bvh.positions, skeleton, path, choices)
    height = float(np.ptp(pos[0, :, 1]))
    if height > _CM_HEIGHT:
        pos = pos * 0.01
    return MotionInput(_check_array(pos, path), rate, name, None, str(path))


def _rig_positions(
    names: tuple[str, ...], positions: np.ndarray, skeleton: str | None, path: Path, choices: list[str]
) -> tuple[str, np.ndarray]:
    """A third-party rig's joints (:mod:`momu.features.rig_names`: Mixamo, CMU, SMPL, Unreal
    names) posed on ``skeleton`` (default :data:`RIG_SKELETON`) by its landmarks; a figure standing
    along Z (head above the ankles on Z, as Blender and Unreal export) is turned to momu's Y up."""
    from momu.features.convert import landmark_matrix
    from momu.features.rig_names import rig_landmarks

    target = skeleton or RIG_SKELETON
    have = rig_landmarks(names)
    try:
        weights = landmark_matrix(have, len(names), target)
    except (KeyError, ValueError) as exc:
        found = f"read {sorted(have)}" if have else "none read"
        raise ValueError(
            f"{path}: its joints {sorted(names)[:8]}... do not include all joints of any registered 3D "
            f"skeleton ({', '.join(choices)}), nor a {target} body by Mixamo / CMU / SMPL / Unreal "
            f"joint names ({exc}; {found}); rename them or export with momu"
        ) from None
    log.info(
        "%s: joints read by their rig names as %s (%d of %d joints used)", path, target, len(have), len(names)
    )
    pos = np.einsum("ij,tjd->tid", weights, positions)
    if not {"head", "l_ankle", "r_ankle"} <= have.keys():  # every 3D target needs them; be safe
        return target, pos
    up = positions[:, have["head"]] - positions[:, [have["l_ankle"], have["r_ankle"]]].mean(axis=1)
    up = up.mean(axis=0)
    if np.argmax(np.abs(up)) == 2:  # Z up (Blender's, Unreal's axes): turn it to Y up
        sign = np.sign(up[2])
        log.info("%s: the figure stands along Z; turned to Y up", path)
        pos = np.stack([pos[..., 0], sign * pos[..., 2], -sign * pos[..., 1]], axis=-1)
    return target, pos


def _scalar(path: Path, key: str) -> np.ndarray:
    value = np.asarray(read_npz_array(path, key, _SMALL_BYTES))
    if value.size != 1:
        raise ValueError(f"{path}: {key!r} must hold one value, got shape {value.shape}")
    return value.reshape(())


def _read_npz(path: Path, skeleton: str | None, fps: float | None, max_seconds: float | None) -> MotionInput:
    keys = npz_keys(path)
    key = next((k for k in _ARRAY_KEYS if k in keys), None)
    if key is None:
        raise ValueError(f"{path}: no motion array (looked for {_ARRAY_KEYS}; has {sorted(keys)})")
    rate = fps
    if rate is None and "fps" in keys:
        value = _scalar(path, "fps")
        if not np.issubdtype(value.dtype, np.number) or np.iscomplexobj(value):
            raise ValueError(f"{path}: 'fps' must be a number, got dtype {value.dtype}")
        rate = float(value)
    if rate is not None:
        _check_fps(rate, path)
    x = _check_array(read_npz_array(path, key, MAX_MOTION_BYTES), path)
    name = skeleton or (str(_scalar(path, "skeleton")) if "skeleton" in keys else None)
    name = guess_skeleton(x.shape[1], x.shape[2], path, name)
    rate = _frame_rate(rate, name, path)
    _check_seconds(x.shape[0], rate, path, max_seconds)
    traj = None
    if "trajectory" in keys:
        traj = np.asarray(read_npz_array(path, "trajectory", MAX_MOTION_BYTES))
        if traj.shape != (x.shape[0], 3) or np.iscomplexobj(traj) or not np.issubdtype(traj.dtype, np.number):
            raise ValueError(
                f"{path}: trajectory must be real ({x.shape[0]}, 3), got {traj.dtype} {traj.shape}"
            )
        traj = traj.astype(np.float32)
        if not np.all(np.isfinite(traj)):
            raise ValueError(f"{path}: trajectory contains NaN or infinite values")
    return MotionInput(x, rate, name, traj, str(path))


def _read_npy(path: Path, skeleton: str | None, fps: float | None, max_seconds: float | None) -> MotionInput:
    shape, dtype, _ = npy_header(path)  # checked against the file's size before anything is allocated
    _check_shape(shape, path)
    if np.issubdtype(dtype, np.complexfloating):
        raise ValueError(f"{path}: motion holds complex numbers (dtype {dtype}); give real joint positions")
    name = guess_skeleton(shape[1], shape[2], path, skeleton)
    rate = _frame_rate(fps, name, path)
    _check_seconds(shape[0], rate, path, max_seconds)
    x = _check_array(load_npy(path, MAX_MOTION_BYTES), path)
    return MotionInput(x, rate, name, None, str(path))


def _read_dance_with_melody(folder: Path) -> MotionInput:
    from momu.data.dance_with_melody import DanceWithMelodyConfig, DanceWithMelodyDataset

    ds = DanceWithMelodyDataset(DanceWithMelodyConfig(root=str(folder.parent), load_audio=False))
    index = next((i for i, ref in enumerate(ds.items) if ref.id == folder.name), None)
    if index is None:  # pragma: no cover - the folder was checked to be a DANCE_* folder
        raise ValueError(f"{folder}: not a Dance with Melody DANCE_* folder")
    clip = ds[index]
    assert clip.motion is not None
    return MotionInput(clip.motion, clip.fps, clip.skeleton, clip.trajectory, str(folder))


def read_motion_file(
    path: str | Path,
    *,
    skeleton: str | None = None,
    fps: float | None = None,
    max_seconds: float | None = None,
) -> MotionInput:
    """Read a motion file (see the module docstring); errors name the file and what is wrong.

    ``max_seconds``: refuse a longer motion (checked from the BVH header or the array's shape, before
    the motion is converted).
    """
    path = Path(path)
    try:
        given = _read(path, skeleton, fps, max_seconds)
    except DataFileError as exc:
        raise ValueError(str(exc)) from None
    _check_seconds(given.motion.shape[0], given.fps, path, max_seconds)
    return given


def _read(path: Path, skeleton: str | None, fps: float | None, max_seconds: float | None) -> MotionInput:
    if not path.exists():
        raise FileNotFoundError(f"{path}: motion file not found")
    if path.is_dir() or path.name == "skeletons.json":
        folder = path if path.is_dir() else path.parent
        if not (folder / "skeletons.json").is_file() or not folder.name.startswith("DANCE_"):
            raise ValueError(
                f"{path}: a folder must be a Dance with Melody DANCE_* folder with skeletons.json"
            )
        return _read_dance_with_melody(folder)
    suffix = path.suffix.lower()
    if suffix == ".bvh":
        return _read_bvh(path, skeleton, fps, max_seconds)
    if suffix == ".npz":
        return _read_npz(path, skeleton, fps, max_seconds)
    if suffix == ".npy":
        return _read_npy(path, skeleton, fps, max_seconds)
    raise ValueError(
        f"{path}: unknown motion file type {path.suffix!r} (use .bvh, .npy, .npz or a DANCE_* folder)"
    )
