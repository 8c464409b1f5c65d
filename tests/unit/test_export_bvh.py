"""BVH export (momu.export): the file written through upc-pymotion, read back by an independent library.

The independent reader is ``bvhio`` (its own parser and its own forward kinematics, through
``spatial-transform`` / PyGLM); positions it computes from the written file must equal the input joints
within 1 mm on rigid motion (forward kinematics of the registered skeletons, and synth_dance clips), and
equal the rigid version of the motion (``momu.export.rigid_motion``: one length per bone, every bone in
its direction) on generated-like motion whose bones change length and whose sibling bones change angle.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from momu.data.synth.dataset import SynthConfig, generate_clip
from momu.export import (
    build_rig,
    fit_bone_lengths,
    read_bvh,
    read_motion_npz,
    rigid_motion,
    write_bvh,
    write_motion_npz,
)
from momu.features.bones import bone_lengths
from momu.features.skeletons import SEGMENTS, forward_kinematics, get_skeleton

bvhio = pytest.importorskip("bvhio")

SKELETONS_3D = ["smpl24", "dwm21", "dwm23", "coco17", "humanml22"]
MM = 1e-3


def bvhio_positions(path: Path, names: tuple[str, ...], frames: list[int]) -> np.ndarray:
    """``(len(frames), J, 3)`` world positions of ``names`` computed by bvhio from the file."""
    root = bvhio.readAsHierarchy(str(path))
    out = []
    for f in frames:
        root.loadPose(f)
        world = {joint.Name: np.array(joint.PositionWorld, dtype=np.float64) for joint, _, _ in root.layout()}
        out.append(np.stack([world[n] for n in names]))
    return np.stack(out)


def rigid_fk_motion(skeleton: str, frames: int, seed: int) -> np.ndarray:
    """Forward kinematics of the skeleton with a random rotation per body segment per frame."""
    skel = get_skeleton(skeleton)
    rng = np.random.default_rng(seed)
    per_segment = Rotation.random(frames * len(SEGMENTS), random_state=rng).as_matrix()
    per_segment = per_segment.reshape(frames, len(SEGMENTS), 3, 3)
    index = [SEGMENTS.index(s) if s != "root" else 0 for s in skel.segments]
    root = rng.normal(scale=0.5, size=(frames, 3)) + np.array([0.0, 1.0, 0.0])
    return forward_kinematics(skel, per_segment[:, index], root)


def generated_like_motion(skeleton: str, frames: int, seed: int) -> np.ndarray:
    """Rigid FK motion made to look generated: every bone of every frame scaled by 0.5-1.5 (an upper
    arm of 0.13-0.39 m) and turned by noise, so bones change length and sibling bones change angle."""
    skel = get_skeleton(skeleton)
    rigid = rigid_fk_motion(skeleton, frames, seed)
    rng = np.random.default_rng(seed + 1)
    out = np.empty_like(rigid)
    out[:, skel.root] = rigid[:, skel.root]
    for c in skel.order[1:]:
        p = skel.parents[c]
        bone = (rigid[:, c] - rigid[:, p]) * rng.uniform(0.5, 1.5, size=(frames, 1))
        bone += rng.normal(scale=0.03, size=bone.shape)
        out[:, c] = out[:, p] + bone
    return out


def _directions(motion: np.ndarray, skeleton: str) -> np.ndarray:
    skel = get_skeleton(skeleton)
    vec = motion[:, [c for _, c in skel.bones]] - motion[:, [p for p, _ in skel.bones]]
    return vec / np.linalg.norm(vec, axis=-1, keepdims=True)


@pytest.mark.parametrize("skeleton", SKELETONS_3D)
def test_rigid_motion_keeps_bone_directions_with_one_median_length_per_bone(skeleton: str) -> None:
    skel = get_skeleton(skeleton)
    motion = generated_like_motion(skeleton, frames=40, seed=4)
    rigid = rigid_motion(motion, skeleton)
    lengths = np.asarray(bone_lengths(rigid, skel.bones))
    median = np.median(np.asarray(bone_lengths(motion, skel.bones)), axis=0)
    assert np.abs(lengths - median).max() < 1e-9  # one length per bone, the median, in every frame
    assert np.abs(_directions(rigid, skeleton) - _directions(motion, skeleton)).max() < 1e-9
    assert np.abs(rigid[:, skel.root] - motion[:, skel.root]).max() == 0.0
    assert np.abs(rigid_motion(rigid, skeleton) - rigid).max() < 1e-9  # idempotent
    assert np.allclose(fit_bone_lengths(rigid, skeleton), median)
    # rigid motion is itself
    exact = rigid_fk_motion(skeleton, frames=5, seed=5)
    assert np.abs(rigid_motion(exact, skeleton) - exact).max() < 1e-9
    # 2D keypoints have no rigid bones: unchanged
    flat = np.random.default_rng(0).normal(size=(3, 14, 2))
    assert np.array_equal(rigid_motion(flat, "openpose14"), flat)


@pytest.mark.parametrize("skeleton", SKELETONS_3D)
def test_bvh_of_generated_like_motion_is_its_rigid_motion_at_every_joint_and_frame(
    tmp_path: Path, skeleton: str
) -> None:
    """Bones that change length and sibling bones that change angle (the shipped model's output): the
    file holds rigid_motion(motion) at every joint and frame, under an independent reader."""
    motion = generated_like_motion(skeleton, frames=24, seed=6)
    path = write_bvh(tmp_path / "dance.bvh", motion, 30.0, skeleton)
    names = get_skeleton(skeleton).joint_names
    got = bvhio_positions(path, names, list(range(24)))
    err = np.linalg.norm(got - rigid_motion(motion, skeleton), axis=-1)
    assert err.max() <= MM, f"{skeleton}: max FK error {err.max() * 1000:.3f} mm"
    # the rig's bones have the motion's median lengths (mean lengths and one rotation per multi-child
    # joint put joints up to 20 cm off)
    back = read_bvh(path)
    idx = [back.names.index(n) for n in names]
    assert np.linalg.norm(back.positions[:, idx] - rigid_motion(motion, skeleton), axis=-1).max() <= MM


def test_generate_writes_one_rigid_motion_to_the_npz_and_the_bvh(tmp_path: Path) -> None:
    """``momu generate``'s writer: the npz's joints and the BVH's joints agree within 1 mm at every
    joint and frame, and the npz's bones keep one length for the whole dance."""
    from momu.cli.generate_write import write_dance_outputs

    skel = get_skeleton("dwm21")
    motion = generated_like_motion("dwm21", frames=30, seed=7)
    paths = {"npz": tmp_path / "dance.npz", "bvh": tmp_path / "dance.bvh"}
    write_dance_outputs(paths, motion, 25.0, "dwm21", None, None, {"seed": 0})
    joints = read_motion_npz(paths["npz"]).joints.astype(np.float64)
    got = bvhio_positions(paths["bvh"], skel.joint_names, list(range(30)))
    err = np.linalg.norm(got - joints, axis=-1)
    assert err.max() <= MM, f"npz and BVH differ by {err.max() * 1000:.1f} mm"
    lengths = np.asarray(bone_lengths(joints, skel.bones))
    assert (lengths.max(axis=0) - lengths.min(axis=0)).max() < 1e-5


@pytest.mark.parametrize("skeleton", SKELETONS_3D)
def test_bvh_fk_matches_rigid_motion_under_an_independent_reader(tmp_path: Path, skeleton: str) -> None:
    motion = rigid_fk_motion(skeleton, frames=12, seed=1)
    path = write_bvh(tmp_path / "dance.bvh", motion, 30.0, skeleton)
    names = get_skeleton(skeleton).joint_names
    frames = [0, 5, 11]
    got = bvhio_positions(path, names, frames)
    err = np.linalg.norm(got - motion[frames], axis=-1)
    assert err.max() <= MM, f"{skeleton}: max FK error {err.max() * 1000:.3f} mm"


@pytest.mark.parametrize("skeleton", ["smpl24", "dwm21", "coco17"])
def test_bvh_of_a_synth_dance_clip_round_trips(tmp_path: Path, skeleton: str) -> None:
    cfg = SynthConfig(num_clips=1, min_seconds=2.0, max_seconds=2.0, skeleton=skeleton, root_centred=True)
    clip = generate_clip(cfg, 0)
    path = write_bvh(tmp_path / "clip.bvh", clip.motion, clip.fps, skeleton, trajectory=clip.trajectory)
    want = np.asarray(clip.motion, dtype=np.float64) + np.asarray(clip.trajectory)[:, None]
    frames = list(range(0, clip.num_frames, 17))
    got = bvhio_positions(path, get_skeleton(skeleton).joint_names, frames)
    assert np.linalg.norm(got - want[frames], axis=-1).max() <= MM
    # momu's own reader (pymotion FK) agrees, over every frame, and gives the frame rate back
    back = read_bvh(path)
    idx = [back.names.index(n) for n in get_skeleton(skeleton).joint_names]
    assert back.positions.shape[0] == clip.num_frames
    assert np.linalg.norm(back.positions[:, idx] - want, axis=-1).max() <= MM
    assert back.fps == pytest.approx(clip.fps, rel=1e-5)


def test_bvh_header_has_frame_time_root_translation_and_rest_bone_lengths(tmp_path: Path) -> None:
    motion = rigid_fk_motion("smpl24", frames=4, seed=2)
    text = write_bvh(tmp_path / "a.bvh", motion, 25.0, "smpl24").read_text()
    assert "Frame Time: 0.040000" in text
    assert "Frames: 4" in text
    assert "CHANNELS 6 Xposition Yposition Zposition Zrotation Xrotation Yrotation" in text
    # rest offsets are the skeleton's (rigid motion: median lengths equal rest lengths)
    rig = build_rig(get_skeleton("smpl24"), fit_bone_lengths(motion, "smpl24"))
    knee = rig.names.index("l_knee")
    knee_length = get_skeleton("smpl24").bone_lengths[3]
    assert np.linalg.norm(rig.offsets[knee]) == pytest.approx(knee_length, rel=1e-9)
    # centimetres on request
    text_cm = write_bvh(tmp_path / "cm.bvh", motion, 25.0, "smpl24", scale=100.0)
    got = read_bvh(text_cm).positions
    assert np.abs(got[:, 0] - motion[:, 0] * 100).max() < 1e-3


def test_rig_splits_joints_whose_children_turn_separately() -> None:
    rig = build_rig(get_skeleton("dwm21"))
    # DwM's pelvis carries hips (pelvis segment) and shoulders + head (abdomen segment)
    assert "pelvis_abdomen" in rig.names
    virtual = rig.names.index("pelvis_abdomen")
    assert rig.parents[virtual] == 0 and np.allclose(rig.offsets[virtual], 0.0)
    # each child of a group of two or more gets its own zero-offset bone helper joint, which aims
    # that bone alone: the hips under the pelvis, head and shoulders under pelvis_abdomen
    for helper_name, holder, child in [
        ("pelvis_to_l_hip", "pelvis", "l_hip"),
        ("pelvis_to_head_front", "pelvis_abdomen", "head_front"),
        ("l_ankle_to_l_heel", "l_ankle", "l_heel"),
    ]:
        helper = rig.names.index(helper_name)
        assert rig.parents[helper] == rig.names.index(holder) and np.allclose(rig.offsets[helper], 0.0)
        assert rig.parents[rig.names.index(child)] == helper
    # a single child hangs from its parent directly; SMPL: 3 helpers at the pelvis, 3 at spine3
    assert rig.parents[rig.names.index("l_knee")] == rig.names.index("l_hip")
    smpl = build_rig(get_skeleton("smpl24"))
    assert len(smpl.names) == 30 and "spine3_to_neck" in smpl.names
    # every parent comes before its children
    assert all(p < b for b, p in enumerate(rig.parents) if p >= 0)


@given(seed=st.integers(0, 2**16), skeleton=st.sampled_from(SKELETONS_3D), generated=st.booleans())
def test_ik_then_fk_gives_the_rigid_motion(seed: int, skeleton: str, generated: bool) -> None:
    """Property: BVH data reproduces rigid motion, and the rigid version of generated-like motion, by
    the BVH FK convention (pymotion's FK)."""
    from momu.export.bvh import motion_bvh_data

    motion = (generated_like_motion if generated else rigid_fk_motion)(skeleton, frames=3, seed=seed)
    rig, data = motion_bvh_data(motion, 30.0, skeleton)
    import pymotion.rotations.quat_np as quat
    from pymotion.ops.skeleton_np import fk

    euler = np.radians(np.asarray(data["rotations"]))
    orders = np.broadcast_to(np.asarray(data["rot_order"]), euler.shape)
    root = np.asarray(data["positions"])[:, 0]
    pos, _ = fk(quat.from_euler(euler, orders), root, rig.offsets, np.asarray(data["parents"]))
    idx = list(rig.bvh_index)
    assert np.abs(pos[:, idx] - rigid_motion(motion, skeleton)).max() < 1e-6
    if not generated:
        assert np.abs(pos[:, idx] - motion).max() < 1e-6


def test_bvh_rejects_2d_motion_and_bad_shapes(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match="3D"):
        write_bvh(tmp_path / "x.bvh", np.zeros((3, 14, 2)), 30.0, "openpose14")
    with pytest.raises(ValueError, match=r"\(T, 24, 3\)"):
        write_bvh(tmp_path / "x.bvh", np.zeros((3, 21, 3)), 30.0, "smpl24")
    bad = rigid_fk_motion("smpl24", 2, 0)
    bad[1, 3, 0] = np.nan
    with pytest.raises(ValueError, match="NaN"):
        write_bvh(tmp_path / "x.bvh", bad, 30.0, "smpl24")
    assert not (tmp_path / "x.bvh").exists()
    (tmp_path / "junk.bvh").write_text("not a bvh\n")
    with pytest.raises(ValueError, match="junk.bvh"):
        read_bvh(tmp_path / "junk.bvh")


def test_npz_round_trip_without_pickles(tmp_path: Path) -> None:
    motion = rigid_fk_motion("dwm21", frames=5, seed=3).astype(np.float32)
    path = write_motion_npz(tmp_path / "m.npz", motion, 25.0, "dwm21", provenance={"seed": 7, "model": "x"})
    with np.load(path, allow_pickle=False) as data:
        assert list(data["joint_names"]) == list(get_skeleton("dwm21").joint_names)
        assert data["parents"].tolist() == list(get_skeleton("dwm21").parents)
        assert str(data["skeleton"]) == "dwm21"
    back = read_motion_npz(path)
    assert np.array_equal(back.joints, motion)
    assert back.fps == 25.0 and back.skeleton == "dwm21"
    assert back.provenance == {"seed": 7, "model": "x"}
    with pytest.raises(ValueError, match=r"\(T, 21, D\)"):
        write_motion_npz(tmp_path / "bad.npz", motion[:, :20], 25.0, "dwm21")


@given(seed=st.integers(0, 2**16), order=st.sampled_from(["zxy", "xyz", "yzx", "zyx"]))
def test_bvh_euler_channels_give_back_every_rotation_gimbal_lock_included(seed: int, order: str) -> None:
    """The channels written for a rotation give that rotation back under the BVH reading (pymotion's
    ``from_euler``, intrinsic), also where the middle angle is ±90° and the Euler angles are not
    unique; no warning reaches the user."""
    import warnings

    import pymotion.rotations.quat_np as quat

    from momu.export.bvh import _intrinsic_euler_degrees

    rng = np.random.default_rng(seed)
    angles = rng.uniform(-180.0, 180.0, (6, 3))
    angles[:3, 1] = [90.0, -90.0, 90.0]  # gimbal lock
    matrices = Rotation.from_euler(order.upper(), angles, degrees=True).as_matrix()[None]
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        euler = _intrinsic_euler_degrees(matrices, order)
    orders = np.broadcast_to(np.array(list(order)), euler.shape)
    back = quat.to_matrix(quat.from_euler(np.radians(euler), orders))
    assert np.abs(back - matrices).max() < 1e-9
