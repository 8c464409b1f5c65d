"""MoFusion's pose vector (§3): ``m_i ∈ R^{3J}``, root translation + root-relative joints.

"The pose at each timestep i is parameterised as m_i ∈ R^{3J}, which includes the root-relative
3D coordinates of each of the J joints and the camera-relative translation of the root joint."
The root's own root-relative coordinate is always zero, so its slot carries the translation:

* slot ``root``: the root joint's position (the translation);
* slot ``j ≠ root``: ``p_j − p_root``.

:func:`encode_pose` / :func:`decode_pose` map ``(..., T, J, 3)`` ↔ ``(..., T, 3J)`` for numpy arrays
and torch tensors alike; both are linear, so the decode is differentiable and the kinematic losses
(MoFusion §3.2) decode the estimated x̂₀ through it. The round trip is exact up to float rounding
of one subtraction and one addition (bit-exact for float64 of moderate magnitude is not promised).

:func:`mirror_bone_pairs` lists the left/right bone pairs ``(b, δ(b))`` of a skeleton from its mirror
map (MoFusion's ``δ`` in L_a).
"""

from __future__ import annotations

from typing import Any

import numpy as np
import torch

from momu.features.skeletons import Skeleton

__all__ = ["encode_pose", "decode_pose", "mirror_bone_pairs", "pose_channels"]


def pose_channels(num_joints: int) -> int:
    """``3J``: the width of MoFusion's pose vector (72 for SMPL-24, 66 for HumanML3D's 22)."""
    return 3 * int(num_joints)


def _check(motion: Any, root: int) -> None:
    if motion.ndim < 2 or motion.shape[-1] != 3:
        raise ValueError(f"motion: expected (..., J, 3) positions, got shape {tuple(motion.shape)}")
    if not 0 <= root < motion.shape[-2]:
        raise ValueError(f"root: joint index {root} out of range for {motion.shape[-2]} joints")


def encode_pose(motion: Any, root: int = 0) -> Any:
    """``(..., J, 3)`` global positions -> ``(..., 3J)`` MoFusion pose vectors (§3); numpy or torch in,
    the same type out."""
    _check(motion, root)
    p_root = motion[..., root : root + 1, :]
    rel = motion - p_root
    if isinstance(rel, torch.Tensor):
        rel = rel.clone()
        rel[..., root, :] = p_root[..., 0, :]
        return rel.reshape(*rel.shape[:-2], -1)
    rel = np.array(rel, copy=True)
    rel[..., root, :] = p_root[..., 0, :]
    return rel.reshape(*rel.shape[:-2], -1)


def decode_pose(vectors: Any, num_joints: int, root: int = 0) -> Any:
    """``(..., 3J)`` MoFusion pose vectors -> ``(..., J, 3)`` global positions (inverse of encode)."""
    if vectors.shape[-1] != pose_channels(num_joints):
        raise ValueError(
            f"pose vectors: expected {pose_channels(num_joints)} channels for {num_joints} joints, "
            f"got shape {tuple(vectors.shape)}"
        )
    if not 0 <= root < num_joints:
        raise ValueError(f"root: joint index {root} out of range for {num_joints} joints")
    x = vectors.reshape(*vectors.shape[:-1], num_joints, 3)
    translation = x[..., root : root + 1, :]
    if isinstance(x, torch.Tensor):
        is_root = torch.zeros(num_joints, 1, dtype=x.dtype, device=x.device)
        is_root[root] = 1.0
        return x * (1.0 - is_root) + translation  # root slot: 0 + translation
    out = x + translation
    out[..., root, :] = translation[..., 0, :]
    return out


def mirror_bone_pairs(skeleton: Skeleton) -> tuple[tuple[int, int], ...]:
    """Left/right bone pairs ``(b, b')`` (indices into ``skeleton.bones``), each unordered pair once.

    Bone ``(p, c)`` pairs with ``(δ(p), δ(c))`` when that is also a bone and not the same bone
    (midline bones map to themselves and are left out). SMPL-24 has 9 pairs, HumanML3D's 22 have 8.
    """
    index = {bone: k for k, bone in enumerate(skeleton.bones)}
    pairs = []
    for k, (p, c) in enumerate(skeleton.bones):
        other = index.get((skeleton.mirror[p], skeleton.mirror[c]))
        if other is not None and other > k:
            pairs.append((k, other))
    return tuple(pairs)
