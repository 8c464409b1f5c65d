"""Generated motion as a plain ``.npz`` (no pickles): joints, frame rate, skeleton and provenance.

Arrays of a momu motion file (``np.load(path)`` reads it with the default ``allow_pickle=False``):

* ``joints``: ``(T, J, D)`` float32 joint positions (metres, Y up for 3D; pixels for 2D keypoints);
* ``fps``: scalar float, frames per second;
* ``skeleton``: scalar string, the registered skeleton name (:mod:`momu.features.skeletons`);
* ``joint_names``: ``(J,)`` strings; ``parents``: ``(J,)`` int, ``-1`` for the root;
* ``trajectory`` (optional): ``(T, 3)`` root path when ``joints`` is root-centred;
* ``provenance``: scalar string, JSON (model, command, seed, momu version ...).
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from momu.features.skeletons import get_skeleton
from momu.io import atomic_path

__all__ = ["MotionFile", "write_motion_npz", "read_motion_npz"]


@dataclass(frozen=True)
class MotionFile:
    """What a momu ``.npz`` motion file holds (see the module docstring)."""

    joints: np.ndarray
    fps: float
    skeleton: str
    trajectory: np.ndarray | None = None
    provenance: dict[str, Any] = field(default_factory=dict)


def write_motion_npz(
    path: str | Path,
    joints: np.ndarray,
    fps: float,
    skeleton: str,
    *,
    trajectory: np.ndarray | None = None,
    provenance: dict[str, Any] | None = None,
) -> Path:
    """Write a motion file atomically; errors name what is wrong before anything is written."""
    skel = get_skeleton(skeleton)
    x = np.asarray(joints, dtype=np.float32)
    if x.ndim != 3 or x.shape[1] != skel.num_joints or x.shape[0] < 1:
        raise ValueError(f"joints must be (T, {skel.num_joints}, D) for skeleton {skeleton!r}, got {x.shape}")
    if not np.all(np.isfinite(x)):
        raise ValueError("joints contain NaN or infinite values")
    if not np.isfinite(fps) or fps <= 0:
        raise ValueError(f"fps must be > 0, got {fps!r}")
    arrays: dict[str, np.ndarray] = {
        "joints": x,
        "fps": np.asarray(float(fps)),
        "skeleton": np.asarray(skel.name),
        "joint_names": np.asarray(skel.joint_names),
        "parents": np.asarray(skel.parents, dtype=np.int64),
        "provenance": np.asarray(json.dumps(provenance or {}, sort_keys=True, default=str)),
    }
    if trajectory is not None:
        traj = np.asarray(trajectory, dtype=np.float32)
        if traj.shape != (x.shape[0], 3):
            raise ValueError(f"trajectory must be ({x.shape[0]}, 3), got {traj.shape}")
        arrays["trajectory"] = traj
    path = Path(path)
    with atomic_path(path) as tmp:
        with open(tmp, "wb") as fh:
            np.savez(fh, **arrays)  # type: ignore[arg-type]
    return path


def read_motion_npz(path: str | Path) -> MotionFile:
    """Read a file written by :func:`write_motion_npz` (no pickles; errors name the file and key)."""
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"{path}: motion file not found")
    try:
        with np.load(path, allow_pickle=False) as data:
            content = {k: data[k] for k in data.files}
    except (ValueError, OSError) as exc:
        raise ValueError(f"{path}: not a plain .npz archive: {exc}") from None
    for key in ("joints", "fps", "skeleton"):
        if key not in content:
            raise ValueError(f"{path}: missing array {key!r} (has {sorted(content)})")
    provenance: dict[str, Any] = {}
    if "provenance" in content:
        try:
            provenance = dict(json.loads(str(content["provenance"])))
        except (ValueError, TypeError):
            raise ValueError(f"{path}: 'provenance' is not a JSON object") from None
    return MotionFile(
        joints=np.asarray(content["joints"], dtype=np.float32),
        fps=float(content["fps"]),
        skeleton=str(content["skeleton"]),
        trajectory=np.asarray(content["trajectory"], dtype=np.float32) if "trajectory" in content else None,
        provenance=provenance,
    )
