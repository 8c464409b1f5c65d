"""Rigid motion: one length per bone for the whole motion, every bone aimed where the input aims it.

Generated joint positions are not a rigid skeleton: a model's limbs change length from frame to frame
(an upper arm of 0.13-0.35 m within one dance of the shipped model). A BVH file cannot hold that (its
bones have one rest length), so every exported file is written from the *rigid* version of the
motion, and the npz, the BVH and the mp4 of one ``momu generate`` run all hold the same rigid motion:

1. :func:`fit_bone_lengths`: each bone's **median** length over the motion (robust to the frames
   where a limb stretches or collapses); a bone whose median is under :data:`MIN_BONE_LENGTH` keeps
   the skeleton's rest length.
2. :func:`fit_rigid_pose`: the rotations of the BVH rig of those lengths
   (:mod:`momu.export.rig`: inverse kinematics by bone directions, one rotation per bone).
3. :func:`rigid_motion`: forward kinematics of those rotations: the root where the input's root is,
   every bone in the input bone's direction, with its fitted length (a bone of zero length in a frame,
   whose direction is undefined, keeps its rest direction relative to its parent).

It is exactly what forward kinematics of the written BVH gives (up to the file's 6 decimals), and it
is idempotent: the rigid version of rigid motion is itself.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from momu.export.rig import BvhRig, build_rig, global_rotations, world_positions
from momu.features.bones import bone_lengths
from momu.features.skeletons import Skeleton, get_skeleton

__all__ = ["MIN_BONE_LENGTH", "RigidPose", "fit_bone_lengths", "fit_rigid_pose", "rigid_motion"]

MIN_BONE_LENGTH = 1e-4
"""Bones whose median length in the motion is shorter (metres) keep the skeleton's rest length."""


@dataclass(frozen=True)
class RigidPose:
    """A motion posed on a rigid BVH rig.

    Attributes:
        rig: the rig (rest offsets of the fitted bone lengths).
        rotations: ``(T, N, 3, 3)`` global rotation of every BVH joint.
        root: ``(T, 3)`` root joint positions.
    """

    rig: BvhRig
    rotations: np.ndarray
    root: np.ndarray

    def positions(self) -> np.ndarray:
        """``(T, J, 3)`` joint positions of the skeleton (helper joints left out), by forward kinematics."""
        return world_positions(self.rig, self.rotations, self.root)[:, list(self.rig.bvh_index)]


def as_skeleton(skeleton: str | Skeleton) -> Skeleton:
    """``skeleton`` itself, or the registered skeleton of that name."""
    return skeleton if isinstance(skeleton, Skeleton) else get_skeleton(skeleton)


def check_motion_3d(motion: np.ndarray, skeleton: Skeleton) -> np.ndarray:
    """``motion`` as float64 ``(T, J, 3)``; ``ValueError`` naming what is wrong otherwise."""
    x = np.asarray(motion, dtype=np.float64)
    if skeleton.dims != 3:
        raise ValueError(
            f"skeleton {skeleton.name!r} is {skeleton.dims}D image keypoints: BVH needs 3D joint positions "
            "(convert with momu.features.convert, or use a 3D model)"
        )
    if x.ndim != 3 or x.shape[1:] != (skeleton.num_joints, 3) or x.shape[0] < 1:
        want = f"(T, {skeleton.num_joints}, 3)"
        raise ValueError(f"motion must be {want} for skeleton {skeleton.name!r}, got {x.shape}")
    if not np.all(np.isfinite(x)):
        raise ValueError("motion contains NaN or infinite values")
    return x


def fit_bone_lengths(motion: np.ndarray, skeleton: str | Skeleton) -> np.ndarray:
    """``(J - 1,)`` one length per bone (:attr:`Skeleton.bones` order): the median over the frames of
    ``(T, J, 3)`` ``motion``; bones of median length under :data:`MIN_BONE_LENGTH` get the rest length."""
    skel = as_skeleton(skeleton)
    x = check_motion_3d(motion, skel)
    median = np.median(np.asarray(bone_lengths(x, skel.bones), dtype=np.float64), axis=0)
    rest = skel.bone_lengths
    return np.where(median > MIN_BONE_LENGTH, median, np.maximum(rest, MIN_BONE_LENGTH))


def fit_rigid_pose(
    motion: np.ndarray, skeleton: str | Skeleton, bone_lengths: np.ndarray | None = None
) -> RigidPose:
    """The :class:`RigidPose` of ``(T, J, 3)`` ``motion`` (metres) on a rig with ``bone_lengths``
    (default: :func:`fit_bone_lengths` of the motion)."""
    skel = as_skeleton(skeleton)
    x = check_motion_3d(motion, skel)
    lengths = fit_bone_lengths(x, skel) if bone_lengths is None else bone_lengths
    rig = build_rig(skel, lengths)
    return RigidPose(rig=rig, rotations=global_rotations(rig, x), root=x[:, skel.root].copy())


def rigid_motion(
    motion: np.ndarray, skeleton: str | Skeleton, bone_lengths: np.ndarray | None = None
) -> np.ndarray:
    """The rigid version of ``motion`` (module docstring): ``(T, J, 3)`` float64 for a 3D skeleton.

    Image-plane keypoints of a 2D skeleton have no rigid bones (their lengths change with the view):
    they are returned unchanged, as float64.
    """
    skel = as_skeleton(skeleton)
    if skel.dims != 3:
        return np.asarray(motion, dtype=np.float64)
    return fit_rigid_pose(motion, skel, bone_lengths).positions()
