"""Skeleton converters: joint maps between registered skeletons, and 3D → 2D projection.

A conversion is a fixed linear map: every target joint is a weighted mean of source joints
(``convert_motion(x, "smpl24", "openpose14")``). It goes through named body *landmarks*: each skeleton
says which landmark each of its joints is (:data:`JOINT_LANDMARKS`), and landmarks a source lacks are
derived from others by the rules of :data:`DERIVED` (a neck is the mid-shoulder point, a pelvis the
mid-hip point, a spine point lies between pelvis and neck, a hand without fingers is its wrist ...).
Joints that are the same body point map one to one; derived ones are approximations, good enough for
what momu uses them for (a motion's rhythm, a stick figure), not for biomechanics. A target joint that
no rule can reach is an error naming it.

2D targets (``openpose14``) are image keypoints: the converted 3D motion is stood on the floor (its
lowest 1 % of joint heights at Y = 0), centred on its mean root position, and projected by the pinhole
camera of the synthetic dataset (:func:`momu.data.synth.motion.project`, 1280 × 720 px, 5 m away), the
camera the 2D training data was made with.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from momu.features.skeletons import get_skeleton

__all__ = [
    "JOINT_LANDMARKS",
    "DERIVED",
    "conversion_matrix",
    "landmark_matrix",
    "can_convert",
    "convert_motion",
    "floor_offset",
    "stand_on_floor",
]

_LIMBS = ("shoulder", "elbow", "wrist", "hip", "knee", "ankle")


def _sided(*names: str) -> dict[str, str]:
    return {f"{s}_{n}": f"{s}_{n}" for n in names for s in ("l", "r")}


_DWM21 = {
    "pelvis": "pelvis",
    "head_front": "head",
    "head_back": "head_back",
    **_sided(*_LIMBS, "hand", "heel", "toe"),
}

_SMPL_BODY = {
    "pelvis": "pelvis",
    "spine1": "spine1",
    "spine2": "spine2",
    "spine3": "spine3",
    "neck": "neck",
    "head": "head",
    **_sided("collar", *_LIMBS),
    "l_foot": "l_toe",
    "r_foot": "r_toe",
}

JOINT_LANDMARKS: Mapping[str, Mapping[str, str]] = {
    "openpose14": {"nose": "nose", "neck": "neck", **_sided(*_LIMBS)},
    "coco17": {"nose": "nose", **_sided("eye", "ear", *_LIMBS)},
    "smpl24": {**_SMPL_BODY, **_sided("hand")},
    "humanml22": _SMPL_BODY,  # SMPL's first 22 joints: no hand tips
    # Dance with Melody: the "head" points sit at the head (0.49 m above the pelvis); its "hand"
    # points are the hand ends, "wrist" the wrists (momu.features.skeletons).
    "dwm21": _DWM21,
    "dwm23": {**_DWM21, **_sided("hand_dir")},
}
"""Which body landmark each joint of a skeleton is (joint name → landmark name)."""


DERIVED: Mapping[str, tuple[Mapping[str, float], ...]] = {
    "neck": ({"l_shoulder": 0.5, "r_shoulder": 0.5},),
    "pelvis": ({"l_hip": 0.5, "r_hip": 0.5},),
    "head": ({"nose": 1.0}, {"head_back": 1.0}),
    "nose": ({"head": 1.0},),
    "head_back": ({"head": 1.0},),
    "spine1": ({"pelvis": 0.75, "neck": 0.25},),
    "spine2": ({"pelvis": 0.5, "neck": 0.5},),
    "spine3": ({"pelvis": 0.25, "neck": 0.75},),
    **{
        f"{s}_{name}": rules
        for s in "lr"
        for name, rules in {
            "collar": ({"neck": 0.5, f"{s}_shoulder": 0.5},),
            "hand": ({f"{s}_wrist": 1.0},),
            "hand_dir": ({f"{s}_hand": 1.0}, {f"{s}_wrist": 1.0}),
            "wrist": ({f"{s}_hand": 1.0},),
            "toe": ({f"{s}_ankle": 1.0},),
            "heel": ({f"{s}_ankle": 1.0},),
            "ankle": ({f"{s}_heel": 0.5, f"{s}_toe": 0.5},),
            "eye": ({"nose": 1.0}, {"head": 1.0}),
            "ear": ({"head": 1.0}, {"nose": 1.0}),
        }.items()
    },
}
"""How a landmark a skeleton lacks is made from others: alternatives, the first that resolves wins."""


def _resolve(landmark: str, have: Mapping[str, int], depth: int = 0) -> dict[int, float] | None:
    """Source-joint weights of ``landmark`` (``have``: landmark → source joint), or None."""
    if landmark in have:
        return {have[landmark]: 1.0}
    if depth > 4:
        return None
    for rule in DERIVED.get(landmark, ()):
        out: dict[int, float] = {}
        for part, w in rule.items():
            sub = _resolve(part, have, depth + 1)
            if sub is None:
                break
            for j, v in sub.items():
                out[j] = out.get(j, 0.0) + w * v
        else:
            return out
    return None


def conversion_matrix(source: str, target: str) -> np.ndarray:
    """``(J_target, J_source)`` weights: ``target_motion = W @ source_motion`` (rows sum to 1).

    Raises:
        KeyError: unknown skeleton.
        ValueError: a target joint no landmark rule reaches from ``source`` (the message names them).
    """
    src = get_skeleton(source)
    get_skeleton(target)
    if source not in JOINT_LANDMARKS or target not in JOINT_LANDMARKS:
        missing = source if source not in JOINT_LANDMARKS else target
        raise ValueError(
            f"skeleton {missing!r} has no landmark table; convertible: {sorted(JOINT_LANDMARKS)}"
        )
    have = {JOINT_LANDMARKS[source][n]: j for j, n in enumerate(src.joint_names)}
    try:
        return landmark_matrix(have, src.num_joints, target)
    except ValueError as exc:
        raise ValueError(f"cannot convert skeleton {source!r} to {target!r}: {exc}") from None


def landmark_matrix(have: Mapping[str, int], num_source: int, target: str) -> np.ndarray:
    """``(J_target, num_source)`` weights posing ``target``'s joints from source joints of known
    landmarks (``have``: landmark → source joint index; other source joints get no weight).

    Raises:
        KeyError: unknown ``target`` skeleton.
        ValueError: ``target`` has no landmark table, or joints no rule reaches (``no source for [...]``).
    """
    tgt = get_skeleton(target)
    if target not in JOINT_LANDMARKS:
        raise ValueError(f"skeleton {target!r} has no landmark table; convertible: {sorted(JOINT_LANDMARKS)}")
    w = np.zeros((tgt.num_joints, num_source))
    unreachable = []
    for i, name in enumerate(tgt.joint_names):
        weights = _resolve(JOINT_LANDMARKS[target][name], have)
        if weights is None:
            unreachable.append(name)
            continue
        for j, v in weights.items():
            w[i, j] = v
    if unreachable:
        raise ValueError(f"no source for {unreachable}")
    return w


def can_convert(source: str, target: str) -> bool:
    """Whether :func:`convert_motion` can map ``source`` motion to ``target`` (never 2D to 3D)."""
    try:
        if get_skeleton(source).dims == 2 and get_skeleton(target).dims == 3:
            return False
        conversion_matrix(source, target)
    except (KeyError, ValueError):
        return False
    return True


def floor_offset(motion: np.ndarray, root: int) -> np.ndarray:
    """The ``(3,)`` translation that puts 3D motion's lowest 1 % of joint heights at Y = 0 and its mean
    root X, Z at 0 (:func:`stand_on_floor`)."""
    x = np.asarray(motion, dtype=np.float64)
    offset = np.zeros(3)
    offset[1] = -np.percentile(x[..., 1], 1.0)
    offset[[0, 2]] = -x[:, root, [0, 2]].mean(axis=0)
    return offset


def stand_on_floor(motion: np.ndarray, root: int) -> np.ndarray:
    """3D motion moved so its lowest 1 % of joint heights are at Y = 0 and its mean root X, Z at 0."""
    return np.asarray(motion, dtype=np.float64) + floor_offset(motion, root)


def convert_motion(
    motion: np.ndarray, source: str, target: str, *, trajectory: np.ndarray | None = None
) -> np.ndarray:
    """``(T, J_s, D)`` motion of skeleton ``source`` as ``(T, J_t, D_t)`` motion of ``target``.

    3D → 3D and 2D → 2D map joints (:func:`conversion_matrix`); 3D → 2D also projects (module
    docstring); 2D → 3D is refused (depth cannot be recovered by a joint map). ``trajectory`` (root path
    of root-centred 3D motion) is added first.
    """
    src, tgt = get_skeleton(source), get_skeleton(target)
    x = np.asarray(motion, dtype=np.float64)
    if x.ndim != 3 or x.shape[1] != src.num_joints or x.shape[2] != src.dims:
        raise ValueError(
            f"motion of skeleton {source!r} must be (T, {src.num_joints}, {src.dims}), got {x.shape}"
        )
    if src.dims == 2 and tgt.dims == 3:
        raise ValueError(f"cannot convert 2D keypoints ({source!r}) to a 3D skeleton ({target!r})")
    if trajectory is not None:
        if src.dims != 3:
            raise ValueError("trajectory is only meaningful for 3D motion")
        x = x + np.asarray(trajectory, dtype=np.float64)[:, None, :]
    out = np.einsum("ij,tjd->tid", conversion_matrix(source, target), x)
    if src.dims == 3 and tgt.dims == 2:
        from momu.data.synth.motion import CameraConfig, project

        root = tgt.root
        out = project(stand_on_floor(out, root), CameraConfig())
    return out.astype(np.float32)
