"""Read a user's motion file: BVH, ``.npy``, ``.npz`` or a Dance with Melody dance.

:func:`read_motion_file` returns joint positions of a *registered* skeleton with their frame rate, ready
for :func:`momu.features.convert.convert_motion`:

* ``.bvh``: any file whose joint names include every joint of a registered 3D skeleton (files written by
  :func:`momu.export.write_bvh` do); world positions by forward kinematics. BVH has no unit field: a
  figure taller than 10 units is read as centimetres (× 0.01), else as metres.
* ``.npz``: a momu motion file (:mod:`momu.export.npz`: ``joints``, ``fps``, ``skeleton``), or any archive
  with one of the arrays ``joints`` / ``motion`` / ``positions`` / ``keypoints``.
* ``.npy``: a ``(T, J, D)`` array.
* a Dance with Melody dance: its ``DANCE_*`` folder or that folder's ``skeletons.json`` (read by the
  ``dance_with_melody`` loader: ``dwm21``, 25 fps, metres).

Where the file does not say, the skeleton is the registered one with that joint count and dimension
(``skeleton=`` chooses when several fit) and the frame rate is ``fps=`` (else the skeleton's usual rate,
with a warning). Every error is one ``ValueError`` / ``FileNotFoundError`` line naming the file.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from momu.features.skeletons import SKELETON_NAMES, get_skeleton

__all__ = ["MotionInput", "read_motion_file", "guess_skeleton", "MOTION_SUFFIXES"]

log = logging.getLogger(__name__)

MOTION_SUFFIXES = (".bvh", ".npy", ".npz", ".json")
"""File types :func:`read_motion_file` reads (``.json``: a Dance with Melody ``skeletons.json``)."""

_ARRAY_KEYS = ("joints", "motion", "positions", "keypoints")
_CM_HEIGHT = 10.0


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


def _check_array(x: np.ndarray, path: Path) -> np.ndarray:
    if x.ndim != 3 or x.shape[0] < 2 or x.shape[2] not in (2, 3):
        raise ValueError(f"{path}: motion must be a (T, J, 2|3) array with T >= 2, got shape {x.shape}")
    if not np.issubdtype(x.dtype, np.number):
        raise ValueError(f"{path}: motion must be numeric, got dtype {x.dtype}")
    if not np.all(np.isfinite(x)):
        raise ValueError(f"{path}: motion contains NaN or infinite values")
    return x.astype(np.float32)


def _frame_rate(fps: float | None, skeleton: str, path: Path) -> float:
    if fps is not None:
        if not np.isfinite(fps) or fps <= 0:
            raise ValueError(f"{path}: frame rate must be > 0, got {fps}")
        return float(fps)
    usual = get_skeleton(skeleton).fps
    log.warning(
        "%s: the file gives no frame rate; assuming %g fps (%s's usual rate; set --fps)",
        path,
        usual,
        skeleton,
    )
    return float(usual)


def _read_bvh(path: Path, skeleton: str | None, fps: float | None) -> MotionInput:
    from momu.export.bvh import read_bvh

    bvh = read_bvh(path)
    names = set(bvh.names)
    choices = [skeleton] if skeleton else [n for n in SKELETON_NAMES if get_skeleton(n).dims == 3]
    fits = [n for n in choices if set(get_skeleton(n).joint_names) <= names]
    if not fits:
        raise ValueError(
            f"{path}: its joints {sorted(names)[:8]}... do not include all joints of any registered 3D "
            f"skeleton ({', '.join(choices)}); rename them or export with momu"
        )
    name = max(fits, key=lambda n: get_skeleton(n).num_joints)  # dwm23 over dwm21 when both fit
    idx = [bvh.names.index(j) for j in get_skeleton(name).joint_names]
    pos = bvh.positions[:, idx]
    height = float(np.ptp(pos[0, :, 1]))
    if height > _CM_HEIGHT:
        pos = pos * 0.01
    return MotionInput(_check_array(pos, path), float(fps or bvh.fps), name, None, str(path))


def _read_npz(path: Path, skeleton: str | None, fps: float | None) -> MotionInput:
    try:
        with np.load(path, allow_pickle=False) as data:
            content = {k: data[k] for k in data.files}
    except (ValueError, OSError) as exc:
        raise ValueError(f"{path}: not a plain .npz archive ({exc})") from None
    key = next((k for k in _ARRAY_KEYS if k in content), None)
    if key is None:
        raise ValueError(f"{path}: no motion array (looked for {_ARRAY_KEYS}; has {sorted(content)})")
    x = _check_array(np.asarray(content[key]), path)
    name = skeleton or (str(content["skeleton"]) if "skeleton" in content else None)
    name = guess_skeleton(x.shape[1], x.shape[2], path, name)
    rate = fps if fps is not None else (float(content["fps"]) if "fps" in content else None)
    traj = None
    if "trajectory" in content:
        traj = np.asarray(content["trajectory"], dtype=np.float32)
        if traj.shape != (x.shape[0], 3):
            raise ValueError(f"{path}: trajectory must be ({x.shape[0]}, 3), got {traj.shape}")
    return MotionInput(x, _frame_rate(rate, name, path), name, traj, str(path))


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
    path: str | Path, *, skeleton: str | None = None, fps: float | None = None
) -> MotionInput:
    """Read a motion file (see the module docstring); errors name the file and what is wrong."""
    path = Path(path)
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
        return _read_bvh(path, skeleton, fps)
    if suffix == ".npz":
        return _read_npz(path, skeleton, fps)
    if suffix == ".npy":
        try:
            x = np.load(path, allow_pickle=False)
        except (ValueError, OSError) as exc:
            raise ValueError(f"{path}: not a plain .npy array ({exc})") from None
        x = _check_array(np.asarray(x), path)
        name = guess_skeleton(x.shape[1], x.shape[2], path, skeleton)
        return MotionInput(x, _frame_rate(fps, name, path), name, None, str(path))
    raise ValueError(
        f"{path}: unknown motion file type {path.suffix!r} (use .bvh, .npy, .npz or a DANCE_* folder)"
    )
