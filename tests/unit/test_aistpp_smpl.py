"""The ``aistpp`` loader's ``motion=smpl24``: SMPL-24 joints by forward kinematics with a user's model."""

from __future__ import annotations

import pickle
from pathlib import Path

import numpy as np
import pytest
from tests.fixtures.layouts import AISTPP_GOOD, write_aistpp
from tests.fixtures.smpl_files import random_smpl, write_smpl_npz, write_smpl_pickle

from momu.data.aistpp import AISTPPConfig, AISTPPDataset
from momu.data.files import DataFileError
from momu.data.smpl_model import aistpp_joints, load_smpl_model
from momu.data.types import Clip
from momu.engine.table import run_table
from momu.methods.mofusion.tables import table1_spec
from momu.registry import METRICS


def _layout(root: Path) -> dict[str, np.ndarray]:
    """The fixture layout with a moving SMPL motion for the first sequence."""
    write_aistpp(root, seconds=1.0)
    rng = np.random.default_rng(7)
    motion = {
        "smpl_poses": (rng.normal(scale=0.4, size=(60, 72))).astype(np.float32),
        "smpl_trans": (np.cumsum(rng.normal(scale=2.0, size=(60, 3)), axis=0) + [0, 90, 0]).astype(
            np.float32
        ),
        "smpl_scaling": np.array([93.0]),
        "smpl_loss": np.float64(1.5),
    }
    with open(root / "motions" / f"{AISTPP_GOOD[0]}.pkl", "wb") as f:
        pickle.dump(motion, f, protocol=4)
    return motion


@pytest.mark.parametrize("kind", ["npz", "pkl"])
def test_smpl24_clips_are_forward_kinematics_of_the_smpl_parameters(tmp_path: Path, kind: str) -> None:
    motion = _layout(tmp_path / "aist")
    writer = write_smpl_npz if kind == "npz" else write_smpl_pickle
    model_path = writer(tmp_path / f"SMPL_MALE.{kind}", random_smpl(seed=5))
    ds = AISTPPDataset(
        AISTPPConfig(root=str(tmp_path / "aist"), split="train", motion="smpl24", smpl_model=str(model_path))
    )
    clip = ds[0]
    assert clip.id == AISTPP_GOOD[0] and clip.skeleton == "smpl24" and clip.fps == 60.0
    assert clip.motion is not None and clip.motion.shape == (60, 24, 3) and clip.audio is not None
    expected = aistpp_joints(load_smpl_model(model_path), motion["smpl_poses"], motion["smpl_trans"], 93.0)
    np.testing.assert_allclose(clip.motion, expected, atol=1e-5)
    assert clip.meta["smpl_model"] == str(model_path) and clip.meta["smpl_scaling"] == 93.0
    np.testing.assert_array_equal(clip.meta["smpl_poses"], motion["smpl_poses"])
    # the second sequence has zero poses and translation: the rest joints
    rest = load_smpl_model(model_path).rest_joints()
    np.testing.assert_allclose(ds[1].motion, np.broadcast_to(rest, (60, 24, 3)), atol=1e-6)


def test_smpl24_clips_feed_fid_k_and_coco17_clips_name_the_option(tmp_path: Path) -> None:
    _layout(tmp_path / "aist")
    model = write_smpl_npz(tmp_path / "m.npz", random_smpl())
    root = str(tmp_path / "aist")
    smpl = AISTPPDataset(
        AISTPPConfig(root=root, split="all", motion="smpl24", smpl_model=str(model), load_audio=False)
    )
    clips = [smpl[i] for i in range(len(smpl))]
    fid_k = METRICS.build("fid_k")
    assert np.isfinite(fid_k(clips[:2], clips)["fid_k"])
    coco = AISTPPDataset(AISTPPConfig(root=root, split="all", load_audio=False))
    with pytest.raises(ValueError, match=r"dataset\.motion=smpl24 with dataset\.smpl_model=PATH"):
        fid_k([coco[0], coco[1]], clips)


def test_without_a_model_file_smpl24_is_refused_and_keypoints_are_unchanged(tmp_path: Path) -> None:
    _layout(tmp_path / "aist")
    root = str(tmp_path / "aist")
    with pytest.raises(ValueError, match=r"motion=smpl24 needs smpl_model=PATH \(dataset\.smpl_model\)"):
        AISTPPDataset(AISTPPConfig(root=root, motion="smpl24"))
    clip: Clip = AISTPPDataset(AISTPPConfig(root=root, split="train", load_audio=False))[0]
    assert clip.skeleton == "coco17" and clip.motion is not None and clip.motion.shape[1:] == (17, 3)
    assert "smpl_poses" in clip.meta and "smpl_model" not in clip.meta


def test_bad_model_files_fail_when_the_dataset_opens(tmp_path: Path) -> None:
    _layout(tmp_path / "aist")
    root = str(tmp_path / "aist")
    bad = write_smpl_npz(tmp_path / "bad.npz", random_smpl(), J_regressor=None)
    with pytest.raises(DataFileError, match=r"bad\.npz: missing key 'J_regressor'"):
        AISTPPDataset(AISTPPConfig(root=root, motion="smpl24", smpl_model=str(bad)))
    model = random_smpl()
    small = write_smpl_npz(
        tmp_path / "small.npz",
        model,
        kintree_table=model["kintree_table"][:, :22],
        J_regressor=model["J_regressor"][:22],
    )
    with pytest.raises(DataFileError, match="not SMPL's 24-joint body"):
        AISTPPDataset(AISTPPConfig(root=root, motion="smpl24", smpl_model=str(small)))


def test_table1_paper_preset_needs_the_model_file_and_fails_before_training(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    _layout(tmp_path / "aist")
    bad = write_smpl_npz(tmp_path / "bad.npz", random_smpl(), v_template=np.zeros((60, 2)))
    base = [
        "--preset",
        "paper",
        "--data",
        str(tmp_path / "aist"),
        "--out",
        str(tmp_path / "out"),
        "--tracker",
        "none",
    ]
    assert run_table(table1_spec(), base) == 2
    assert run_table(table1_spec(), [*base, f"dataset.smpl_model={bad}"]) == 2
    lines = [line for line in capsys.readouterr().err.splitlines() if line.strip()]
    assert any("smpl_model=PATH (dataset.smpl_model)" in line for line in lines)
    assert any(f"{bad}: key 'v_template'" in line for line in lines)
    assert not (tmp_path / "out" / "mofusion_table1").exists()
