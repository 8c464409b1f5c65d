"""Joint names of the BVH rigs that animation tools export, as momu's body landmarks.

A BVH file from Mixamo, a CMU / MotionBuilder (HumanIK) conversion, Rokoko, an SMPL exporter,
Unreal's mannequin or a Blender Rigify rig's deform bones names its joints its own way
("mixamorig:LeftUpLeg", "L_Hip", "thigh_l", "DEF-thigh.L" are one body point). :func:`rig_landmarks`
reads such names as the landmarks of :mod:`momu.features.convert` (``l_hip``, ``r_wrist``, ``head``
...), so that :func:`momu.features.convert.landmark_matrix` can
pose them on a registered skeleton: joints that are the same body point map one to one and the rest
(spine points, collars, hand tips, toes) are derived as for any conversion.

A name is first normalised: anything up to its last ``:`` (a rig's namespace, ``mixamorig:``) is
dropped, then case and the separators ``_ . - space`` are. The families below differ in what a
"shoulder" is (the clavicle for Mixamo and CMU; the shoulder joint for SMPL's ``L_Shoulder``), which
the normalised names keep apart (``leftshoulder`` vs ``lshoulder``). Only body points are read;
fingers, end sites, twist bones and the spine's own joints are left out (the spine points momu needs
lie between the pelvis and the neck, :data:`momu.features.convert.DERIVED`), so rigs that count their
spine joints differently (Mixamo's ``Spine2`` is CMU's ``Spine1``) cannot be misread. Rigify is the
exception that proves it: its deform bones are all ``DEF-spine.NNN``, the pelvis (``DEF-spine``), the
neck (``.004``) and the head (``.006``) included, so those three are read by their full names.
"""

from __future__ import annotations

import re
from collections.abc import Mapping, Sequence

__all__ = ["RIG_FAMILIES", "RIG_NAMES", "normalise_joint_name", "rig_landmarks"]

RIG_FAMILIES: Mapping[str, tuple[tuple[str, str], Mapping[str, str]]] = {
    # Mixamo, CMU (cgspeed's BVH), MotionBuilder / HumanIK, Rokoko: LeftUpLeg, LeftForeArm ...
    "mixamo": (
        ("left{}", "right{}"),
        {
            "upleg": "hip",
            "leg": "knee",
            "foot": "ankle",
            "toebase": "toe",
            "toe": "toe",
            "shoulder": "collar",
            "arm": "shoulder",
            "forearm": "elbow",
            "hand": "wrist",
        },
    ),
    # SMPL's joint names as SMPL exporters write them: L_Hip, L_Foot (the toe), L_Hand (the hand tip)
    "smpl": (
        ("l{}", "r{}"),
        {
            "hip": "hip",
            "knee": "knee",
            "ankle": "ankle",
            "foot": "toe",
            "collar": "collar",
            "shoulder": "shoulder",
            "elbow": "elbow",
            "wrist": "wrist",
            "hand": "hand",
        },
    ),
    # Unreal's mannequin: thigh_l, calf_l, ball_l, upperarm_l ...
    "unreal": (
        ("{}l", "{}r"),
        {
            "thigh": "hip",
            "calf": "knee",
            "foot": "ankle",
            "ball": "toe",
            "clavicle": "collar",
            "upperarm": "shoulder",
            "lowerarm": "elbow",
            "hand": "wrist",
        },
    ),
    # Blender Rigify's deform bones: DEF-thigh.L, DEF-shin.L, DEF-upper_arm.L ... (twist halves,
    # DEF-thigh.L.001, are not read)
    "rigify": (
        ("def{}l", "def{}r"),
        {
            "thigh": "hip",
            "shin": "knee",
            "foot": "ankle",
            "toe": "toe",
            "shoulder": "collar",
            "upperarm": "shoulder",
            "forearm": "elbow",
            "hand": "wrist",
        },
    ),
}
"""Per family: the side patterns (left, right) and its limb names → the landmark's part."""

_CENTRE = {
    "hips": "pelvis",
    "pelvis": "pelvis",
    "neck": "neck",
    "neck01": "neck",
    "head": "head",
    # Rigify numbers its neck and head as spine bones (the human metarig: spine.004-.005 neck, .006 head)
    "defspine": "pelvis",
    "defspine004": "neck",
    "defspine006": "head",
}


def _names() -> dict[str, str]:
    out = dict(_CENTRE)
    for (left, right), parts in RIG_FAMILIES.values():
        for side, pattern in (("l", left), ("r", right)):
            for part, landmark in parts.items():
                name = pattern.format(part)
                if out.setdefault(name, f"{side}_{landmark}") != f"{side}_{landmark}":
                    raise ValueError(f"rig name {name!r} means two landmarks")  # caught by the tests
    return out


RIG_NAMES: Mapping[str, str] = _names()
"""Normalised joint name → landmark (every family together; no name means two body points)."""


def normalise_joint_name(name: str) -> str:
    """``mixamorig:LeftUpLeg`` → ``leftupleg``, ``L_Hip`` → ``lhip``, ``thigh_l`` → ``thighl``."""
    return re.sub(r"[\s_.\-]", "", name.rsplit(":", 1)[-1].lower())


def rig_landmarks(names: Sequence[str]) -> dict[str, int]:
    """Landmark → index in ``names`` of the joints :data:`RIG_NAMES` knows (the first of a repeated one;
    a Rigify deform bone before any other: a whole Rigify rig also has controls named ``hips``, ``neck``
    and ``head`` that do not sit on those joints)."""
    out: dict[str, int] = {}
    found = [(normalise_joint_name(name), i) for i, name in enumerate(names)]
    for key, i in sorted(found, key=lambda f: not f[0].startswith("def")):  # stable: file order within
        landmark = RIG_NAMES.get(key)
        if landmark is not None:
            out.setdefault(landmark, i)
    return out
