"""SMPL model files (.npz and the official pickle) and SMPL-24 forward kinematics for AIST++."""

from __future__ import annotations

import pickle
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial.transform import Rotation
from tests.fixtures.smpl_files import SMPL_PARENTS, random_smpl, write_smpl_npz, write_smpl_pickle

from momu.data.files import DataFileError
from momu.data.smpl_model import aistpp_joints, forward_kinematics, load_smpl_model


@pytest.fixture(params=["npz", "pkl"])
def model_file(request: pytest.FixtureRequest, tmp_path: Path) -> tuple[Path, dict[str, np.ndarray]]:
    model = random_smpl(seed=3)
    writer = write_smpl_npz if request.param == "npz" else write_smpl_pickle
    return writer(tmp_path / f"SMPL_NEUTRAL.{request.param}", model), model


def _rodrigues(v: np.ndarray) -> np.ndarray:
    """Rotation matrix of one axis-angle vector (written out, independent of scipy)."""
    angle = float(np.linalg.norm(v))
    if angle < 1e-12:
        return np.eye(3)
    k = v / angle
    kx = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.eye(3) + np.sin(angle) * kx + (1 - np.cos(angle)) * kx @ kx


def _fk_reference(rest: np.ndarray, parents: tuple[int, ...], poses: np.ndarray) -> np.ndarray:
    """Per frame, per joint: 4x4 local transforms [R_j | J_j - J_parent] multiplied down the chain."""
    out = np.zeros((poses.shape[0], len(parents), 3))
    for t in range(poses.shape[0]):
        world: list[np.ndarray] = []
        for j, p in enumerate(parents):
            local = np.eye(4)
            local[:3, :3] = _rodrigues(poses[t, 3 * j : 3 * j + 3])
            local[:3, 3] = rest[j] - (rest[p] if p >= 0 else 0.0)
            world.append(local if p < 0 else world[p] @ local)
            out[t, j] = world[j][:3, 3]
    return out


def test_model_files_reload_with_their_values(model_file: tuple[Path, dict[str, np.ndarray]]) -> None:
    path, model = model_file
    smpl = load_smpl_model(path)
    assert smpl.parents == SMPL_PARENTS and smpl.num_joints == 24
    np.testing.assert_array_equal(smpl.v_template, model["v_template"])
    np.testing.assert_array_equal(smpl.j_regressor, model["J_regressor"])
    assert smpl.shapedirs is not None
    np.testing.assert_array_equal(smpl.shapedirs, model["shapedirs"])
    np.testing.assert_allclose(smpl.rest_joints(), model["J_regressor"] @ model["v_template"], atol=1e-12)
    betas = np.linspace(-2, 2, 10)
    shaped = model["v_template"] + model["shapedirs"] @ betas
    np.testing.assert_allclose(smpl.rest_joints(betas), model["J_regressor"] @ shaped, atol=1e-12)


def test_official_pickle_loads_without_chumpy_code(tmp_path: Path) -> None:
    """The stand-in ``chumpy.ch.Ch`` raises if its ``__setstate__`` runs, and is gone from
    ``sys.modules`` while reading: the reader takes the pickled state as plain data."""
    path = write_smpl_pickle(tmp_path / "basicmodel_m_lbs_10_207_0_v1.1.0.pkl", random_smpl())
    raw = path.read_bytes()
    assert b"chumpy.ch" in raw and b"scipy.sparse" in raw
    with pytest.raises((ModuleNotFoundError, AttributeError)):
        pickle.loads(raw)  # a plain unpickler would import chumpy (the test proves the file needs it)
    assert load_smpl_model(path).num_joints == 24


def test_zero_pose_is_the_rest_joints_plus_translation(
    model_file: tuple[Path, dict[str, np.ndarray]],
) -> None:
    smpl = load_smpl_model(model_file[0])
    trans = np.random.default_rng(0).normal(size=(5, 3))
    pos = forward_kinematics(smpl.rest_joints(), smpl.parents, np.zeros((5, 72)), trans)
    np.testing.assert_allclose(pos, smpl.rest_joints()[None] + trans[:, None], atol=1e-12)


def test_forward_kinematics_matches_a_per_joint_reference() -> None:
    rng = np.random.default_rng(1)
    model = random_smpl(seed=1)
    rest = model["J_regressor"] @ model["v_template"]
    poses = rng.normal(scale=0.8, size=(6, 72))
    trans = rng.normal(size=(6, 3))
    ours = forward_kinematics(rest, SMPL_PARENTS, poses, trans)
    ref = _fk_reference(rest, SMPL_PARENTS, poses) + trans[:, None]
    np.testing.assert_allclose(ours, ref, atol=1e-5)
    # (T, 24, 3) poses are the same motion
    np.testing.assert_allclose(forward_kinematics(rest, SMPL_PARENTS, poses.reshape(6, 24, 3), trans), ours)
    # the root joint only rotates about itself: it stays at rest + trans
    np.testing.assert_allclose(ours[:, 0], rest[0] + trans, atol=1e-12)


def test_bones_keep_their_rest_lengths_over_time() -> None:
    model = random_smpl(seed=2)
    rest = model["J_regressor"] @ model["v_template"]
    t = np.linspace(0, 2 * np.pi, 40)[:, None]
    poses = np.sin(t * np.arange(1, 73) / 7.0) * 1.5  # large smooth rotations on every joint
    pos = forward_kinematics(rest, SMPL_PARENTS, poses, np.cumsum(np.ones((40, 3)) * 0.05, axis=0))
    child = np.arange(1, 24)
    parent = np.array(SMPL_PARENTS[1:])
    lengths = np.linalg.norm(pos[:, child] - pos[:, parent], axis=-1)
    np.testing.assert_allclose(
        lengths, np.linalg.norm(rest[child] - rest[parent], axis=-1)[None].repeat(40, 0)
    )
    assert np.ptp(pos[:, 10], axis=0).max() > 0.1  # the motion is not trivial


def test_aistpp_joints_divide_the_translation_by_the_scaling(tmp_path: Path) -> None:
    smpl = load_smpl_model(write_smpl_npz(tmp_path / "m.npz", random_smpl()))
    rng = np.random.default_rng(4)
    poses, trans = rng.normal(scale=0.3, size=(4, 72)), rng.normal(scale=90.0, size=(4, 3))
    got = aistpp_joints(smpl, poses, trans, 93.5)
    np.testing.assert_allclose(
        got, forward_kinematics(smpl.rest_joints(), smpl.parents, poses) + trans[:, None] / 93.5
    )
    root_rot = Rotation.from_rotvec(poses[:, :3]).as_matrix()
    offset = smpl.rest_joints()[3] - smpl.rest_joints()[0]  # spine1 hangs off the root
    np.testing.assert_allclose(got[:, 3] - got[:, 0], root_rot @ offset, atol=1e-12)
    with pytest.raises(ValueError, match="smpl_scaling"):
        aistpp_joints(smpl, poses, trans, 0.0)


@pytest.mark.parametrize(
    ("replace", "key"),
    [
        ({"J_regressor": None}, "missing key 'J_regressor'"),
        ({"v_template": None}, "missing key 'v_template'"),
        ({"kintree_table": None}, "missing key 'kintree_table'"),
        ({"J_regressor": np.ones((23, 60)) / 60}, r"key 'J_regressor': expected \(24, 60\)"),
        ({"v_template": np.zeros((60, 2))}, r"key 'v_template': expected \(V, 3\)"),
        ({"shapedirs": np.zeros((59, 3, 10))}, "key 'shapedirs'"),
        (
            {"kintree_table": np.stack([np.arange(24) - 1, np.arange(24)])[:, ::-1].copy()},
            "key 'kintree_table'",
        ),
        ({"v_template": np.full((60, 3), np.nan)}, "key 'v_template': non-finite"),
    ],
)
@pytest.mark.parametrize("kind", ["npz", "pkl"])
def test_bad_model_files_name_the_file_and_key(tmp_path: Path, replace: dict, key: str, kind: str) -> None:
    writer = write_smpl_npz if kind == "npz" else write_smpl_pickle
    path = writer(tmp_path / f"bad.{kind}", random_smpl(), **replace)
    with pytest.raises(DataFileError, match=key) as info:
        load_smpl_model(path)
    assert str(info.value).startswith(str(path)) and "\n" not in str(info.value)


def test_unreadable_or_unsafe_model_files_are_refused(tmp_path: Path) -> None:
    with pytest.raises(FileNotFoundError, match="not found"):
        load_smpl_model(tmp_path / "absent.pkl")
    npz = tmp_path / "object.npz"
    np.savez(npz, J_regressor=np.array({"sparse": 1}, dtype=object), v_template=np.zeros((3, 3)))
    with pytest.raises(DataFileError, match="pickled object array"):
        load_smpl_model(npz)
    evil = tmp_path / "evil.pkl"
    evil.write_bytes(b"\x80\x02cos\nsystem\nq\x00X\x04\x00\x00\x00trueq\x01\x85q\x02Rq\x03.")
    with pytest.raises(DataFileError, match="refusing to load global 'os.system'"):
        load_smpl_model(evil)
    other = tmp_path / "other.pkl"
    other.write_bytes(pickle.dumps([1, 2]))
    with pytest.raises(DataFileError, match="expected a pickled dict"):
        load_smpl_model(other)


def test_a_sparse_regressor_declaring_a_huge_shape_is_refused(tmp_path: Path) -> None:
    """A few bytes of sparse matrix must not become terabytes when made dense."""
    import scipy.sparse

    model = random_smpl()
    bomb = scipy.sparse.csc_matrix(model["J_regressor"])
    bomb._shape = (24, 10**12)  # what a crafted file could declare
    path = write_smpl_pickle(tmp_path / "bomb.pkl", model, J_regressor=bomb)
    with pytest.raises(DataFileError, match="key 'J_regressor': a sparse matrix of shape"):
        load_smpl_model(path)
