"""BVH rigs exported by animation tools (Mixamo, CMU, SMPL exporters, Unreal, Blender Rigify) read as a
body."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from momu.data.motion_files import read_motion_file
from momu.data.synth.dataset import SynthConfig, generate_clip
from momu.export import write_bvh
from momu.features.rig_names import RIG_NAMES, normalise_joint_name, rig_landmarks
from momu.features.skeletons import get_skeleton

# smpl24's joints as each tool names them (None: a joint that rig has under a name momu does not read)
RIGS = {
    "mixamo": {
        "pelvis": "mixamorig:Hips", "l_hip": "mixamorig:LeftUpLeg", "r_hip": "mixamorig:RightUpLeg",
        "spine1": "mixamorig:Spine", "l_knee": "mixamorig:LeftLeg", "r_knee": "mixamorig:RightLeg",
        "spine2": "mixamorig:Spine1", "l_ankle": "mixamorig:LeftFoot", "r_ankle": "mixamorig:RightFoot",
        "spine3": "mixamorig:Spine2", "l_foot": "mixamorig:LeftToeBase", "r_foot": "mixamorig:RightToeBase",
        "neck": "mixamorig:Neck", "l_collar": "mixamorig:LeftShoulder", "r_collar": "mixamorig:RightShoulder",
        "head": "mixamorig:Head", "l_shoulder": "mixamorig:LeftArm", "r_shoulder": "mixamorig:RightArm",
        "l_elbow": "mixamorig:LeftForeArm", "r_elbow": "mixamorig:RightForeArm",
        "l_wrist": "mixamorig:LeftHand", "r_wrist": "mixamorig:RightHand",
        "l_hand": "mixamorig:LeftHandMiddle1", "r_hand": "mixamorig:RightHandMiddle1",
    },
    "smpl": {
        "pelvis": "Pelvis", "l_hip": "L_Hip", "r_hip": "R_Hip", "spine1": "Spine1", "l_knee": "L_Knee",
        "r_knee": "R_Knee", "spine2": "Spine2", "l_ankle": "L_Ankle", "r_ankle": "R_Ankle",
        "spine3": "Spine3", "l_foot": "L_Foot", "r_foot": "R_Foot", "neck": "Neck", "l_collar": "L_Collar",
        "r_collar": "R_Collar", "head": "Head", "l_shoulder": "L_Shoulder", "r_shoulder": "R_Shoulder",
        "l_elbow": "L_Elbow", "r_elbow": "R_Elbow", "l_wrist": "L_Wrist", "r_wrist": "R_Wrist",
        "l_hand": "L_Hand", "r_hand": "R_Hand",
    },
    "unreal": {
        "pelvis": "pelvis", "l_hip": "thigh_l", "r_hip": "thigh_r", "spine1": "spine_01",
        "l_knee": "calf_l", "r_knee": "calf_r", "spine2": "spine_02", "l_ankle": "foot_l",
        "r_ankle": "foot_r", "spine3": "spine_03", "l_foot": "ball_l", "r_foot": "ball_r",
        "neck": "neck_01", "l_collar": "clavicle_l",
        "r_collar": "clavicle_r", "head": "head", "l_shoulder": "upperarm_l", "r_shoulder": "upperarm_r",
        "l_elbow": "lowerarm_l", "r_elbow": "lowerarm_r", "l_wrist": "hand_l", "r_wrist": "hand_r",
        "l_hand": "middle_01_l", "r_hand": "middle_01_r",
    },
    "rigify": {
        "pelvis": "DEF-spine", "l_hip": "DEF-thigh.L", "r_hip": "DEF-thigh.R", "spine1": "DEF-spine.001",
        "l_knee": "DEF-shin.L", "r_knee": "DEF-shin.R", "spine2": "DEF-spine.002", "l_ankle": "DEF-foot.L",
        "r_ankle": "DEF-foot.R", "spine3": "DEF-spine.003", "l_foot": "DEF-toe.L", "r_foot": "DEF-toe.R",
        "neck": "DEF-spine.004", "l_collar": "DEF-shoulder.L", "r_collar": "DEF-shoulder.R",
        "head": "DEF-spine.006", "l_shoulder": "DEF-upper_arm.L", "r_shoulder": "DEF-upper_arm.R",
        "l_elbow": "DEF-forearm.L", "r_elbow": "DEF-forearm.R", "l_wrist": "DEF-hand.L",
        "r_wrist": "DEF-hand.R", "l_hand": "DEF-f_middle.01.L", "r_hand": "DEF-f_middle.01.R",
    },
}  # fmt: skip


@pytest.fixture(scope="module")
def dance(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, np.ndarray, float]:
    """A synthetic smpl24 dance written by momu in centimetres, as Mixamo and most tools write BVH, and
    the joint positions its own names read back to."""
    cfg = SynthConfig(num_clips=1, min_seconds=2.0, max_seconds=2.0, skeleton="smpl24")
    clip = generate_clip(cfg, 0)
    path = write_bvh(
        tmp_path_factory.mktemp("rig") / "smpl.bvh", clip.motion, clip.fps, "smpl24", scale=100.0
    )
    own = read_motion_file(path)
    assert own.skeleton == "smpl24"
    return path, own.motion, clip.fps


def _renamed(src: Path, dst: Path, names: dict[str, str]) -> Path:
    """``src`` with its joints renamed (momu's in-between joints, ``pelvis_to_l_hip``, keep their names:
    joints a rig has that momu does not read)."""
    text = re.sub(
        r"^(\s*(?:ROOT|JOINT)\s+)(\S+)",
        lambda m: m.group(1) + names.get(m.group(2), m.group(2)),
        src.read_text(),
        flags=re.M,
    )
    dst.write_text(text)
    return dst


@pytest.mark.parametrize("rig", sorted(RIGS))
def test_a_tools_rig_reads_as_the_same_body(
    rig: str, dance: tuple[Path, np.ndarray, float], tmp_path: Path
) -> None:
    path, own, fps = dance
    got = read_motion_file(_renamed(path, tmp_path / f"{rig}.bvh", RIGS[rig]))
    assert got.skeleton == "smpl24" and got.fps == pytest.approx(fps)
    j = {n: i for i, n in enumerate(get_skeleton("smpl24").joint_names)}
    tips = rig == "smpl"  # SMPL names its hand tips (L_Hand); the others' are finger joints
    read = [n for n in j if not n.startswith("spine") and (tips or n not in ("l_hand", "r_hand"))]
    np.testing.assert_allclose(got.motion[:, [j[n] for n in read]], own[:, [j[n] for n in read]], atol=1e-6)
    # the spine lies between the pelvis and the neck, a hand tip at its wrist (momu.features.convert)
    for name, w in (("spine1", 0.25), ("spine2", 0.5), ("spine3", 0.75)):
        expected = (1 - w) * own[:, j["pelvis"]] + w * own[:, j["neck"]]
        np.testing.assert_allclose(got.motion[:, j[name]], expected, atol=1e-6)
    if not tips:
        np.testing.assert_allclose(got.motion[:, j["l_hand"]], own[:, j["l_wrist"]], atol=1e-6)


def test_names_are_normalised_and_no_name_means_two_body_points() -> None:
    assert normalise_joint_name("mixamorig1:LeftUpLeg") == "leftupleg"
    assert normalise_joint_name("upperarm_l") == "upperarml"
    # a "shoulder" is the clavicle for Mixamo and CMU, the shoulder joint for SMPL
    assert RIG_NAMES["leftshoulder"] == "l_collar"
    assert RIG_NAMES["lshoulder"] == "l_shoulder"
    # spine joints are never read: rigs count them differently (Mixamo's Spine2 is CMU's Spine1)
    assert not any(name.startswith("spine") for name in RIG_NAMES)
    assert rig_landmarks(["Hips", "LeftUpLeg", "hips", "LeftHandIndex1"]) == {"pelvis": 0, "l_hip": 1}
    # Rigify's neck and head are spine bones by number; its twist halves are not joints of the body
    assert rig_landmarks(["DEF-spine.004", "DEF-spine.006", "DEF-spine.005", "DEF-thigh.L.001"]) == {
        "neck": 0,
        "head": 1,
    }
    # a whole Rigify rig's controls "hips", "neck", "head" give way to its deform bones
    assert rig_landmarks(["hips", "neck", "DEF-spine", "DEF-spine.004", "head"]) == {
        "pelvis": 2,
        "neck": 3,
        "head": 4,
    }


def test_a_rig_without_a_body_fails_in_one_line_naming_what_it_lacks(
    dance: tuple[Path, np.ndarray, float], tmp_path: Path
) -> None:
    path, _, _ = dance
    names = dict(RIGS["mixamo"])
    names["head"] = "mixamorig:HeadTop_End"
    with pytest.raises(ValueError, match=r"nohead.bvh: .*no source for \['head'\].*rename them") as info:
        read_motion_file(_renamed(path, tmp_path / "nohead.bvh", names))
    assert "\n" not in str(info.value)


def test_a_z_up_rig_is_turned_to_y_up(dance: tuple[Path, np.ndarray, float], tmp_path: Path) -> None:
    """Blender and Unreal export Z up: the same dance written standing along Z reads as the Y-up one."""
    path, own, fps = dance
    z_up = np.stack([own[..., 0], -own[..., 2], own[..., 1]], axis=-1)  # Y up -> Z up (a rotation)
    written = write_bvh(tmp_path / "z.bvh", z_up, fps, "smpl24", scale=100.0)
    got = read_motion_file(_renamed(written, tmp_path / "unreal_z.bvh", RIGS["unreal"]))
    reference = read_motion_file(_renamed(path, tmp_path / "unreal_y.bvh", RIGS["unreal"]))
    np.testing.assert_allclose(got.motion, reference.motion, atol=2e-3)
