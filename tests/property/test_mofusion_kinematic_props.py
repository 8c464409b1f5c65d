"""MoFusion §3 pose vector and §3.2 scheduled kinematic losses (Eq. 4–7) as properties."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
import torch
from hypothesis import given
from hypothesis import strategies as st
from scipy.spatial.transform import Rotation

from momu.features.bones import bone_lengths
from momu.features.mofusion_pose import decode_pose, encode_pose, mirror_bone_pairs
from momu.features.skeletons import forward_kinematics, get_skeleton
from momu.losses.scheduled_kinematic import skeleton_consistency, symmetry
from momu.registry import LOSSES, SCHEDULERS


def _fk(skeleton, seed: int, frames: int = 12) -> np.ndarray:
    rng = np.random.default_rng(seed)
    rot = Rotation.random(frames * skeleton.num_joints, random_state=seed).as_matrix()
    rot = rot.reshape(frames, skeleton.num_joints, 3, 3)
    root = rng.normal(0.0, 0.5, (frames, 3))
    return forward_kinematics(skeleton, rot, root)


def _symmetric(skeleton):
    """The skeleton with each mirror pair's rest offsets made mirror images (equal bone lengths)."""
    off = np.asarray(skeleton.offsets)
    mirrored = off[list(skeleton.mirror)] * np.array([-1.0, 1.0, 1.0])
    sym = 0.5 * (off + mirrored)
    return dataclasses.replace(skeleton, offsets=tuple(map(tuple, sym.tolist())))


@given(st.integers(0, 10_000), st.sampled_from(["smpl24", "humanml22"]))
def test_pose_round_trip_numpy_and_torch(seed: int, name: str) -> None:
    sk = get_skeleton(name)
    motion = _fk(sk, seed)
    vec = encode_pose(motion, sk.root)
    assert vec.shape == (motion.shape[0], 3 * sk.num_joints)
    np.testing.assert_allclose(vec[:, :3], motion[:, sk.root])  # the root slot: the translation
    np.testing.assert_allclose(decode_pose(vec, sk.num_joints, sk.root), motion, atol=1e-12)
    t = torch.from_numpy(motion)
    tv = encode_pose(t, sk.root)
    np.testing.assert_allclose(tv.numpy(), vec, atol=1e-12)
    np.testing.assert_allclose(decode_pose(tv, sk.num_joints, sk.root).numpy(), motion, atol=1e-12)


def test_decode_is_differentiable() -> None:
    vec = torch.randn(3, 5, 72, requires_grad=True)
    decode_pose(vec, 24).pow(2).sum().backward()
    assert vec.grad is not None and torch.isfinite(vec.grad).all()


@given(st.integers(0, 10_000), st.sampled_from(["smpl24", "humanml22"]))
def test_skeleton_consistency_is_zero_on_rigid_fk_motion(seed: int, name: str) -> None:
    sk = get_skeleton(name)
    pos = torch.from_numpy(_fk(sk, seed))[None]
    assert float(skeleton_consistency(pos, sk.bones)) == pytest.approx(0.0, abs=1e-20)
    stretched = pos.clone()
    stretched[0, ::2] *= 1.1  # bone lengths change every other frame
    assert float(skeleton_consistency(stretched, sk.bones)) > 1e-6


@given(st.integers(0, 10_000), st.sampled_from(["smpl24", "humanml22"]))
def test_symmetry_is_zero_on_a_mirror_symmetric_skeleton(seed: int, name: str) -> None:
    sk = _symmetric(get_skeleton(name))
    pos = torch.from_numpy(_fk(sk, seed))[None]
    assert float(symmetry(pos, sk.bones, mirror_bone_pairs(sk))) == pytest.approx(0.0, abs=1e-12)


def test_symmetry_floor_of_the_smpl_template() -> None:
    """The SMPL neutral template is asymmetric: L_a's ground-truth floor (docs/papers/mofusion.md)."""
    sk = get_skeleton("smpl24")
    pos = torch.from_numpy(_fk(sk, 0))[None]
    floor = float(symmetry(pos, sk.bones, mirror_bone_pairs(sk)))
    rest = np.linalg.norm(np.asarray(sk.offsets), axis=1)
    lengths = rest[[c for _, c in sk.bones]]
    expected = np.mean([abs(lengths[a] - lengths[b]) for a, b in mirror_bone_pairs(sk)])
    assert floor == pytest.approx(expected, rel=1e-9)
    assert 0.004 < floor < 0.007  # about 5 mm


def test_unbiased_variance_over_valid_frames_only() -> None:
    sk = get_skeleton("smpl24")
    pos = torch.from_numpy(_fk(sk, 1, frames=8))[None].repeat(2, 1, 1, 1)
    pos[1, 5:] *= 3.0  # padded frames of item 1 are wildly off
    mask = torch.ones(2, 8, dtype=torch.bool)
    mask[1, 5:] = False
    out = skeleton_consistency(pos, sk.bones, mask)
    assert float(out[1]) == pytest.approx(0.0, abs=1e-20)
    lengths = bone_lengths(pos[0, :4] * torch.tensor([1.0, 1.2, 1.0, 1.0])[:, None, None], sk.bones)
    expect = lengths.var(dim=0, unbiased=True).mean()
    got = skeleton_consistency(
        (pos[0, :4] * torch.tensor([1.0, 1.2, 1.0, 1.0])[:, None, None])[None], sk.bones
    )
    assert float(got) == pytest.approx(float(expect), rel=1e-9)


@given(st.integers(0, 999), st.integers(0, 1000))
def test_scheduled_x0_term_equals_reweighted_data_term(t: int, seed: int) -> None:
    """With squared norms and no normalisation: ᾱ_t ‖x̂₀ − x₀‖² = (1 − ᾱ_t) ‖ε̂ − ε‖² exactly."""
    loss = LOSSES.build("scheduled_kinematic", {"use_s": False, "use_a": False})
    gen = torch.Generator().manual_seed(seed)
    x0 = torch.randn(2, 6, 72, generator=gen, dtype=torch.float64)
    eps = torch.randn(2, 6, 72, generator=gen, dtype=torch.float64)
    eps_hat = eps + 0.3 * torch.randn(2, 6, 72, generator=gen, dtype=torch.float64)
    tt = torch.full((2,), t)
    sched = loss.scheduler
    x_t = sched.add_noise(x0, eps, tt)
    x0_hat = sched.predict_x0(x_t, eps_hat, tt)
    abar = sched.alphas_cumprod[t].double()
    lhs = abar * ((loss.raw(x0_hat) - loss.raw(x0)) ** 2).sum()
    rhs = (1 - abar) * ((eps_hat - eps) ** 2).sum()
    assert float(lhs) == pytest.approx(float(rhs), rel=1e-6)


def test_schedule_weight_is_alpha_bar() -> None:
    loss = LOSSES.build("scheduled_kinematic", {})
    w = loss.weight(torch.tensor([0, 999]), torch.zeros(1))
    abar = SCHEDULERS.build("ddpm", {}).alphas_cumprod
    assert float(w[1]) == pytest.approx(4.0e-5, rel=0.02)
    assert float(w[0]) == pytest.approx(float(abar[0]))
    const = LOSSES.build("scheduled_kinematic", {"schedule": "constant", "constant_weight": 0.5})
    assert const.weight(torch.tensor([999]), torch.zeros(1)).tolist() == [0.5]
