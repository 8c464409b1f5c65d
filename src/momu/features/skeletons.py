"""Joint layouts of the skeletons momu reads and generates, and forward kinematics over them.

Every skeleton is a frozen :class:`Skeleton`: joint names, a kinematic tree (``parents``, -1 for
the root), the bone list derived from it (``(parent, child)`` pairs, one per non-root joint), a
left/right mirror map, the coordinate dimension of the data it describes and its usual frame rate.
For forward kinematics (the synthetic dataset, tests) each skeleton also carries a 3D rest pose as
bone offsets and a body-segment label per bone.

Conventions shared by all skeletons:

- 3D coordinates are **metres, Y up, the body facing +Z, its left side towards +X** in the rest
  pose (the SMPL convention, right-handed). 2D skeletons (``dims == 2``) are image-plane keypoints;
  their 3D rest pose is the rig they are projected from.
- ``bones[k] == (parents[c], c)`` for the ``k``-th non-root joint ``c`` in joint order, so
  ``len(bones) == num_joints - 1`` and every bone is a parent -> child edge of the tree.
- ``mirror[j]`` is the index of ``j``'s left/right counterpart (``j`` itself on the midline);
  it is an involution, and a mirrored pose is ``pose[..., mirror, :]`` with X negated.

Layouts (see ``docs/synth_dance.md`` for the paper mapping):

- ``openpose14``: the 14 OpenPose keypoints MoMu (§B.2, after D2M [26]) keeps: nose, neck, right/left
  shoulder, elbow, wrist, right/left hip, knee, ankle, in OpenPose COCO-18 order (Body-25 minus
  MidHip, eyes, ears and feet). 2D. Tree rooted at the neck.
- ``smpl24``: the 24 SMPL joints in SMPL order (AIST++, Bailando, MoFusion's 24-joint metrics);
  rest offsets are the SMPL neutral template's joint offsets (as in EDGE/Bailando visualisers).
- ``humanml22``: HumanML3D / T2M's 22 joints: SMPL's first 22 (no hand tips), 20 fps.
- ``coco17``: COCO-17 keypoints (AIST++ ``keypoints3d``/``keypoints2d``, LORIS). COCO has no centre
  joint, so the tree is rooted at the nose with nose -> shoulder pseudo-bones.
- ``dwm21`` / ``dwm23``: Dance with Melody (Tang et al. 2018; HarmoGAN §V-A uses the first 21
  points). The bones are those of the authors' drawing code (``shared/data/README.md``) with the
  drawing's virtual midpoints (mid-shoulder, mid-foot) replaced by real joints: the pelvis (2) is
  the root of the head, both shoulders and both hips; each ankle carries heel and toe. Side names
  are inferred from the data (knees and toes point forward; right-handed, Y up): joints 3-11 are
  the right side, 12-20 the left. Points 21-22 (``dwm23`` only) mark hand direction. The real data
  is in centimetres and not rigid (mocap noise: bone-length std 0.7-5.4 cm); the rest offsets here
  are its mean bone lengths in metres.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

__all__ = ["Skeleton", "SKELETON_NAMES", "get_skeleton", "forward_kinematics", "SEGMENTS"]

# Body segments a bone can belong to. Forward kinematics drives each segment with one rotation, so
# the same dance can be posed on any skeleton by giving per-segment rotations.
SEGMENTS: tuple[str, ...] = (
    "pelvis",  # hips and the lowest spine offset
    "abdomen",  # lower trunk (spine1 -> spine2), whole-trunk bones of skeletons without a spine
    "chest",  # upper trunk (spine2 -> spine3 -> neck / collars)
    "head",
    "l_clavicle",
    "r_clavicle",
    "l_upper_arm",
    "r_upper_arm",
    "l_forearm",
    "r_forearm",
    "l_hand",
    "r_hand",
    "l_thigh",
    "r_thigh",
    "l_shin",
    "r_shin",
    "l_foot",
    "r_foot",
)


@dataclass(frozen=True)
class Skeleton:
    """A joint layout.

    Attributes:
        name: the layout's name (``get_skeleton(name)``).
        joint_names: ``J`` joint names, in the data's joint order.
        parents: ``J`` parent indices, ``-1`` for the (single) root.
        bones: ``J - 1`` ``(parent, child)`` index pairs, in child order.
        mirror: ``J`` indices of each joint's left/right counterpart (itself on the midline).
        dims: 2 (image-plane keypoints) or 3 (metres, Y up).
        fps: the frame rate data in this layout usually has (frames per second).
        offsets: ``J`` 3D rest-pose offsets of each joint from its parent (metres, Y up, facing +Z,
            left = +X; the root's is ``(0, 0, 0)``), for forward kinematics.
        segments: ``J`` body-segment labels (:data:`SEGMENTS`) of the bone ending at each joint
            (``"root"`` for the root); a segment's rotation rotates all its bones' offsets.
    """

    name: str
    joint_names: tuple[str, ...]
    parents: tuple[int, ...]
    bones: tuple[tuple[int, int], ...]
    mirror: tuple[int, ...]
    dims: int
    fps: float
    offsets: tuple[tuple[float, float, float], ...] = field(repr=False)
    segments: tuple[str, ...] = field(repr=False)

    def __post_init__(self) -> None:
        n = len(self.joint_names)
        for attr in ("parents", "mirror", "offsets", "segments"):
            if len(getattr(self, attr)) != n:
                got = len(getattr(self, attr))
                raise ValueError(f"skeleton {self.name!r}: {attr} has {got} entries, expected {n}")
        if self.dims not in (2, 3):
            raise ValueError(f"skeleton {self.name!r}: dims must be 2 or 3, got {self.dims}")
        roots = [j for j, p in enumerate(self.parents) if p == -1]
        if len(roots) != 1:
            raise ValueError(f"skeleton {self.name!r}: expected exactly one root (parent -1), got {roots}")
        expected = tuple((p, c) for c, p in enumerate(self.parents) if p != -1)
        if self.bones != expected:
            raise ValueError(f"skeleton {self.name!r}: bones must be the (parent, child) edges, child order")
        for j, m in enumerate(self.mirror):
            if not 0 <= m < n or self.mirror[m] != j:
                raise ValueError(f"skeleton {self.name!r}: mirror is not an involution at joint {j}")
        for j, s in enumerate(self.segments):
            if (s == "root") != (self.parents[j] == -1) or (s != "root" and s not in SEGMENTS):
                raise ValueError(f"skeleton {self.name!r}: bad segment {s!r} for joint {j}")
        self.order  # noqa: B018  (validates that the tree is acyclic)

    @property
    def num_joints(self) -> int:
        return len(self.joint_names)

    @property
    def root(self) -> int:
        """Index of the root joint."""
        return self.parents.index(-1)

    @cached_property
    def order(self) -> tuple[int, ...]:
        """Joint indices in topological order (every parent before its children), root first."""
        done: list[int] = [self.root]
        seen = {self.root}
        children: dict[int, list[int]] = {}
        for c, p in enumerate(self.parents):
            if p != -1:
                children.setdefault(p, []).append(c)
        i = 0
        while i < len(done):
            for c in children.get(done[i], []):
                if c in seen:  # pragma: no cover - impossible with one parent per joint
                    raise ValueError(f"skeleton {self.name!r}: cycle at joint {c}")
                seen.add(c)
                done.append(c)
            i += 1
        if len(done) != self.num_joints:
            raise ValueError(
                f"skeleton {self.name!r}: joints {sorted(set(range(self.num_joints)) - seen)} "
                "are not reachable from the root"
            )
        return tuple(done)

    def index(self, joint_name: str) -> int:
        """Index of ``joint_name``; ``KeyError`` naming the valid joints otherwise."""
        try:
            return self.joint_names.index(joint_name)
        except ValueError:
            msg = f"skeleton {self.name!r} has no joint {joint_name!r}; joints: {self.joint_names}"
            raise KeyError(msg) from None

    @property
    def bone_lengths(self) -> np.ndarray:
        """``(J - 1,)`` rest-pose bone lengths in metres, in :attr:`bones` order."""
        off = np.asarray(self.offsets, dtype=np.float64)
        return np.linalg.norm(off[[c for _, c in self.bones]], axis=-1)

    def rest_pose(self) -> np.ndarray:
        """``(J, 3)`` rest-pose joint positions (metres), root at the origin."""
        ident = np.broadcast_to(np.eye(3), (1, self.num_joints, 3, 3))
        return forward_kinematics(self, ident, np.zeros((1, 3)))[0]

    def mirror_pose(self, motion: np.ndarray) -> np.ndarray:
        """Left/right mirror of ``motion`` (``(..., J, D)``): swap counterparts and negate X."""
        motion = np.asarray(motion)
        if motion.shape[-2] != self.num_joints:
            got = motion.shape[-2]
            raise ValueError(f"motion has {got} joints, skeleton {self.name!r} has {self.num_joints}")
        out = motion[..., list(self.mirror), :].copy()
        out[..., 0] = -out[..., 0]
        return out


def forward_kinematics(
    skeleton: Skeleton, bone_rotations: np.ndarray, root_positions: np.ndarray
) -> np.ndarray:
    """Joint positions from per-bone global rotations (rigid bones, lengths = rest offsets).

    ``pos[root] = root_positions`` and ``pos[c] = pos[parent(c)] + R[c] @ offsets[c]``: each bone's
    rest offset is rotated by its own *global* rotation (giving the global rotation of a segment to
    all of its bones reproduces classic parent-local FK), so every bone length is exactly the rest
    length in every frame.

    Args:
        skeleton: the layout (its :attr:`Skeleton.offsets` give the bones).
        bone_rotations: ``(T, J, 3, 3)`` rotation matrices (the root's entry is ignored);
            ``(T, 1, 3, 3)`` or ``(1, J, 3, 3)`` broadcast.
        root_positions: ``(T, 3)`` root joint positions in metres.

    Returns:
        ``(T, J, 3)`` float64 positions in metres.
    """
    rot = np.asarray(bone_rotations, dtype=np.float64)
    root = np.asarray(root_positions, dtype=np.float64)
    if root.ndim != 2 or root.shape[1] != 3:
        raise ValueError(f"root_positions must be (T, 3), got {root.shape}")
    if rot.ndim != 4 or rot.shape[-2:] != (3, 3) or rot.shape[1] not in (1, skeleton.num_joints):
        raise ValueError(f"bone_rotations must be (T, {skeleton.num_joints}, 3, 3), got {rot.shape}")
    t = root.shape[0]
    rot = np.broadcast_to(rot, (t, skeleton.num_joints, 3, 3))
    off = np.asarray(skeleton.offsets, dtype=np.float64)  # (J, 3)
    # Rotated offsets of every bone at once: (T, J, 3)
    rotated = np.einsum("tjab,jb->tja", rot, off)
    pos = np.empty((t, skeleton.num_joints, 3))
    pos[:, skeleton.root] = root
    for c in skeleton.order[1:]:
        pos[:, c] = pos[:, skeleton.parents[c]] + rotated[:, c]
    return pos


def _mirror_by_name(names: Sequence[str]) -> tuple[int, ...]:
    """Counterpart indices from ``l_``/``r_`` name prefixes (midline joints map to themselves)."""
    index = {n: i for i, n in enumerate(names)}
    out = []
    for n in names:
        if n.startswith("l_"):
            out.append(index["r_" + n[2:]])
        elif n.startswith("r_"):
            out.append(index["l_" + n[2:]])
        else:
            out.append(index[n])
    return tuple(out)


def _make(
    name: str,
    joints: Sequence[tuple[str, int, tuple[float, float, float], str]],
    *,
    dims: int,
    fps: float,
) -> Skeleton:
    """Build a skeleton from ``(joint name, parent, rest offset, segment)`` rows."""
    names = tuple(j[0] for j in joints)
    parents = tuple(j[1] for j in joints)
    return Skeleton(
        name=name,
        joint_names=names,
        parents=parents,
        bones=tuple((p, c) for c, p in enumerate(parents) if p != -1),
        mirror=_mirror_by_name(names),
        dims=dims,
        fps=fps,
        offsets=tuple((float(o[0]), float(o[1]), float(o[2])) for _, _, o, _ in joints),
        segments=tuple(j[3] for j in joints),
    )


# SMPL neutral template: joint offsets from the parent joint (metres), SMPL joint order.
_SMPL24 = [
    ("pelvis", -1, (0.0, 0.0, 0.0), "root"),
    ("l_hip", 0, (0.05858135, -0.08228004, -0.01766408), "pelvis"),
    ("r_hip", 0, (-0.06030973, -0.09051332, -0.01354254), "pelvis"),
    ("spine1", 0, (0.00443945, 0.12440352, -0.03838522), "pelvis"),
    ("l_knee", 1, (0.04345142, -0.38646945, 0.008037), "l_thigh"),
    ("r_knee", 2, (-0.04325663, -0.38368791, -0.00484304), "r_thigh"),
    ("spine2", 3, (0.00448844, 0.1379564, 0.02682033), "abdomen"),
    ("l_ankle", 4, (-0.01479032, -0.42687458, -0.037428), "l_shin"),
    ("r_ankle", 5, (0.01905555, -0.4200455, -0.03456167), "r_shin"),
    ("spine3", 6, (-0.00226458, 0.05603239, 0.00285505), "chest"),
    ("l_foot", 7, (0.04105436, -0.06028581, 0.12204243), "l_foot"),
    ("r_foot", 8, (-0.03483987, -0.06210566, 0.13032329), "r_foot"),
    ("neck", 9, (-0.0133902, 0.21163553, -0.03346758), "chest"),
    ("l_collar", 9, (0.07170245, 0.11399969, -0.01889817), "chest"),
    ("r_collar", 9, (-0.08295366, 0.11247234, -0.02370739), "chest"),
    ("head", 12, (0.01011321, 0.08893734, 0.05040987), "head"),
    ("l_shoulder", 13, (0.12292141, 0.04520509, -0.019046), "l_clavicle"),
    ("r_shoulder", 14, (-0.11322832, 0.04685326, -0.00847207), "r_clavicle"),
    ("l_elbow", 16, (0.2553319, -0.01564902, -0.02294649), "l_upper_arm"),
    ("r_elbow", 17, (-0.26012748, -0.01436928, -0.03126873), "r_upper_arm"),
    ("l_wrist", 18, (0.26570925, 0.01269811, -0.00737473), "l_forearm"),
    ("r_wrist", 19, (-0.26910836, 0.00679372, -0.00602676), "r_forearm"),
    ("l_hand", 20, (0.08669055, -0.01063603, -0.01559429), "l_hand"),
    ("r_hand", 21, (-0.0887537, -0.00865157, -0.01010708), "r_hand"),
]

# OpenPose COCO-18 order without eyes/ears (MoMu §B.2 / D2M): rest pose from the SMPL template
# (neck, shoulders, elbows, wrists, hips, knees, ankles at SMPL joint positions; nose 10 cm in
# front of the SMPL head joint), expressed relative to the neck.
_OPENPOSE14 = [
    ("nose", 1, (0.0, 0.12, 0.10), "head"),
    ("neck", -1, (0.0, 0.0, 0.0), "root"),
    ("r_shoulder", 1, (-0.17, -0.05, 0.0), "chest"),
    ("r_elbow", 2, (-0.26, -0.015, -0.03), "r_upper_arm"),
    ("r_wrist", 3, (-0.27, 0.007, -0.006), "r_forearm"),
    ("l_shoulder", 1, (0.17, -0.05, 0.0), "chest"),
    ("l_elbow", 5, (0.26, -0.015, -0.03), "l_upper_arm"),
    ("l_wrist", 6, (0.27, 0.007, -0.006), "l_forearm"),
    ("r_hip", 1, (-0.06, -0.58, 0.03), "abdomen"),
    ("r_knee", 8, (-0.043, -0.384, -0.005), "r_thigh"),
    ("r_ankle", 9, (0.015, -0.42, -0.035), "r_shin"),
    ("l_hip", 1, (0.06, -0.58, 0.03), "abdomen"),
    ("l_knee", 11, (0.043, -0.384, -0.005), "l_thigh"),
    ("l_ankle", 12, (-0.015, -0.42, -0.035), "l_shin"),
]

# COCO-17, rooted at the nose (COCO has no centre joint).
_COCO17 = [
    ("nose", -1, (0.0, 0.0, 0.0), "root"),
    ("l_eye", 0, (0.035, 0.035, -0.02), "head"),
    ("r_eye", 0, (-0.035, 0.035, -0.02), "head"),
    ("l_ear", 1, (0.04, -0.01, -0.08), "head"),
    ("r_ear", 2, (-0.04, -0.01, -0.08), "head"),
    ("l_shoulder", 0, (0.17, -0.17, -0.10), "chest"),
    ("r_shoulder", 0, (-0.17, -0.17, -0.10), "chest"),
    ("l_elbow", 5, (0.26, -0.015, -0.03), "l_upper_arm"),
    ("r_elbow", 6, (-0.26, -0.015, -0.03), "r_upper_arm"),
    ("l_wrist", 7, (0.27, 0.007, -0.006), "l_forearm"),
    ("r_wrist", 8, (-0.27, 0.007, -0.006), "r_forearm"),
    ("l_hip", 5, (-0.11, -0.53, 0.03), "abdomen"),
    ("r_hip", 6, (0.11, -0.53, 0.03), "abdomen"),
    ("l_knee", 11, (0.043, -0.384, -0.005), "l_thigh"),
    ("r_knee", 12, (-0.043, -0.384, -0.005), "r_thigh"),
    ("l_ankle", 13, (-0.015, -0.42, -0.035), "l_shin"),
    ("r_ankle", 14, (0.015, -0.42, -0.035), "r_shin"),
]

# Dance with Melody: mean bone lengths of the real data (shared/data, 8 dances), metres.
_DWM23 = [
    ("head_back", 1, (0.0, 0.02, -0.105), "head"),
    ("head_front", 2, (0.0, 0.488, 0.05), "abdomen"),
    ("pelvis", -1, (0.0, 0.0, 0.0), "root"),
    ("r_shoulder", 2, (-0.155, 0.301, 0.0), "abdomen"),
    ("r_elbow", 3, (-0.03, -0.298, -0.02), "r_upper_arm"),
    ("r_wrist", 4, (-0.005, -0.116, 0.01), "r_forearm"),
    ("r_hand", 5, (0.0, -0.143, 0.005), "r_hand"),
    ("r_hip", 2, (-0.10, -0.156, 0.0), "pelvis"),
    ("r_knee", 7, (-0.01, -0.477, 0.02), "r_thigh"),
    ("r_ankle", 8, (0.0, -0.342, -0.01), "r_shin"),
    ("r_heel", 9, (0.0, -0.08, -0.074), "r_foot"),
    ("r_toe", 9, (-0.01, -0.07, 0.1615), "r_foot"),
    ("l_shoulder", 2, (0.155, 0.301, 0.0), "abdomen"),
    ("l_elbow", 12, (0.03, -0.298, -0.02), "l_upper_arm"),
    ("l_wrist", 13, (0.005, -0.116, 0.01), "l_forearm"),
    ("l_hand", 14, (0.0, -0.143, 0.005), "l_hand"),
    ("l_hip", 2, (0.10, -0.156, 0.0), "pelvis"),
    ("l_knee", 16, (0.01, -0.477, 0.02), "l_thigh"),
    ("l_ankle", 17, (0.0, -0.342, -0.01), "l_shin"),
    ("l_heel", 18, (0.0, -0.08, -0.074), "l_foot"),
    ("l_toe", 18, (0.01, -0.07, 0.1615), "l_foot"),
    ("l_hand_dir", 14, (0.0, -0.02, 0.05), "l_hand"),
    ("r_hand_dir", 6, (0.0, -0.02, 0.05), "r_hand"),
]

_SKELETONS: dict[str, Skeleton] = {
    "openpose14": _make("openpose14", _OPENPOSE14, dims=2, fps=60.0),
    "smpl24": _make("smpl24", _SMPL24, dims=3, fps=60.0),
    "dwm21": _make("dwm21", _DWM23[:21], dims=3, fps=25.0),
    "dwm23": _make("dwm23", _DWM23, dims=3, fps=25.0),
    "coco17": _make("coco17", _COCO17, dims=3, fps=60.0),
    "humanml22": _make("humanml22", _SMPL24[:22], dims=3, fps=20.0),
}

SKELETON_NAMES: tuple[str, ...] = tuple(_SKELETONS)


def get_skeleton(name: str) -> Skeleton:
    """The :class:`Skeleton` called ``name``; ``KeyError`` naming the valid names otherwise."""
    try:
        return _SKELETONS[name]
    except KeyError:
        raise KeyError(f"unknown skeleton {name!r}; valid names: {', '.join(SKELETON_NAMES)}") from None
