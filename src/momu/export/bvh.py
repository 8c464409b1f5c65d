"""BVH export and import of joint positions, through ``upc-pymotion`` (``pymotion.io.bvh``).

:func:`write_bvh` turns ``(T, J, 3)`` joint positions of a registered 3D skeleton into a BVH file:
the hierarchy and rotations of :mod:`momu.export.rig` (bone-direction IK, documented twist choice)
with one length per bone for the whole motion (:mod:`momu.export.rigid`: the median), the root's
position as translation channels, ``Frame Time = 1 / fps``. The file holds the rigid version of the
motion (:func:`momu.export.rigid.rigid_motion`), joint for joint. Lengths are written in metres
(``scale`` changes the unit: 100 writes centimetres), so Blender's importer shows the dancer life-size
at its default scale 1. :func:`read_bvh` loads any BVH file with the same library and returns its
joints' world positions by forward kinematics.

pymotion's convention, which the tests check against an independent reader (``bvhio``): channels
``Zrotation Xrotation Yrotation`` mean the local rotation ``R = R_z R_x R_y`` (intrinsic, the BVH
standard), a joint's position is ``pos[parent] + G[parent] · OFFSET`` and ``G = G[parent] · R``.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from momu.export.rig import BvhRig, local_rotations
from momu.export.rigid import as_skeleton, check_motion_3d, fit_rigid_pose
from momu.features.skeletons import Skeleton
from momu.io import atomic_path

__all__ = ["BvhMotion", "motion_bvh_data", "write_bvh", "read_bvh", "DEFAULT_ROTATION_ORDER"]

DEFAULT_ROTATION_ORDER = "zxy"
"""Euler channel order of written files (``Zrotation Xrotation Yrotation``, as in CMU/Mixamo files)."""


@dataclass(frozen=True)
class BvhMotion:
    """Joints of a BVH file: names, parents, world positions, frame rate.

    Attributes:
        names: joint names in file order (End Sites excluded).
        parents: parent index of each joint (``-1`` for the root).
        positions: ``(T, N, 3)`` world positions by forward kinematics, in the file's units.
        fps: frames per second (``1 / Frame Time``).
    """

    names: tuple[str, ...]
    parents: tuple[int, ...]
    positions: np.ndarray
    fps: float


def _check_motion(motion: np.ndarray, skel: Skeleton, trajectory: np.ndarray | None) -> np.ndarray:
    x = check_motion_3d(motion, skel)
    if trajectory is not None:
        traj = np.asarray(trajectory, dtype=np.float64)
        if traj.shape != (x.shape[0], 3) or not np.all(np.isfinite(traj)):
            raise ValueError(f"trajectory must be finite (T, 3) = ({x.shape[0]}, 3), got {traj.shape}")
        x = x + traj[:, None, :]
    return x


def _intrinsic_euler_degrees(matrices: np.ndarray, order: str) -> np.ndarray:
    """``(..., 3)`` intrinsic Euler angles (degrees, channel ``order`` such as ``"zxy"``) of ``(..., 3, 3)``
    rotation matrices, by scipy (vectorised: pymotion's ``to_euler`` loops in Python, 7x slower on a
    3-minute dance). At gimbal lock scipy warns and sets the last angle to 0; the angles still give
    the same rotation, which is all a BVH file needs."""
    import warnings

    from scipy.spatial.transform import Rotation

    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message="Gimbal lock detected", category=UserWarning)
        euler = Rotation.from_matrix(matrices.reshape(-1, 3, 3)).as_euler(order.upper(), degrees=True)
    return euler.reshape(*matrices.shape[:-2], 3)


def motion_bvh_data(
    motion: np.ndarray,
    fps: float,
    skeleton: str | Skeleton,
    *,
    trajectory: np.ndarray | None = None,
    bone_lengths: np.ndarray | None = None,
    rotation_order: str = DEFAULT_ROTATION_ORDER,
    scale: float = 1.0,
) -> tuple[BvhRig, dict[str, object]]:
    """The rig and the ``pymotion`` BVH data dict of ``motion`` (see :func:`write_bvh`)."""
    skel = as_skeleton(skeleton)
    if not np.isfinite(fps) or fps <= 0:
        raise ValueError(f"fps must be a positive frame rate, got {fps!r}")
    order = rotation_order.lower()
    if sorted(order) != ["x", "y", "z"]:
        raise ValueError(f"rotation_order must be a permutation of 'xyz', got {rotation_order!r}")
    if not np.isfinite(scale) or scale <= 0:
        raise ValueError(f"scale must be > 0, got {scale!r}")
    x = _check_motion(motion, skel, trajectory)
    pose = fit_rigid_pose(x, skel, bone_lengths)
    rig = pose.rig
    local = local_rotations(rig, pose.rotations)
    t, n = local.shape[:2]
    euler = _intrinsic_euler_degrees(local, order)
    euler = (euler + 180.0) % 360.0 - 180.0  # (-180, 180]: smaller numbers, same rotation
    positions = np.broadcast_to(rig.offsets * scale, (t, n, 3)).copy()
    positions[:, 0] = pose.root * scale
    leaves = [b for b in range(n) if not any(p == b for p in rig.parents)]
    data: dict[str, object] = {
        "names": np.array(rig.names),
        "offsets": rig.offsets * scale,
        "parents": np.array([max(p, 0) for p in rig.parents]),  # pymotion: the root is its own parent
        "rot_order": np.array([list(order)] * n),
        "channels": np.array([6] + [3] * (n - 1)),
        "positions": positions,
        "rotations": euler,
        "frame_time": 1.0 / float(fps),
        "end_sites": rig.end_sites[leaves] * scale,
        "end_sites_parents": np.array(leaves, dtype=np.int64),
    }
    return rig, data


def write_bvh(
    path: str | Path,
    motion: np.ndarray,
    fps: float,
    skeleton: str | Skeleton,
    *,
    trajectory: np.ndarray | None = None,
    bone_lengths: np.ndarray | None = None,
    rotation_order: str = DEFAULT_ROTATION_ORDER,
    scale: float = 1.0,
) -> Path:
    """Write ``(T, J, 3)`` joint positions (metres, Y up) of ``skeleton`` as a BVH file, atomically.

    Args:
        path: output ``.bvh`` file.
        motion: joint positions in the skeleton's joint order.
        fps: frame rate (the file's ``Frame Time`` is ``1 / fps``).
        skeleton: a registered 3D skeleton (name or :class:`Skeleton`).
        trajectory: optional ``(T, 3)`` root path added to every joint (root-centred clips).
        bone_lengths: rest bone lengths in :attr:`Skeleton.bones` order (default: the motion's median
            bone lengths, :func:`momu.export.rigid.fit_bone_lengths`).
        rotation_order: Euler channel order (default ``zxy``).
        scale: length unit factor (1 = metres, 100 = centimetres).

    Returns:
        ``Path(path)``. Forward kinematics of the file gives :func:`momu.export.rigid.rigid_motion` of
        ``motion`` (+ ``trajectory``) within a micrometre: ``motion`` itself where its bones keep the
        written lengths, else every bone in its direction with the written length.
    """
    from pymotion.io.bvh import BVH

    path = Path(path)
    _, data = motion_bvh_data(
        motion,
        fps,
        skeleton,
        trajectory=trajectory,
        bone_lengths=bone_lengths,
        rotation_order=rotation_order,
        scale=scale,
    )
    writer = BVH()
    writer.data = data
    with atomic_path(path) as tmp:
        writer.save(str(tmp))
        _precise_frame_time(tmp, 1.0 / float(fps))
    return path


def _precise_frame_time(path: Path, frame_time: float) -> None:
    """Rewrite the ``Frame Time`` line with 10 decimals (pymotion writes 6: 60 fps would read back as
    59.9988 and drift 3.6 ms over three minutes)."""
    text = path.read_text()
    head, sep, tail = text.partition("Frame Time:")
    if not sep:  # pragma: no cover - pymotion always writes the line
        raise RuntimeError(f"{path}: BVH writer wrote no Frame Time line")
    _, newline, frames = tail.partition("\n")
    path.write_text(f"{head}Frame Time: {frame_time:.10f}{newline}{frames}")


def read_bvh(path: str | Path) -> BvhMotion:
    """Load a BVH file and compute its joints' world positions (``pymotion`` reader and FK).

    Raises:
        FileNotFoundError: no such file.
        ValueError: the file is not a BVH file pymotion can parse (the message names it).
    """
    from pymotion.io.bvh import BVH
    from pymotion.ops.skeleton_np import fk

    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"{path}: BVH file not found")
    reader = BVH()
    try:
        reader.load(str(path))
        rots, pos, parents, offsets, _, _ = reader.get_data()
    except Exception as exc:  # pymotion's parser raises bare Exception / IndexError / ValueError
        raise ValueError(f"{path}: not a readable BVH file ({type(exc).__name__}: {exc})") from None
    if rots.ndim != 3 or rots.shape[0] < 1:
        raise ValueError(f"{path}: BVH file has no motion frames")
    world, _ = fk(rots, pos[:, 0], offsets, parents)
    frame_time = float(reader.data["frame_time"])
    if not np.isfinite(frame_time) or frame_time <= 0:
        raise ValueError(f"{path}: Frame Time must be > 0, got {frame_time}")
    parent_list = tuple(-1 if i == 0 else int(p) for i, p in enumerate(parents))
    return BvhMotion(
        names=tuple(str(n) for n in reader.data["names"]),
        parents=parent_list,
        positions=np.asarray(world, dtype=np.float64),
        fps=1.0 / frame_time,
    )
