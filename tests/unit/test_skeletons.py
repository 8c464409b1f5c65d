"""Skeleton definitions: contract fields, trees, mirror maps, rest poses and forward kinematics."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from momu.features.skeletons import SKELETON_NAMES, Skeleton, forward_kinematics, get_skeleton

EXPECTED_JOINTS = {"openpose14": 14, "smpl24": 24, "dwm21": 21, "dwm23": 23, "coco17": 17, "humanml22": 22}


def test_contract_names_and_sizes() -> None:
    assert set(SKELETON_NAMES) == set(EXPECTED_JOINTS)
    for name, n in EXPECTED_JOINTS.items():
        sk = get_skeleton(name)
        assert isinstance(sk, Skeleton) and sk.name == name
        assert sk.num_joints == n == len(sk.parents) == len(sk.mirror)
        assert len(sk.bones) == n - 1
        assert all(sk.parents[c] == p for p, c in sk.bones)
    assert get_skeleton("openpose14").dims == 2
    assert all(get_skeleton(n).dims == 3 for n in SKELETON_NAMES if n != "openpose14")


def test_unknown_name_lists_valid_ones() -> None:
    with pytest.raises(KeyError, match="smpl24"):
        get_skeleton("smpl25")


def test_frozen() -> None:
    sk = get_skeleton("smpl24")
    with pytest.raises(AttributeError):
        sk.name = "x"  # type: ignore[misc]


def test_openpose14_order_is_mo_mu_d2m() -> None:
    sk = get_skeleton("openpose14")
    assert sk.joint_names[:2] == ("nose", "neck")
    assert sk.joint_names[2:5] == ("r_shoulder", "r_elbow", "r_wrist")
    assert sk.joint_names[8:11] == ("r_hip", "r_knee", "r_ankle")
    assert sk.root == 1


def test_smpl_order_and_parents() -> None:
    sk = get_skeleton("smpl24")
    assert sk.parents == (-1, 0, 0, 0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 9, 9, 12, 13, 14, 16, 17, 18, 19, 20, 21)
    assert sk.joint_names[15] == "head" and sk.joint_names[21] == "r_wrist"
    hml = get_skeleton("humanml22")
    assert hml.parents == sk.parents[:22] and hml.joint_names == sk.joint_names[:22]


@pytest.mark.parametrize("name", SKELETON_NAMES)
def test_mirror_is_an_involution_swapping_sides(name: str) -> None:
    sk = get_skeleton(name)
    for j, m in enumerate(sk.mirror):
        assert sk.mirror[m] == j
        a, b = sk.joint_names[j], sk.joint_names[m]
        if a.startswith("l_"):
            assert b == "r_" + a[2:]
        elif not a.startswith("r_"):
            assert m == j


@pytest.mark.parametrize("name", [n for n in SKELETON_NAMES if n != "dwm23"])
def test_rest_pose_is_left_right_symmetric_and_left_is_plus_x(name: str) -> None:
    sk = get_skeleton(name)
    rest = sk.rest_pose()
    tol = 0.02 if name in ("smpl24", "humanml22") else 1e-9  # the SMPL template is not exactly symmetric
    np.testing.assert_allclose(sk.mirror_pose(rest), rest, atol=tol)
    left = [j for j, n in enumerate(sk.joint_names) if n.startswith("l_")]
    assert np.all(rest[left, 0] > 0)


@pytest.mark.parametrize("name", SKELETON_NAMES)
def test_fk_keeps_bone_lengths(name: str) -> None:
    sk = get_skeleton(name)
    rng = np.random.default_rng(0)
    t = 5
    rot = Rotation.random(t * sk.num_joints, random_state=1).as_matrix().reshape(t, sk.num_joints, 3, 3)
    root = rng.normal(size=(t, 3))
    pos = forward_kinematics(sk, rot, root)
    assert pos.shape == (t, sk.num_joints, 3)
    np.testing.assert_allclose(pos[:, sk.root], root)
    lengths = np.stack([np.linalg.norm(pos[:, c] - pos[:, p], axis=-1) for p, c in sk.bones], axis=1)
    np.testing.assert_allclose(lengths, np.broadcast_to(sk.bone_lengths, lengths.shape), rtol=1e-12)


def test_fk_identity_translates_rest_pose() -> None:
    sk = get_skeleton("dwm21")
    rest = sk.rest_pose()
    pos = forward_kinematics(sk, np.eye(3)[None, None], np.array([[1.0, 2.0, 3.0]]))
    np.testing.assert_allclose(pos[0], rest + [1.0, 2.0, 3.0])
    # a 90 degree yaw of every bone about the root turns +Z (forward) into +X
    yaw = Rotation.from_euler("y", 90, degrees=True).as_matrix()[None, None]
    turned = forward_kinematics(sk, yaw, np.zeros((1, 3)))[0]
    np.testing.assert_allclose(turned[:, 0], rest[:, 2], atol=1e-12)


def test_fk_rejects_bad_shapes() -> None:
    sk = get_skeleton("smpl24")
    with pytest.raises(ValueError, match="bone_rotations"):
        forward_kinematics(sk, np.zeros((2, 5, 3, 3)), np.zeros((2, 3)))
    with pytest.raises(ValueError, match="root_positions"):
        forward_kinematics(sk, np.zeros((2, 24, 3, 3)), np.zeros((2, 2)))


def test_skeleton_validation() -> None:
    with pytest.raises(ValueError, match="involution"):
        Skeleton(
            "bad", ("a", "b"), (-1, 0), ((0, 1),), (1, 1), 3, 30.0, ((0, 0, 0), (0, 1, 0)), ("root", "head")
        )
    with pytest.raises(ValueError, match="root"):
        Skeleton("bad", ("a", "b"), (-1, -1), (), (0, 1), 3, 30.0, ((0, 0, 0), (0, 1, 0)), ("root", "head"))


def test_dwm21_bones_follow_the_authors_drawing(shared_data) -> None:  # type: ignore[no-untyped-def]
    """Every real-joint edge of the README's bone list is a bone; rest lengths near the data's means."""
    import json

    sk = get_skeleton("dwm21")
    edges = {frozenset(b) for b in sk.bones}
    for chain in ([0, 1], [3, 4, 5, 6], [12, 13, 14, 15], [2, 7, 8, 9], [2, 16, 17, 18]):
        for a, b in zip(chain[:-1], chain[1:], strict=True):
            assert frozenset((a, b)) in edges
    files = sorted((shared_data / "dance_with_melody").glob("*/skeletons.json"))
    assert files
    pts = np.concatenate([np.asarray(json.loads(f.read_text())["skeletons"])[:, :21] for f in files]) / 100.0
    real = np.stack([np.linalg.norm(pts[:, c] - pts[:, p], axis=-1).mean() for p, c in sk.bones])
    np.testing.assert_allclose(sk.bone_lengths, real, atol=0.05)
