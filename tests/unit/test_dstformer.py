"""DSTformer (shared spatio-temporal transformer) and the ``learnable_motion`` encoder (MoMu §5.1)."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import pytest
import torch
from safetensors.torch import load_file, save_file

from momu.config import build_component
from momu.encoders.dstformer import DSTformer, DSTformerConfig, sinusoidal_embedding
from momu.encoders.learnable_motion import LearnableMotionConfig, LearnableMotionEncoder
from momu.registry import ENCODERS

TINY = DSTformerConfig(num_joints=5, dim_in=2, dim_feat=8, dim_rep=6, depth=2, num_heads=2)


@pytest.fixture(autouse=True)
def _seed() -> None:
    torch.manual_seed(0)


def test_dstformer_output_shape_and_range() -> None:
    net = DSTformer(TINY).eval()
    out = net(torch.randn(3, 7, 5, 2))
    assert out.shape == (3, 7, 5, 6)
    assert net.out_channels == 6
    assert out.abs().max() <= 1.0  # tanh pre-logits


def test_dstformer_padding_never_changes_valid_frames() -> None:
    net = DSTformer(TINY).eval()
    x = torch.randn(2, 6, 5, 2)
    ref = net(x)
    junk = 100 * torch.randn(2, 4, 5, 2)
    padded = torch.cat([x, junk], dim=1)
    mask = torch.zeros(2, 10, dtype=torch.bool)
    mask[:, :6] = True
    out = net(padded, mask)
    torch.testing.assert_close(out[:, :6], ref, atol=1e-5, rtol=1e-5)


def test_dstformer_mixes_frames_and_joints() -> None:
    """Changing one joint of one frame changes other joints and other frames (both attentions work)."""
    net = DSTformer(TINY).eval()
    x = torch.randn(1, 4, 5, 2)
    y = x.clone()
    y[0, 0, 0] += 1.0
    diff = (net(x) - net(y)).abs()
    assert diff[0, 3, 4].max() > 1e-6  # another frame, another joint


def test_dstformer_gradients_reach_every_parameter() -> None:
    net = DSTformer(TINY)
    net(torch.randn(2, 5, 5, 2)).pow(2).mean().backward()
    missing = [n for n, p in net.named_parameters() if p.grad is None or not torch.isfinite(p.grad).all()]
    assert not missing


def test_dstformer_rejects_bad_input() -> None:
    net = DSTformer(TINY)
    with pytest.raises(ValueError, match=r"\(B, T, 5, 2\)"):
        net(torch.randn(2, 5, 4, 2))
    with pytest.raises(ValueError, match="mask"):
        net(torch.randn(2, 5, 5, 2), torch.ones(2, 5))
    empty = torch.ones(2, 5, dtype=torch.bool)
    empty[1] = False
    with pytest.raises(ValueError, match="at least one valid"):
        net(torch.randn(2, 5, 5, 2), empty)
    with pytest.raises(ValueError, match="divisible"):
        DSTformerConfig(dim_feat=10, num_heads=4)


def test_sinusoidal_embedding_values() -> None:
    table = sinusoidal_embedding(3, 4)
    assert table.shape == (3, 4)
    torch.testing.assert_close(table[0], torch.tensor([0.0, 1.0, 0.0, 1.0]))
    torch.testing.assert_close(table[2, 0], torch.sin(torch.tensor(2.0)))
    torch.testing.assert_close(table[2, 2], torch.sin(torch.tensor(2.0 / 100.0)))


def _tiny_encoder(downsample: int = 1) -> LearnableMotionEncoder:
    cfg = LearnableMotionConfig(
        num_joints=5,
        dim_in=2,
        dim_feat=8,
        dim_rep=4,
        depth=1,
        num_heads=2,
        out_channels=3,
        downsample=downsample,
    )
    return LearnableMotionEncoder(cfg).eval()


def test_learnable_motion_registered_and_builds_from_default_config() -> None:
    assert "learnable_motion" in ENCODERS.names()
    enc = ENCODERS.build("learnable_motion")
    assert isinstance(enc, LearnableMotionEncoder)
    out = enc(torch.randn(2, 9, 14, 2))  # default: openpose14, 2D, 20 channels (MoMu latent width)
    assert out.shape == (2, 9, 20)
    out.mean().backward()
    node = build_component(
        {"name": "learnable_motion", "num_joints": 24, "dim_in": 3, "downsample": 4}, "encoders"
    )
    assert node(torch.randn(1, 10, 24, 3)).shape == (1, 3, 20)


def test_learnable_motion_downsample_is_masked_window_mean() -> None:
    full = _tiny_encoder(1)
    pooled = _tiny_encoder(3)
    pooled.load_state_dict(full.state_dict())
    x = torch.randn(2, 7, 5, 2)
    mask = torch.ones(2, 7, dtype=torch.bool)
    mask[1, 5:] = False
    per_frame = full(x, mask)  # (2, 7, 3)
    out = pooled(x, mask)  # (2, 3, 3): windows [0,3), [3,6), [6,7)
    assert out.shape == (2, 3, 3)
    torch.testing.assert_close(out[0, 0], per_frame[0, 0:3].mean(0))
    torch.testing.assert_close(out[0, 2], per_frame[0, 6])
    torch.testing.assert_close(out[1, 1], per_frame[1, 3:5].mean(0))  # frame 5 is padding
    assert pooled.output_mask(mask).tolist() == [[True, True, True], [True, True, False]]
    assert pooled.output_length(7) == 3


def test_learnable_motion_padding_invariance() -> None:
    enc = _tiny_encoder(2)
    x = torch.randn(1, 6, 5, 2)
    ref = enc(x)
    padded = torch.cat([x, torch.full((1, 5, 5, 2), 7.0)], dim=1)
    mask = torch.zeros(1, 11, dtype=torch.bool)
    mask[:, :6] = True
    torch.testing.assert_close(enc(padded, mask)[:, :3], ref, atol=1e-5, rtol=1e-5)


def test_learnable_motion_safetensors_round_trip(tmp_path: Path) -> None:
    enc = _tiny_encoder(2)
    path = tmp_path / "enc.safetensors"
    save_file({k: v.contiguous() for k, v in enc.state_dict().items()}, str(path))
    other = _tiny_encoder(2)
    other.load_state_dict(load_file(str(path)), strict=True)
    x = torch.randn(2, 6, 5, 2)
    torch.testing.assert_close(other(x), enc(x))
    wrong = LearnableMotionEncoder(
        LearnableMotionConfig(num_joints=6, dim_in=2, dim_feat=8, dim_rep=4, depth=1, num_heads=2)
    )
    with pytest.raises(RuntimeError):
        wrong.load_state_dict(load_file(str(path)), strict=True)


def test_learnable_motion_config_validation() -> None:
    with pytest.raises(ValueError, match="downsample"):
        LearnableMotionConfig(downsample=0)
    with pytest.raises(ValueError, match="out_channels"):
        LearnableMotionConfig(out_channels=0)


def test_learnable_motion_parts_io_round_trip(tmp_path: Path) -> None:
    from momu.parts_io import load_part, save_part

    cfg = LearnableMotionConfig(
        num_joints=5, dim_in=2, dim_feat=8, dim_rep=4, depth=1, num_heads=2, downsample=2
    )
    enc = LearnableMotionEncoder(cfg).eval()
    save_part(enc, "encoders", "learnable_motion", cfg, tmp_path / "enc")
    loaded = load_part(tmp_path / "enc").eval()
    assert isinstance(loaded, LearnableMotionEncoder) and loaded.cfg == cfg
    x = torch.randn(2, 6, 5, 2)
    torch.testing.assert_close(loaded(x), enc(x))


def test_learnable_motion_velocity_input_sees_displacements_and_ignores_padding() -> None:
    from momu.encoders.learnable_motion import LearnableMotionConfig, LearnableMotionEncoder

    torch.manual_seed(0)
    cfg = LearnableMotionConfig(num_joints=5, dim_in=2, dim_feat=8, dim_rep=4, depth=1, num_heads=2,
                                out_channels=3, velocity=True)  # fmt: skip
    enc = LearnableMotionEncoder(cfg).eval()
    assert enc.backbone.cfg.dim_in == 4  # positions and their first differences
    x = torch.randn(1, 6, 5, 2)
    moved = x + torch.tensor([3.0, -1.0])  # a translated copy: same displacements, other positions
    with torch.no_grad():
        ref = enc(x)
        assert not torch.allclose(enc(moved), ref)  # positions are still seen
        padded = torch.cat([x, torch.full((1, 4, 5, 2), 9.0)], dim=1)
        mask = torch.zeros(1, 10, dtype=torch.bool)
        mask[:, :6] = True
        torch.testing.assert_close(enc(padded, mask)[:, :6], ref, atol=1e-5, rtol=1e-5)


def test_learnable_motion_standardizes_its_inputs_with_training_statistics(tmp_path: Path) -> None:
    """``set_statistics`` makes each joint feature (position and displacement) zero-mean, unit-std on
    the training motion: a skeleton's fixed joint offsets no longer dwarf its movement (issue 12)."""
    cfg = LearnableMotionConfig(
        num_joints=5, dim_in=2, dim_feat=8, dim_rep=4, depth=1, num_heads=2, out_channels=3, velocity=True
    )
    enc = LearnableMotionEncoder(cfg).eval()
    offsets = torch.arange(10.0).reshape(1, 1, 5, 2) * 3.0  # fixed joint layout
    train = offsets + 0.05 * torch.randn(16, 12, 5, 2)  # small movement around it
    before = enc(train)
    enc.set_statistics(train)
    assert enc.input_mean.shape == enc.input_std.shape == (5, 4)
    z = (enc.features(train) - enc.input_mean) / enc.input_std
    torch.testing.assert_close(z.mean(dim=(0, 1)), torch.zeros(5, 4), atol=1e-3, rtol=0)
    torch.testing.assert_close(z.std(dim=(0, 1)), torch.ones(5, 4), atol=1e-3, rtol=0)
    assert not torch.allclose(enc(train), before)
    # the statistics are buffers: they travel with the weights
    path = tmp_path / "enc.safetensors"
    save_file({k: v.contiguous() for k, v in enc.state_dict().items()}, str(path))
    other = LearnableMotionEncoder(cfg).eval()
    other.load_state_dict(load_file(str(path)), strict=True)
    torch.testing.assert_close(other(train), enc(train))
    # standardize=False keeps the identity transform
    plain = LearnableMotionEncoder(dataclasses.replace(cfg, standardize=False))
    plain.set_statistics(train)
    assert bool((plain.input_mean == 0).all()) and bool((plain.input_std == 1).all())
