"""Bone geometry: lengths, unit directions and their inverse, and MoMu's bone-length correction.

``bones`` is a sequence of ``(parent, child)`` joint-index pairs (``Skeleton.bones`` of
:mod:`momu.features.skeletons`); ``motion`` is ``(T, J, D)`` joint positions.

* :func:`bone_directions` / :func:`positions_from_directions` — MoMu's directional-vector motion
  encoding (§5.3, Table 7 #1, after [48]): each bone as a unit vector from parent to child, decoded by
  walking the skeleton tree from the root with (mean) bone lengths. Exact round trip for rigid motion.
* :func:`correct_bone_lengths` — MoMu App. E: a predicted bone longer than ``ratio`` (1.3) × its mean
  length is set to the mean length; the child's whole subtree moves with it so other bones keep their
  lengths and directions.

Functions accept numpy arrays (float64 results) or torch tensors (same dtype/device; differentiable).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any, TypeVar

import numpy as np
import torch

__all__ = [
    "check_bones",
    "bone_order",
    "root_joint",
    "bone_vectors",
    "bone_lengths",
    "mean_bone_lengths",
    "bone_directions",
    "positions_from_directions",
    "correct_bone_lengths",
]

Array = TypeVar("Array", np.ndarray, torch.Tensor)
Bones = Sequence[tuple[int, int]] | Sequence[Sequence[int]] | np.ndarray


def check_bones(bones: Bones, num_joints: int | None = None) -> np.ndarray:
    """Validate ``(parent, child)`` pairs; returns an ``(B, 2)`` int64 array.

    Raises:
        ValueError: malformed pairs, indices outside ``[0, num_joints)``, a self-loop, or a joint that
            is the child of two bones.
    """
    arr = np.asarray(bones, dtype=np.int64)
    if arr.ndim != 2 or arr.shape[1] != 2 or arr.shape[0] == 0:
        raise ValueError(f"bones: expected a non-empty list of (parent, child) pairs, got shape {arr.shape}")
    if num_joints is not None and (arr.min() < 0 or arr.max() >= num_joints):
        raise ValueError(
            f"bones: joint indices must be in [0, {num_joints}), got range [{arr.min()}, {arr.max()}]"
        )
    if np.any(arr[:, 0] == arr[:, 1]):
        i = int(np.flatnonzero(arr[:, 0] == arr[:, 1])[0])
        raise ValueError(f"bones[{i}] = {tuple(arr[i])}: a bone cannot connect a joint to itself")
    children, counts = np.unique(arr[:, 1], return_counts=True)
    if np.any(counts > 1):
        raise ValueError(f"bones: joint {int(children[counts > 1][0])} is the child of more than one bone")
    return arr


def root_joint(bones: Bones) -> int:
    """The joint that is a parent but never a child (raises when there is not exactly one)."""
    arr = check_bones(bones)
    roots = sorted(set(arr[:, 0].tolist()) - set(arr[:, 1].tolist()))
    if len(roots) != 1:
        raise ValueError(
            f"bones: expected one root joint (parent of some bone, child of none), found {roots}"
        )
    return roots[0]


def bone_order(bones: Bones, root: int | None = None) -> list[int]:
    """Indices into ``bones`` ordered so every bone comes after the bone ending at its parent joint.

    Raises:
        ValueError: a bone is not reachable from ``root`` (a cycle or a disconnected part).
    """
    arr = check_bones(bones)
    root = root_joint(arr) if root is None else int(root)
    placed = {root}
    order: list[int] = []
    remaining = list(range(len(arr)))
    while remaining:
        ready = [i for i in remaining if int(arr[i, 0]) in placed]
        if not ready:
            bad = [tuple(int(v) for v in arr[i]) for i in remaining]
            raise ValueError(f"bones: {bad} are not connected to root joint {root}")
        for i in ready:
            order.append(i)
            placed.add(int(arr[i, 1]))
        remaining = [i for i in remaining if i not in ready]
    return order


def _check_positions(motion: Any, name: str = "motion") -> Any:
    if isinstance(motion, torch.Tensor):
        if motion.ndim < 2:
            raise ValueError(f"{name}: expected (..., J, D) positions, got shape {tuple(motion.shape)}")
        return motion
    x = np.asarray(motion, dtype=np.float64)
    if x.ndim < 2:
        raise ValueError(f"{name}: expected (..., J, D) positions, got shape {x.shape}")
    return x


def bone_vectors(motion: Array, bones: Bones) -> Array:
    """``child − parent`` for every bone: ``(..., B, D)`` from ``(..., J, D)`` positions."""
    x = _check_positions(motion)
    arr = check_bones(bones, x.shape[-2])
    return x[..., arr[:, 1], :] - x[..., arr[:, 0], :]


def bone_lengths(motion: Array, bones: Bones) -> Array:
    """Euclidean bone lengths ``(T, B)`` (any leading axes: ``(..., J, D) → (..., B)``)."""
    v = bone_vectors(motion, bones)
    if isinstance(v, torch.Tensor):
        return torch.linalg.vector_norm(v, dim=-1)
    return np.linalg.norm(v, axis=-1)


def mean_bone_lengths(motion: Array | Sequence[np.ndarray], bones: Bones) -> Array:
    """Mean length of each bone ``(B,)`` over all frames (and clips, for a list of ``(T, J, D)`` arrays).

    MoMu App. E averages "the bone length between each pair of keypoints in the dataset"; pass every
    training clip as a list to get dataset means (frames weighted equally).
    """
    if isinstance(motion, (list, tuple)):
        if not motion:
            raise ValueError("mean_bone_lengths: empty list of motions")
        per_clip = [np.asarray(bone_lengths(np.asarray(m), bones)).reshape(-1, len(bones)) for m in motion]
        return np.concatenate(per_clip).mean(axis=0)  # type: ignore[return-value]
    lengths: Any = bone_lengths(motion, bones)  # type: ignore[type-var]
    flat = lengths.reshape(-1, lengths.shape[-1])
    if flat.shape[0] == 0:
        raise ValueError("mean_bone_lengths: motion has no frames")
    return flat.mean(0)  # type: ignore[return-value]


def bone_directions(motion: Array, bones: Bones, eps: float = 1e-8) -> Array:
    """Unit bone vectors ``(..., B, D)`` (parent → child); a zero-length bone gives a zero vector.

    MoMu's directional-vector encoding (§5.3, Table 7 #1).
    """
    v = bone_vectors(motion, bones)
    if isinstance(v, torch.Tensor):
        n = torch.linalg.vector_norm(v, dim=-1, keepdim=True)
        return v / n.clamp_min(eps)
    n = np.linalg.norm(v, axis=-1, keepdims=True)
    return np.divide(v, n, out=np.zeros_like(v), where=n > eps)


def positions_from_directions(
    directions: Array,
    lengths: Array | Sequence[float],
    bones: Bones,
    root: Array,
    *,
    root_index: int | None = None,
    num_joints: int | None = None,
) -> Array:
    """Inverse of :func:`bone_directions`: joint positions ``(T, J, D)`` from bone directions.

    Args:
        directions: ``(T, B, D)`` bone direction vectors (normalised here, so any non-zero length works).
        lengths: ``(B,)`` (e.g. :func:`mean_bone_lengths`) or ``(T, B)`` bone lengths.
        bones: ``(parent, child)`` pairs forming a tree.
        root: ``(T, D)`` positions of the root joint.
        root_index: the root joint (default: the one joint that is never a child).
        num_joints: ``J`` of the output (default: the largest joint index in ``bones`` + 1).

    Joints not reached by any bone other than the root stay at the root position. Rigid motion
    round-trips: ``positions_from_directions(bone_directions(m), bone_lengths(m), bones, m[:, root])``.
    """
    arr = check_bones(bones)
    ridx = root_joint(arr) if root_index is None else int(root_index)
    order = bone_order(arr, ridx)
    is_torch = isinstance(directions, torch.Tensor)
    d: Any
    ln: Any
    if directions.ndim != 3 or directions.shape[1] != len(arr):
        raise ValueError(f"directions: expected (T, {len(arr)}, D), got shape {tuple(directions.shape)}")
    num_frames, _, dims = directions.shape
    needed = int(max(arr.max(), ridx)) + 1
    if num_joints is None:
        num_joints = needed
    elif num_joints < needed:
        raise ValueError(f"num_joints={num_joints} is smaller than the joints bones refer to ({needed})")
    if tuple(root.shape) != (num_frames, dims):
        raise ValueError(
            f"root: expected ({num_frames}, {dims}) root positions, got shape {tuple(root.shape)}"
        )
    if isinstance(directions, torch.Tensor):
        d = directions / torch.linalg.vector_norm(directions, dim=-1, keepdim=True).clamp_min(1e-12)
        ln = torch.as_tensor(lengths, dtype=directions.dtype, device=directions.device)
    else:
        d = np.asarray(directions, dtype=np.float64)
        n = np.linalg.norm(d, axis=-1, keepdims=True)
        d = np.divide(d, n, out=np.zeros_like(d), where=n > 1e-12)
        ln = np.asarray(lengths, dtype=np.float64)
    if ln.ndim == 1:
        ln = ln[None, :]
    if ln.shape[-1] != len(arr) or ln.ndim != 2 or ln.shape[0] not in (1, num_frames):
        raise ValueError(
            f"lengths: expected ({len(arr)},) or ({num_frames}, {len(arr)}), got shape {tuple(ln.shape)}"
        )
    joints: list[Any] = [root] * num_joints
    for b in order:
        parent, child = int(arr[b, 0]), int(arr[b, 1])
        joints[child] = joints[parent] + d[:, b] * ln[:, b, None]
    if is_torch:
        return torch.stack(joints, dim=1)  # type: ignore[return-value]
    return np.stack(joints, axis=1)  # type: ignore[return-value]


def correct_bone_lengths(
    motion: Array,
    bones: Bones,
    mean_lengths: Array | Sequence[float],
    ratio: float = 1.3,
) -> Array:
    """MoMu App. E post-processing: bones longer than ``ratio × mean`` are shortened to the mean.

    Args:
        motion: ``(T, J, D)`` predicted positions.
        bones: ``(parent, child)`` tree.
        mean_lengths: ``(B,)`` dataset mean bone lengths (:func:`mean_bone_lengths`).
        ratio: the threshold factor (1.3 in the paper).

    Returns:
        Corrected ``(T, J, D)``: the root stays in place, every bone keeps its direction, bones within
        the threshold keep their length, and over-long ones get their mean length (their subtrees move
        rigidly with them). Joints that no bone reaches are left unchanged.
    """
    if ratio <= 0:
        raise ValueError(f"ratio must be positive, got {ratio}")
    x = _check_positions(motion)
    arr: np.ndarray = check_bones(bones, x.shape[-2])
    if x.ndim != 3:
        raise ValueError(f"motion: expected (T, J, D), got shape {tuple(x.shape)}")
    ridx = root_joint(arr)
    lengths = bone_lengths(x, arr)
    mean: Any
    fixed: Any
    if isinstance(x, torch.Tensor):
        mean = torch.as_tensor(mean_lengths, dtype=x.dtype, device=x.device)
    else:
        mean = np.asarray(mean_lengths, dtype=np.float64)
    if tuple(mean.shape) != (len(arr),):
        raise ValueError(f"mean_lengths: expected ({len(arr)},), got shape {tuple(mean.shape)}")
    if isinstance(x, torch.Tensor):
        fixed = torch.where(lengths > ratio * mean, mean.expand_as(lengths), lengths)
    else:
        fixed = np.where(lengths > ratio * mean, mean, lengths)
    out = positions_from_directions(
        bone_directions(x, arr), fixed, arr, x[:, ridx], root_index=ridx, num_joints=x.shape[1]
    )
    reached = {ridx, *arr[:, 1].tolist()}
    if len(reached) < x.shape[1]:
        keep = [j for j in range(x.shape[1]) if j not in reached]
        out[:, keep] = x[:, keep]
    return out  # type: ignore[no-any-return]
