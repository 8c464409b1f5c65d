"""Skeleton converters (momu.features.convert) and motion file readers (momu.data.motion_files)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from momu.data.motion_files import read_motion_file
from momu.data.synth.dataset import SynthConfig, generate_clip
from momu.export import write_bvh, write_motion_npz
from momu.features.convert import conversion_matrix, convert_motion
from momu.features.skeletons import SKELETON_NAMES, get_skeleton

CONVERTIBLE = ["smpl24", "dwm21", "dwm23", "coco17", "openpose14", "humanml22"]


@pytest.mark.parametrize("source", CONVERTIBLE)
@pytest.mark.parametrize("target", CONVERTIBLE)
def test_every_registered_pair_converts_with_rows_summing_to_one(source: str, target: str) -> None:
    if get_skeleton(source).dims == 2 and get_skeleton(target).dims == 3:
        with pytest.raises(ValueError, match="2D keypoints"):
            convert_motion(np.zeros((2, get_skeleton(source).num_joints, 2)), source, target)
        return
    w = conversion_matrix(source, target)
    assert w.shape == (get_skeleton(target).num_joints, get_skeleton(source).num_joints)
    assert np.allclose(w.sum(axis=1), 1.0)
    if source == target:
        assert np.array_equal(w, np.eye(len(w)))


def test_same_body_points_map_exactly_between_smpl_and_coco() -> None:
    clip = generate_clip(SynthConfig(num_clips=1, min_seconds=1.0, max_seconds=1.0, skeleton="smpl24"), 0)
    smpl = get_skeleton("smpl24")
    out = convert_motion(clip.motion, "smpl24", "coco17")
    coco = get_skeleton("coco17")
    for name in ("l_knee", "r_wrist", "l_shoulder"):
        assert np.allclose(out[:, coco.index(name)], clip.motion[:, smpl.index(name)], atol=1e-6)
    # a neck made from two shoulders is their midpoint
    op = convert_motion(out, "coco17", "smpl24")
    mid = 0.5 * (out[:, coco.index("l_shoulder")] + out[:, coco.index("r_shoulder")])
    assert np.allclose(op[:, smpl.index("neck")], mid, atol=1e-6)


def test_3d_to_2d_projects_like_the_synthetic_openpose_data() -> None:
    """smpl24 -> openpose14 lands in the image where synth_dance's own openpose14 clips are."""
    cfg3 = SynthConfig(
        num_clips=1, min_seconds=2.0, max_seconds=2.0, skeleton="smpl24", trajectory_radius=0.0
    )
    cfg2 = SynthConfig(
        num_clips=1, min_seconds=2.0, max_seconds=2.0, skeleton="openpose14", trajectory_radius=0.0
    )
    ours = convert_motion(generate_clip(cfg3, 0).motion, "smpl24", "openpose14")
    theirs = generate_clip(cfg2, 0).motion
    assert ours.shape[1:] == (14, 2)
    # same camera: the figure's height in pixels and its centre agree within 15 %
    h_ours = np.ptp(ours[..., 1], axis=1).mean()
    h_theirs = np.ptp(theirs[..., 1], axis=1).mean()
    assert h_ours == pytest.approx(h_theirs, rel=0.15)
    assert np.abs(ours[..., 0].mean() - theirs[..., 0].mean()) < 0.15 * h_theirs


def test_unknown_skeleton_names_the_valid_ones() -> None:
    with pytest.raises(KeyError, match="valid names"):
        conversion_matrix("smpl24", "nope")
    assert set(CONVERTIBLE) <= set(SKELETON_NAMES)


def test_motion_files_bvh_npz_npy(tmp_path: Path) -> None:
    clip = generate_clip(SynthConfig(num_clips=1, min_seconds=1.0, max_seconds=1.0, skeleton="dwm21"), 0)
    motion = np.asarray(clip.motion, dtype=np.float64)
    got = read_motion_file(write_bvh(tmp_path / "a.bvh", motion, clip.fps, "dwm21"))
    assert got.skeleton == "dwm21" and got.fps == pytest.approx(clip.fps)
    assert np.abs(got.motion - motion).max() < 1e-3
    # centimetre files are recognised by the figure's size
    got_cm = read_motion_file(write_bvh(tmp_path / "cm.bvh", motion, clip.fps, "dwm21", scale=100.0))
    assert np.abs(got_cm.motion - motion).max() < 1e-3
    got = read_motion_file(write_motion_npz(tmp_path / "a.npz", motion, clip.fps, "dwm21"))
    assert got.skeleton == "dwm21" and got.fps == clip.fps
    np.save(tmp_path / "a.npy", motion.astype(np.float32))
    got = read_motion_file(tmp_path / "a.npy", fps=25.0)
    assert got.skeleton == "dwm21" and got.fps == 25.0


def test_motion_file_errors_name_the_file(tmp_path: Path) -> None:
    with pytest.raises(FileNotFoundError, match="missing.bvh"):
        read_motion_file(tmp_path / "missing.bvh")
    np.save(tmp_path / "odd.npy", np.zeros((10, 9, 3), dtype=np.float32))
    with pytest.raises(ValueError, match=r"odd.npy: no registered skeleton has 9 joints"):
        read_motion_file(tmp_path / "odd.npy")
    np.save(tmp_path / "nan.npy", np.full((10, 24, 3), np.nan, dtype=np.float32))
    with pytest.raises(ValueError, match="nan.npy: motion contains NaN"):
        read_motion_file(tmp_path / "nan.npy")
    (tmp_path / "x.txt").write_text("hi")
    with pytest.raises(ValueError, match="unknown motion file type"):
        read_motion_file(tmp_path / "x.txt")


def test_dance_with_melody_folder_reads_as_dwm21(shared_data: Path) -> None:
    folder = shared_data / "dance_with_melody" / "DANCE_W_1"
    if not folder.is_dir():
        pytest.skip(f"{folder} not found")
    got = read_motion_file(folder)
    assert got.skeleton == "dwm21" and got.fps == 25.0 and got.motion.shape[1:] == (21, 3)
    assert got.trajectory is not None and got.trajectory.shape == (got.motion.shape[0], 3)
    same = read_motion_file(folder / "skeletons.json")
    assert np.array_equal(same.motion, got.motion)
