"""The learnable-motion motion→music stage of MoMu Tables 3–4 (momu.methods.momu.learnable)."""

from __future__ import annotations

import pytest
import torch

from momu.config import build_component
from momu.methods.momu.learnable import LearnableMotionStage, MotionLatentDataset, learnable_encoder_node
from momu.registry import BACKBONES, ENCODERS, LOSSES


def _stage(latent: int = 4, joints: int = 5, k: int = 2) -> LearnableMotionStage:
    torch.manual_seed(0)
    node = learnable_encoder_node(
        {"name": "learnable_motion", "dim_feat": 8, "dim_rep": 4, "depth": 1, "num_heads": 2},
        num_joints=joints,
        joint_dims=2,
        latent_channels=latent,
        downsample=k,
    )
    encoder = build_component(node, "encoders")
    backbone = BACKBONES.build(
        "dit",
        {
            "in_channels": latent,
            "cond_channels": latent,
            "hidden": 16,
            "heads": 2,
            "depth": 1,
            "cond_embed_dim": 16,
        },
    )
    loss = LOSSES.build("diffusion", {"cond_drop_prob": 0.0})
    return LearnableMotionStage(encoder, backbone, loss, latent)


def test_encoder_node_gets_the_data_derived_fields() -> None:
    node = learnable_encoder_node(
        {"name": "learnable_motion", "depth": 3},
        num_joints=17,
        joint_dims=2,
        latent_channels=20,
        downsample=2,
    )
    assert node == {
        "name": "learnable_motion",
        "depth": 3,
        "num_joints": 17,
        "dim_in": 2,
        "out_channels": 20,
        "downsample": 2,
    }
    assert ENCODERS.get("learnable_motion").name == "learnable_motion"
    with pytest.raises(ValueError, match="learnable_motion"):
        learnable_encoder_node(
            {"name": "waveform"}, num_joints=1, joint_dims=2, latent_channels=4, downsample=1
        )


def test_condition_has_one_frame_per_latent_frame() -> None:
    stage = _stage(latent=4, joints=5, k=2)
    cond = stage.condition(torch.randn(3, 14, 5, 2))  # 7 latent frames x k = 2 motion frames
    assert cond.shape == (3, 7, 4)


def test_diffusion_loss_trains_encoder_and_denoiser_end_to_end() -> None:
    """MoMu §5.1: the encoder has no separate pre-training; the ε-loss reaches its parameters."""
    stage = _stage()
    z = torch.randn(6, 7, 4) * 3.0 + 1.0
    stage.set_statistics(z)
    flat = z.reshape(-1, 4)
    assert torch.allclose(stage.music_mean, flat.mean(0), atol=1e-5)
    assert torch.allclose(stage.music_std, flat.std(0), atol=1e-5)
    data = MotionLatentDataset(z, torch.randn(6, 14, 5, 2))
    batch = {k: torch.stack([data[i][k] for i in range(len(data))]) for k in ("z_music", "motion")}
    loss, logs = stage(batch)
    assert torch.isfinite(loss) and logs["motion2music"] == pytest.approx(float(loss.detach()))
    loss.backward()
    enc_grads = [p.grad for p in stage.encoder.parameters() if p.requires_grad]
    assert enc_grads and all(g is not None for g in enc_grads)
    assert sum(float(g.abs().sum()) for g in enc_grads if g is not None) > 0
    no_grad = [n for n, p in stage.backbone.named_parameters() if p.requires_grad and p.grad is None]
    assert all("null" in n for n in no_grad), no_grad  # only the null condition (no dropout here)
    assert set(stage.state_dict()) >= {"music_mean", "music_std"}  # statistics saved with the weights


def test_dataset_lengths_must_match() -> None:
    with pytest.raises(ValueError, match="3 music latents but 2 motion windows"):
        MotionLatentDataset(torch.zeros(3, 4, 2), torch.zeros(2, 8, 5, 2))
