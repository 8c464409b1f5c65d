"""Bone lengths, directions and their inverse, and MoMu App. E bone-length correction."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from momu.features.bones import (
    bone_directions,
    bone_lengths,
    bone_order,
    correct_bone_lengths,
    mean_bone_lengths,
    positions_from_directions,
    root_joint,
)
from momu.features.skeletons import get_skeleton

# A 2D "T": root 0 with children 1 (up) and 2 (right); 3 is a child of 2.
BONES = [(0, 1), (0, 2), (2, 3)]


def t_pose(length_23: float = 1.0) -> np.ndarray:
    return np.array([[[0.0, 0.0], [0.0, 2.0], [1.0, 0.0], [1.0 + length_23, 0.0]]])


def test_lengths_and_directions_hand_computed() -> None:
    m = t_pose()
    np.testing.assert_allclose(bone_lengths(m, BONES), [[2.0, 1.0, 1.0]])
    np.testing.assert_allclose(bone_directions(m, BONES), [[[0, 1], [1, 0], [1, 0]]])
    clips = [np.concatenate([t_pose(1.0), t_pose(3.0)]), t_pose(2.0)]
    np.testing.assert_allclose(mean_bone_lengths(clips, BONES), [2.0, 1.0, 2.0])
    np.testing.assert_allclose(mean_bone_lengths(clips[0], BONES), [2.0, 1.0, 2.0])


def test_zero_length_bone_has_a_zero_direction() -> None:
    m = np.zeros((1, 4, 2))
    assert np.all(bone_directions(m, BONES) == 0)


def test_positions_from_directions_inverts_with_the_given_root() -> None:
    m = t_pose() + np.array([5.0, -1.0])
    back = positions_from_directions(bone_directions(m, BONES), bone_lengths(m, BONES)[0], BONES, m[:, 0])
    np.testing.assert_allclose(back, m, atol=1e-12)
    # Per-frame lengths are accepted too, and unnormalised directions are normalised.
    dirs = bone_directions(m, BONES) * 7.0
    back2 = positions_from_directions(dirs, bone_lengths(m, BONES), BONES, m[:, 0])
    np.testing.assert_allclose(back2, m, atol=1e-12)


def test_bone_order_puts_parents_first_whatever_the_input_order() -> None:
    shuffled = [(2, 3), (0, 1), (0, 2)]
    order = bone_order(shuffled)
    assert order.index(2) < order.index(0)  # (0, 2) before (2, 3)
    m = t_pose()
    back = positions_from_directions(
        bone_directions(m, shuffled), bone_lengths(m, shuffled)[0], shuffled, m[:, 0]
    )
    np.testing.assert_allclose(back, m, atol=1e-12)


def test_correct_bone_lengths_clamps_only_bones_over_the_threshold() -> None:
    mean = np.array([2.0, 1.0, 1.0])
    # Bone (2, 3) is 1.2x its mean: kept (threshold 1.3x).
    kept = correct_bone_lengths(t_pose(1.2), BONES, mean)
    np.testing.assert_allclose(kept, t_pose(1.2), atol=1e-12)
    # Bone (2, 3) is 2x its mean: set to the mean, same direction.
    fixed = correct_bone_lengths(t_pose(2.0), BONES, mean)
    np.testing.assert_allclose(fixed, t_pose(1.0), atol=1e-12)
    # An over-long inner bone moves its subtree rigidly: (0, 2) stretched to 3 -> back to 1.
    m = np.array([[[0.0, 0.0], [0.0, 2.0], [3.0, 0.0], [4.0, 0.0]]])
    out = correct_bone_lengths(m, BONES, mean)
    np.testing.assert_allclose(out, [[[0, 0], [0, 2], [1, 0], [2, 0]]], atol=1e-12)
    assert np.all(bone_lengths(out, BONES) <= 1.3 * mean + 1e-12)
    # A different ratio changes the decision.
    np.testing.assert_allclose(correct_bone_lengths(t_pose(1.2), BONES, mean, ratio=1.1), t_pose(1.0))


def test_correct_bone_lengths_keeps_joints_outside_the_tree() -> None:
    m = np.concatenate([t_pose(3.0), np.array([[[9.0, 9.0]]])], axis=1)  # joint 4 is in no bone
    out = correct_bone_lengths(m, BONES, [2.0, 1.0, 1.0])
    assert out.shape == m.shape
    np.testing.assert_allclose(out[0, 4], [9.0, 9.0])
    np.testing.assert_allclose(out[0, 3], [2.0, 0.0])


def test_on_a_real_skeleton_layout() -> None:
    sk = get_skeleton("smpl24")
    rest = sk.rest_pose()[None]
    np.testing.assert_allclose(bone_lengths(rest, sk.bones)[0], sk.bone_lengths, atol=1e-12)
    assert root_joint(sk.bones) == sk.root
    stretched = rest.copy()
    stretched[:, sk.index("l_wrist")] += np.array([0.5, 0.0, 0.0])  # forearm grows by ~0.5 m
    out = correct_bone_lengths(stretched, sk.bones, sk.bone_lengths)
    np.testing.assert_allclose(bone_lengths(out, sk.bones)[0], sk.bone_lengths, atol=1e-9)


def test_torch_inputs_are_differentiable() -> None:
    m = torch.tensor(t_pose(2.0), requires_grad=True)
    lengths = bone_lengths(m, BONES)
    assert isinstance(lengths, torch.Tensor)
    torch.testing.assert_close(lengths.detach(), torch.tensor([[2.0, 1.0, 2.0]], dtype=torch.float64))
    out = correct_bone_lengths(m, BONES, [2.0, 1.0, 1.0])
    assert isinstance(out, torch.Tensor)
    torch.testing.assert_close(out.detach(), torch.tensor(t_pose(1.0)))
    out.sum().backward()
    assert m.grad is not None and torch.isfinite(m.grad).all()


def test_bad_bones_and_shapes_are_rejected() -> None:
    with pytest.raises(ValueError, match="itself"):
        bone_lengths(t_pose(), [(0, 0)])
    with pytest.raises(ValueError, match="range"):
        bone_lengths(t_pose(), [(0, 9)])
    with pytest.raises(ValueError, match="more than one bone"):
        root_joint([(0, 1), (2, 1)])
    with pytest.raises(ValueError, match="root"):
        root_joint([(0, 1), (1, 0)])
    with pytest.raises(ValueError, match="not connected"):
        bone_order([(0, 1), (2, 3)], root=0)
    with pytest.raises(ValueError, match="root"):
        positions_from_directions(np.zeros((2, 3, 2)), [1, 1, 1], BONES, np.zeros((3, 2)))
    with pytest.raises(ValueError, match="lengths"):
        positions_from_directions(np.zeros((2, 3, 2)), [1, 1], BONES, np.zeros((2, 2)))
    with pytest.raises(ValueError, match="mean_lengths"):
        correct_bone_lengths(t_pose(), BONES, [1.0, 1.0])
