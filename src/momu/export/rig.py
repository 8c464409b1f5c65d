"""A BVH rig for a registered skeleton, joint rotations from joint positions, and its forward kinematics.

A BVH file stores one rotation per joint; that rotation turns the rest offsets of *all* the joint's
children. A skeleton joint whose children belong to different body segments
(:attr:`momu.features.skeletons.Skeleton.segments`: Dance with Melody's pelvis carries the hips, which
turn with the pelvis, and the shoulders and head, which turn with the abdomen) gets one BVH joint for
the group of children that shares its own segment (for the root: the ``pelvis`` group, else the
largest) and one *segment* helper joint per other group, at the same place (zero offset), named
``<joint>_<segment>``, whose rotation is the group's.

The bones of a group of two or more children (SMPL's ``spine3`` with its neck and collars) need not
keep their angles to each other in generated motion, so one rotation cannot place them all. Each
child of such a group hangs from its own *bone* helper joint, ``<joint>_to_<child>``, at the group
joint's place (zero offset), whose local rotation turns that one bone from the group's rotation onto
its own direction. So every bone of the skeleton has a BVH joint whose rotation aims it exactly, and
forward kinematics of the rig reproduces every joint position of a motion whose bones have the rig's
lengths (:mod:`momu.export.rigid` re-poses any motion that way).

Rest offsets are the skeleton's rest directions scaled to the bone lengths given (one length per
bone for the whole motion: :func:`momu.export.rigid.fit_bone_lengths`).

Rotations from positions (inverse kinematics by aligning bone directions):

* a group of two or more children: the rotation that best maps the group's rest offsets onto its
  current bone vectors (scaled to rest length), by the Kabsch/SVD solution of Wahba's problem (a
  least-squares "segment orientation"; the bone helpers make every bone exact).
* one child (a limb bone, or a bone helper's bone): its direction fixes the rotation up to a twist
  about the bone. **Twist choice**: the joint's *local* rotation is the shortest-arc rotation taking
  the rest offset to the current bone direction expressed in the parent's frame, i.e. no twist about
  the bone relative to the parent. Twist cannot be seen in joint positions; this choice keeps local
  rotations smallest and continuous.
* a leaf (no children): local rotation identity; its End Site extends its bone by a quarter length.

The root joint carries the root's position (translation channels) and its group's rotation.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from momu.features.skeletons import Skeleton

__all__ = ["BvhRig", "build_rig", "global_rotations", "local_rotations", "world_positions"]

END_SITE_FRACTION = 0.25
"""Length of a leaf's End Site as a fraction of the leaf's bone (it only gives a viewer a bone tail)."""


@dataclass(frozen=True)
class BvhRig:
    """BVH joints of a skeleton, in file order (every parent before its children, root first).

    Attributes:
        skeleton: the skeleton's name.
        names: BVH joint names (the skeleton's joint names, plus the ``<joint>_<segment>`` and
            ``<joint>_to_<child>`` helper joints).
        parents: parent BVH joint of each joint (``-1`` for the root).
        offsets: ``(N, 3)`` rest offsets from the parent joint, in metres.
        joint_of: the skeleton joint each BVH joint sits at.
        groups: the skeleton joints whose bones each BVH joint's rotation turns (empty for leaves).
        end_sites: ``(N, 3)`` End Site offsets (non-zero only for leaves).
    """

    skeleton: str
    names: tuple[str, ...]
    parents: tuple[int, ...]
    offsets: np.ndarray
    joint_of: tuple[int, ...]
    groups: tuple[tuple[int, ...], ...]
    end_sites: np.ndarray

    @property
    def num_joints(self) -> int:
        return len(self.names)

    @property
    def bvh_index(self) -> tuple[int, ...]:
        """For each skeleton joint, the BVH joint that is it (not one of its helper joints)."""
        out: dict[int, int] = {}
        for b, j in enumerate(self.joint_of):
            out.setdefault(j, b)
        return tuple(out[j] for j in range(len(out)))


def _rest_offsets(skeleton: Skeleton, bone_lengths: np.ndarray | None) -> np.ndarray:
    """``(J, 3)`` rest offsets: the skeleton's rest directions scaled to ``bone_lengths`` (bones order)."""
    off = np.asarray(skeleton.offsets, dtype=np.float64)
    if bone_lengths is None:
        return off
    lengths = np.asarray(bone_lengths, dtype=np.float64).reshape(-1)
    if lengths.shape != (len(skeleton.bones),) or not np.all(np.isfinite(lengths)) or np.any(lengths <= 0):
        raise ValueError(
            f"bone_lengths: expected {len(skeleton.bones)} positive lengths for skeleton "
            f"{skeleton.name!r}, got shape {lengths.shape}"
        )
    out = off.copy()
    for (_, c), length in zip(skeleton.bones, lengths):
        norm = np.linalg.norm(off[c])
        out[c] = off[c] / norm * length if norm > 0 else off[c]
    return out


def _child_groups(skeleton: Skeleton, joint: int) -> list[tuple[str, list[int]]]:
    """The children of ``joint`` grouped by segment, the group that turns with the joint first."""
    groups: dict[str, list[int]] = {}
    for c, p in enumerate(skeleton.parents):
        if p == joint:
            groups.setdefault(skeleton.segments[c], []).append(c)
    if not groups:
        return []
    own = skeleton.segments[joint]
    if own in groups:
        first = own
    elif own == "root" and "pelvis" in groups:
        first = "pelvis"
    else:
        first = max(groups, key=lambda s: len(groups[s]))  # ties: the first in joint order
    return [(first, groups[first])] + [(s, cs) for s, cs in groups.items() if s != first]


def build_rig(skeleton: Skeleton, bone_lengths: np.ndarray | None = None) -> BvhRig:
    """The :class:`BvhRig` of a 3D skeleton with rest bones of ``bone_lengths`` (default: its rest pose)."""
    rest = _rest_offsets(skeleton, bone_lengths)
    names: list[str] = []
    parents: list[int] = []
    offsets: list[np.ndarray] = []
    joint_of: list[int] = []
    groups: list[tuple[int, ...]] = []

    def add(name: str, parent: int, offset: np.ndarray, joint: int) -> int:
        names.append(name)
        parents.append(parent)
        offsets.append(np.asarray(offset, dtype=np.float64))
        joint_of.append(joint)
        groups.append(())
        return len(names) - 1

    def visit(joint: int, parent: int, offset: np.ndarray) -> None:
        name = skeleton.joint_names[joint]
        here = add(name, parent, offset, joint)
        for k, (segment, children) in enumerate(_child_groups(skeleton, joint)):
            holder = here if k == 0 else add(f"{name}_{segment}", here, np.zeros(3), joint)
            groups[holder] = tuple(children)
            if len(children) == 1:
                visit(children[0], holder, rest[children[0]])
                continue
            for c in children:  # one bone helper per child: each bone gets its own rotation
                helper = add(f"{name}_to_{skeleton.joint_names[c]}", holder, np.zeros(3), joint)
                groups[helper] = (c,)
                visit(c, helper, rest[c])

    visit(skeleton.root, -1, np.zeros(3))
    if len(set(names)) != len(names):  # pragma: no cover - registered skeletons have none
        raise ValueError(f"skeleton {skeleton.name!r}: BVH helper joint names clash with joint names")
    off = np.stack(offsets)
    ends = np.zeros_like(off)
    for b, g in enumerate(groups):
        if not g and parents[b] >= 0:
            ends[b] = END_SITE_FRACTION * off[b]
    return BvhRig(
        skeleton=skeleton.name,
        names=tuple(names),
        parents=tuple(parents),
        offsets=off,
        joint_of=tuple(joint_of),
        groups=tuple(groups),
        end_sites=ends,
    )


def _shortest_arc(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``(..., 3, 3)`` rotations taking direction ``a`` to direction ``b`` by the shortest arc
    (Rodrigues' formula; identity where ``b`` is zero, a half turn about a perpendicular where opposite)."""
    a = a / np.maximum(np.linalg.norm(a, axis=-1, keepdims=True), 1e-12)
    nb = np.linalg.norm(b, axis=-1, keepdims=True)
    b = np.where(nb > 1e-12, b / np.maximum(nb, 1e-12), a)
    v = np.cross(a, b)
    c = np.sum(a * b, axis=-1)[..., None, None]
    k = np.zeros(v.shape[:-1] + (3, 3))
    k[..., 0, 1], k[..., 0, 2], k[..., 1, 2] = -v[..., 2], v[..., 1], -v[..., 0]
    k[..., 1, 0], k[..., 2, 0], k[..., 2, 1] = v[..., 2], -v[..., 1], v[..., 0]
    eye = np.broadcast_to(np.eye(3), k.shape)
    opposite = c[..., 0, 0] < -1.0 + 1e-9
    rot = eye + k + (k @ k) / np.maximum(1.0 + c, 1e-12)
    if np.any(opposite):
        aa = np.broadcast_to(a, v.shape)[opposite]
        helper = np.where(np.abs(aa[:, :1]) < 0.9, [[1.0, 0.0, 0.0]], [[0.0, 1.0, 0.0]])
        axis = np.cross(aa, helper)
        axis /= np.linalg.norm(axis, axis=-1, keepdims=True)
        rot = rot.copy()
        rot[opposite] = 2.0 * axis[:, :, None] * axis[:, None, :] - np.eye(3)
    return rot


def _kabsch(rest: np.ndarray, current: np.ndarray) -> np.ndarray:
    """``(T, 3, 3)`` rotations ``R`` minimising ``Σ_i |R rest_i − current_i|²`` (rest ``(k, 3)``,
    current ``(T, k, 3)``), with the reflection case excluded (Kabsch 1976)."""
    h = np.einsum("ka,tkb->tab", rest, current)  # Σ a_i b_iᵀ
    u, _, vt = np.linalg.svd(h)
    d = np.sign(np.linalg.det(np.swapaxes(vt, -1, -2) @ np.swapaxes(u, -1, -2)))
    d = np.where(d == 0, 1.0, d)
    fix = np.broadcast_to(np.eye(3), h.shape).copy()
    fix[:, 2, 2] = d
    return np.swapaxes(vt, -1, -2) @ fix @ np.swapaxes(u, -1, -2)


def _is_degenerate(rest: np.ndarray) -> bool:
    """Whether rest offsets ``(k, 3)`` span at most a line (then only a direction is known)."""
    s = np.linalg.svd(rest, compute_uv=False)
    return len(s) < 2 or s[1] <= 1e-6 * max(s[0], 1e-12)


def global_rotations(rig: BvhRig, motion: np.ndarray) -> np.ndarray:
    """``(T, N, 3, 3)`` global rotation of every BVH joint from ``(T, J, 3)`` joint positions (metres).

    See the module docstring for the rules (Kabsch for rigid groups, shortest arc with no twist
    relative to the parent for single bones, identity local rotation for leaves).
    """
    x = np.asarray(motion, dtype=np.float64)
    t = x.shape[0]
    out = np.empty((t, rig.num_joints, 3, 3))
    for b in range(rig.num_joints):
        parent_rot = out[:, rig.parents[b]] if rig.parents[b] >= 0 else np.broadcast_to(np.eye(3), (t, 3, 3))
        group = rig.groups[b]
        if not group:
            out[:, b] = parent_rot
            continue
        base = rig.joint_of[b]
        children = [rig.joint_of.index(c) for c in group]  # the BVH joints of the group's children
        rest = rig.offsets[children]  # (k, 3)
        vec = x[:, list(group)] - x[:, base : base + 1]  # (T, k, 3)
        if len(group) >= 2 and not _is_degenerate(rest):
            lengths = np.linalg.norm(rest, axis=-1)
            unit = vec / np.maximum(np.linalg.norm(vec, axis=-1, keepdims=True), 1e-12)
            out[:, b] = _kabsch(rest, unit * lengths[None, :, None])
        else:
            # direction only: shortest arc in the parent's frame (no twist relative to the parent)
            local_target = np.einsum("tba,tb->ta", parent_rot, vec.sum(axis=1))
            out[:, b] = parent_rot @ _shortest_arc(
                np.broadcast_to(rest.sum(axis=0), local_target.shape), local_target
            )
    return out


def local_rotations(rig: BvhRig, global_rot: np.ndarray) -> np.ndarray:
    """``(T, N, 3, 3)`` local rotations ``R_parentᵀ R`` (the root's is its global rotation)."""
    local = np.array(global_rot, dtype=np.float64, copy=True)
    for b, p in enumerate(rig.parents):
        if p >= 0:
            local[:, b] = np.swapaxes(global_rot[:, p], -1, -2) @ global_rot[:, b]
    return local


def world_positions(rig: BvhRig, global_rot: np.ndarray, root_positions: np.ndarray) -> np.ndarray:
    """``(T, N, 3)`` world positions of every BVH joint by the BVH convention of forward kinematics:
    ``pos[b] = pos[parent] + G[parent] · offset[b]``, the root at ``root_positions`` ``(T, 3)``."""
    rot = np.asarray(global_rot, dtype=np.float64)
    pos = np.empty(rot.shape[:2] + (3,))
    pos[:, 0] = np.asarray(root_positions, dtype=np.float64)
    for b in range(1, rig.num_joints):
        p = rig.parents[b]
        pos[:, b] = pos[:, p] + rot[:, p] @ rig.offsets[b]
    return pos
