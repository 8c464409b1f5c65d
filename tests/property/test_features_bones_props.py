"""Properties of the bone helpers on rigid motion built by rotating fixed skeletons (forward kinematics)."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from momu.features.bones import (
    bone_directions,
    bone_lengths,
    correct_bone_lengths,
    mean_bone_lengths,
    positions_from_directions,
)
from momu.features.skeletons import forward_kinematics, get_skeleton

LAYOUTS = ["smpl24", "dwm21", "coco17", "humanml22", "openpose14"]


def rotations(angles: np.ndarray) -> np.ndarray:
    """Rotation matrices ``(..., 3, 3)`` from ``(..., 3)`` Euler angles (x, then y, then z)."""
    cx, cy, cz = np.cos(angles).T
    sx, sy, sz = np.sin(angles).T
    one, zero = np.ones_like(cx), np.zeros_like(cx)
    rx = np.stack([one, zero, zero, zero, cx, -sx, zero, sx, cx], -1).reshape(*cx.shape, 3, 3)
    ry = np.stack([cy, zero, sy, zero, one, zero, -sy, zero, cy], -1).reshape(*cx.shape, 3, 3)
    rz = np.stack([cz, -sz, zero, sz, cz, zero, zero, zero, one], -1).reshape(*cx.shape, 3, 3)
    return rz @ ry @ rx


@st.composite
def rigid_motion(draw: st.DrawFn) -> tuple[str, np.ndarray]:
    """FK motion of a fixed skeleton: random per-bone rotations and root path, constant bone lengths.

    The 2D layout (openpose14) rotates bones about z only and keeps x, y: in-plane rigid motion.
    """
    name = draw(st.sampled_from(LAYOUTS))
    sk = get_skeleton(name)
    t = draw(st.integers(1, 6))
    angle = st.floats(-np.pi, np.pi, allow_nan=False, width=64)
    angles = draw(arrays(np.float64, (sk.num_joints, t, 3), elements=angle))
    if sk.dims == 2:
        angles[..., :2] = 0.0
    rot = np.swapaxes(rotations(angles.reshape(-1, 3)).reshape(sk.num_joints, t, 3, 3), 0, 1)  # (T, J, 3, 3)
    root = draw(arrays(np.float64, (t, 3), elements=st.floats(-5, 5, width=64)))
    return name, forward_kinematics(sk, rot, root)[..., : sk.dims]


def rest_lengths(name: str) -> np.ndarray:
    """Bone lengths of the layout's rest pose in its own dimensions (2D: in the x–y plane)."""
    sk = get_skeleton(name)
    return bone_lengths(sk.rest_pose()[None, :, : sk.dims], sk.bones)[0]


@settings(deadline=None)
@given(rigid_motion())
def test_bone_lengths_are_exact_on_rigid_motion(case: tuple[str, np.ndarray]) -> None:
    name, motion = case
    sk = get_skeleton(name)
    lengths = bone_lengths(motion, sk.bones)
    np.testing.assert_allclose(lengths, np.broadcast_to(rest_lengths(name), lengths.shape), atol=1e-9)
    np.testing.assert_allclose(mean_bone_lengths(motion, sk.bones), rest_lengths(name), atol=1e-9)
    np.testing.assert_allclose(np.linalg.norm(bone_directions(motion, sk.bones), axis=-1), 1.0, atol=1e-9)


@settings(deadline=None)
@given(rigid_motion())
def test_directional_encoding_round_trips_rigid_motion(case: tuple[str, np.ndarray]) -> None:
    name, motion = case
    sk = get_skeleton(name)
    dirs = bone_directions(motion, sk.bones)
    # Decoded with the mean bone lengths, as MoMu's directional-vector encoding does (Table 7 #1).
    back = positions_from_directions(dirs, mean_bone_lengths(motion, sk.bones), sk.bones, motion[:, sk.root])
    np.testing.assert_allclose(back, motion, atol=1e-8)


@settings(deadline=None)
@given(rigid_motion(), st.floats(1.0, 2.0))
def test_bone_correction_leaves_rigid_motion_unchanged(case: tuple[str, np.ndarray], ratio: float) -> None:
    name, motion = case
    sk = get_skeleton(name)
    out = correct_bone_lengths(motion, sk.bones, rest_lengths(name), ratio=ratio * (1 + 1e-9))
    np.testing.assert_allclose(out, motion, atol=1e-8)


def subtree(parents: tuple[int, ...], joint: int) -> list[int]:
    out = [joint]
    for j in range(len(parents)):
        p = parents[j]
        while p != -1 and p not in out:
            p = parents[p]
        if p in out and j not in out:
            out.append(j)
    return out


@settings(deadline=None)
@given(rigid_motion(), st.floats(1.31, 4.0), st.data())
def test_bone_correction_undoes_a_stretched_bone(
    case: tuple[str, np.ndarray], factor: float, data: st.DataObject
) -> None:
    name, motion = case
    sk = get_skeleton(name)
    b = data.draw(st.integers(0, len(sk.bones) - 1))
    parent, child = sk.bones[b]
    # Stretch one bone by `factor` (> 1.3), moving the child's whole subtree with it.
    stretched = motion.copy()
    shift = (factor - 1) * (motion[:, child] - motion[:, parent])
    stretched[:, subtree(sk.parents, child)] += shift[:, None]
    assert np.allclose(bone_lengths(stretched, sk.bones)[:, b], factor * rest_lengths(name)[b])
    out = correct_bone_lengths(stretched, sk.bones, rest_lengths(name))
    np.testing.assert_allclose(out, motion, atol=1e-8)
