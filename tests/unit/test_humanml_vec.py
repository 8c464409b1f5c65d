"""HumanML3D's 263-d features from 22 joints (what T2M's evaluator reads)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from momu.features.humanml_vec import (
    FEATURE_DIM,
    KINEMATIC_CHAIN,
    RAW_OFFSETS,
    humanml_features,
    recover_from_ric,
)
from momu.features.skeletons import forward_kinematics, get_skeleton


def _walk(frames: int = 60, seed: int = 0) -> np.ndarray:
    """A rigid humanml22 motion: every joint rotating smoothly, the root turning and travelling."""
    sk = get_skeleton("humanml22")
    rng = np.random.default_rng(seed)
    t = np.linspace(0, 3, frames)[:, None]
    phase = rng.uniform(0, 2 * np.pi, size=(1, 22, 3))
    rotvec = 0.35 * np.sin(1.7 * t[..., None] + phase)
    rotvec[:, 0, 1] += 0.8 * t[:, 0]  # the body turns about Y
    rots = Rotation.from_rotvec(rotvec.reshape(-1, 3)).as_matrix().reshape(frames, 22, 3, 3)
    root = np.concatenate([0.6 * t, 0.95 + 0.03 * np.sin(5 * t), 0.4 * t], axis=1)
    return forward_kinematics(sk, rots, root)


def _rot_y(angle: float) -> np.ndarray:
    return Rotation.from_rotvec([0.0, angle, 0.0]).as_matrix()


def test_layout_and_invariance_to_where_the_motion_is_and_faces() -> None:
    m = _walk()
    f = humanml_features(m)
    assert f.shape == (59, FEATURE_DIM) and np.all(np.isfinite(f))
    moved = m @ _rot_y(2.1).T + np.array([4.0, 0.3, -2.0])
    np.testing.assert_allclose(humanml_features(moved), f, atol=1e-9)
    assert not np.allclose(humanml_features(m[::-1].copy()), f[::-1])  # but it does see the motion


def test_root_and_ric_parts_recover_the_facing_normalised_motion() -> None:
    m = _walk(seed=1)
    rec = recover_from_ric(humanml_features(m))
    assert rec.shape == (59, 22, 3)
    dist = np.linalg.norm(rec[:, :, None] - rec[:, None], axis=-1)
    np.testing.assert_allclose(dist, np.linalg.norm(m[:-1, :, None] - m[:-1, None], axis=-1), atol=1e-9)
    np.testing.assert_allclose(rec[..., 1], m[:-1, :, 1] - m[..., 1].min(), atol=1e-9)  # on the floor
    np.testing.assert_allclose(rec[0, 0, [0, 2]], 0.0, atol=1e-12)  # starts at the origin
    # already normalised motion is a fixed point (up to the floor of the shorter clip)
    again = recover_from_ric(humanml_features(rec))
    np.testing.assert_allclose(again[..., [0, 2]], rec[:-1][..., [0, 2]], atol=1e-9)


def test_rotations_point_each_raw_bone_along_the_real_bone() -> None:
    """The 6D rotations, composed down T2M's chains from the recovered root rotation, take T2M's raw
    bone directions onto the recovered bones."""
    f = humanml_features(_walk(seed=2))
    rec = recover_from_ric(f)
    angle = np.concatenate([[0.0], np.cumsum(f[:-1, 0])])
    root = np.stack([_rot_y(-2 * a) for a in angle])  # recover's root quaternion (cos a, 0, sin a, 0)⁻¹
    six = np.concatenate([np.zeros((len(f), 1, 6)), f[:, 67:193].reshape(len(f), 21, 6)], axis=1)
    c0, c1 = six[..., :3], six[..., 3:]
    local = np.stack([c0, c1, np.cross(c0, c1)], axis=-1)  # columns of each rotation matrix
    for chain in KINEMATIC_CHAIN:
        rot = np.linalg.inv(root)  # the chain starts from the (inverse-recovered) root rotation
        for parent, child in zip(chain[:-1], chain[1:], strict=False):
            rot = rot @ local[:, child]
            bone = rec[:, child] - rec[:, parent]
            want = bone / np.linalg.norm(bone, axis=-1, keepdims=True)
            np.testing.assert_allclose(rot @ RAW_OFFSETS[child], want, atol=1e-6)


def test_foot_contacts_and_velocities() -> None:
    m = np.repeat(_walk(seed=3)[:1], 10, axis=0)
    m[5:, 8] += np.linspace(0, 1.0, 5)[:, None] * np.array([1.0, 0.0, 0.0])  # the right ankle slides
    f = humanml_features(m)
    contacts = f[:, -4:]  # left ankle, left foot, right ankle, right foot
    np.testing.assert_array_equal(contacts[:, [0, 1, 3]], 1.0)
    assert contacts[:4, 2].all() and not contacts[5:, 2].any()
    np.testing.assert_allclose(f[:4, 1:3], 0.0, atol=1e-12)  # the root does not move
    with pytest.raises(ValueError, match=r"\(T, 22, 3\)"):
        humanml_features(np.zeros((10, 24, 3)))
    with pytest.raises(ValueError, match="non-finite"):
        humanml_features(np.full((10, 22, 3), np.nan))
