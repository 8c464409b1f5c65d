"""HarmoGAN's registered parts build from their default configs and train on CPU; its losses and schedules."""

from __future__ import annotations

import dataclasses

import pytest
import torch

from momu.encoders.harmogan_discriminators import CrossModalDiscriminator, SpatioTemporalDiscriminator
from momu.encoders.harmogan_generator import HarmoGANGenerator
from momu.methods.harmogan.config import AdversarialSchedule, HarmoGANConfig, Schedule, lr_segments
from momu.methods.harmogan.stages import AdversarialStage, PretrainStage, feature_loss, kl_loss
from momu.registry import ENCODERS, LOSSES, METHODS

B, T, J, C = 3, 24, 21, 20


def _batch() -> dict[str, torch.Tensor]:
    g = torch.Generator().manual_seed(0)
    motion = 0.3 * torch.randn(B, T, J, 3, generator=g).cumsum(1) / T
    return {
        "mfcc": torch.randn(B, T, C, generator=g),
        "initial_poses": motion[:, :1].expand(B, T, J, 3).clone(),
        "transition": torch.cat([torch.ones(B, 4), torch.zeros(B, T - 4)], dim=1),
        "motion": motion,
        "pose_2d": motion[..., :2],
        "audio_times": torch.tensor([[0.2, 0.6, 1.0]] * B),
        "audio_saliency": torch.tensor([[1.0, 0.5, 0.7]] * B),
        "audio_mask": torch.ones(B, 3, dtype=torch.bool),
    }


def test_every_part_builds_from_its_default_config_and_backpropagates() -> None:
    batch = _batch()
    gen = ENCODERS.build("harmogan_generator")
    assert isinstance(gen, HarmoGANGenerator)
    out = gen(batch["mfcc"], batch["initial_poses"], batch["transition"])
    assert out.motion.shape == (B, T, J, 3) and out.pose_2d.shape == (B, T, J, 2)
    assert torch.equal(out.motion[..., :2], out.pose_2d)  # V'_2d is the projection of V' (depth lifting)
    d_cd = ENCODERS.build("harmogan_cross_modal_discriminator")
    d_st = ENCODERS.build("harmogan_spatiotemporal_discriminator")
    assert isinstance(d_cd, CrossModalDiscriminator) and isinstance(d_st, SpatioTemporalDiscriminator)
    logits = d_cd(batch["mfcc"], out.motion) + d_st(out.motion)
    assert logits.shape == (B,)
    logits.sum().backward()
    for module in (gen, d_cd, d_st):
        grads = [p.grad for p in module.parameters()]
        assert all(g is not None and torch.isfinite(g).all() for g in grads), type(module).__name__
    assert isinstance(METHODS.build("harmogan").cfg, HarmoGANConfig)


def test_generator_noise_is_seeded_and_dropout_only_in_training() -> None:
    batch = _batch()
    gen = ENCODERS.build("harmogan_generator").eval()
    a = gen(
        batch["mfcc"], batch["initial_poses"], batch["transition"], generator=torch.Generator().manual_seed(1)
    )
    b = gen(
        batch["mfcc"], batch["initial_poses"], batch["transition"], generator=torch.Generator().manual_seed(1)
    )
    c = gen(
        batch["mfcc"], batch["initial_poses"], batch["transition"], generator=torch.Generator().manual_seed(2)
    )
    assert torch.equal(a.motion, b.motion) and not torch.equal(a.motion, c.motion)
    with pytest.raises(ValueError, match="expected V_f"):
        gen(batch["mfcc"], batch["initial_poses"][:, :-1], batch["transition"])


def test_spatiotemporal_discriminator_sees_the_order_of_its_four_parts() -> None:
    d_st = ENCODERS.build("harmogan_spatiotemporal_discriminator").eval()
    motion = _batch()["motion"]
    quarters = torch.tensor_split(motion, 4, dim=1)
    swapped = torch.cat([quarters[1], quarters[0], quarters[2], quarters[3]], dim=1)
    assert not torch.allclose(d_st(motion), d_st(swapped))  # local-to-global in chronological order
    with pytest.raises(ValueError, match="power of 2"):
        ENCODERS.build("harmogan_spatiotemporal_discriminator", {"parts": 3})


def test_pose_losses() -> None:
    x = _batch()["motion"]
    assert float(kl_loss(x[..., :2], x[..., :2], 0.1)) == pytest.approx(0.0, abs=1e-6)
    assert float(kl_loss(x[..., :2] + 0.2 * torch.randn_like(x[..., :2]), x[..., :2], 0.1)) > 0
    assert float(feature_loss(x + 1.0, x)) == pytest.approx(0.0, abs=1e-5)  # a constant offset moves nothing
    assert float(feature_loss(x * 2.0, x)) > 0


def _adversarial(weights: object) -> AdversarialStage:
    return AdversarialStage(
        ENCODERS.build("harmogan_generator"),
        ENCODERS.build("harmogan_cross_modal_discriminator"),
        ENCODERS.build("harmogan_spatiotemporal_discriminator"),
        gan_loss=LOSSES.build("gan", {"objective": "vanilla", "adaptive_weight": False}),
        harmony_loss=LOSSES.build("harmony"),
        weights=weights,  # type: ignore[arg-type]
        kl_temperature=0.1,
        fps=15.0,
        generator_weight_decay=1e-4,
        discriminator_weight_decay=1e-3,
    )


def test_stages_give_disjoint_gradients() -> None:
    batch = _batch()
    cfg = HarmoGANConfig()
    pre = PretrainStage(ENCODERS.build("harmogan_generator"), cfg.pretrain_weights, 0.1)
    loss, logs = pre(batch)
    assert set(logs) == {"kl", "mse"} and torch.isfinite(loss)
    stage = _adversarial(cfg.weights)
    loss, logs = stage(batch)
    assert {"kl", "mse", "feat", "harmo", "gan", "d_cd", "d_st"} <= set(logs)
    # the discriminators' gradients are exactly those of Eq. 17-18 (plus weight decay): the generator's
    # terms (Eq. 19-20) reach them through detached parameters only
    stage.eval()  # no dropout: the same fake twice
    torch.manual_seed(0)
    stage(batch)[0].backward()
    full = [p.grad.clone() for p in stage.cross_modal.parameters()]  # type: ignore[union-attr]
    stage.zero_grad()
    torch.manual_seed(0)
    fake = stage.generator(batch["mfcc"], batch["initial_poses"], batch["transition"]).motion.detach()
    d_cd = stage.gan_loss.discriminator_loss(
        stage.cross_modal(batch["mfcc"], batch["motion"]), stage.cross_modal(batch["mfcc"], fake)
    )
    decay = 0.5 * 1e-3 * sum(p.pow(2).sum() for p in stage.cross_modal.parameters())
    (d_cd + decay).backward()
    for a, p in zip(full, stage.cross_modal.parameters()):
        assert torch.allclose(a, p.grad, atol=1e-6)  # type: ignore[arg-type]
    no_harmo = _adversarial(dataclasses.replace(cfg.weights, harmo=0.0))
    assert "harmo" not in no_harmo(batch)[1]


def test_paper_schedules_are_the_defaults() -> None:
    cfg = HarmoGANConfig()
    assert (cfg.pretrain.epochs, cfg.pretrain.batch_size, cfg.pretrain.lr) == (225, 10, 1e-3)
    assert [round(f, 6) for _, f in lr_segments(cfg.pretrain)] == [1.0, 0.5, 0.1, 0.02, 0.01]
    assert [n for n, _ in lr_segments(cfg.pretrain)] == [50, 50, 50, 50, 25]
    adv = cfg.adversarial
    assert (adv.epochs, adv.lr, adv.generator_weight_decay, adv.discriminator_weight_decay) == (
        45,
        1e-4,
        1e-4,
        1e-3,
    )
    factors = [f for _, f in lr_segments(adv)]
    assert len(factors) == 9 and factors[1] == pytest.approx(0.5) and factors[2] == pytest.approx(0.1)
    assert factors[-1] == pytest.approx(1e-4)  # ÷2 and ÷5 alternately: 1e-8 by epoch 40
    w = cfg.weights
    assert (w.kl, w.mse, w.feat, w.harmo, w.gan) == (1e-4, 1e-3, 1e-3, 1.0, 1e-3)
    assert (cfg.pretrain_weights.kl, cfg.pretrain_weights.mse) == (0.1, 1.0)
    assert lr_segments(Schedule(epochs=7, decay_every=0)) == [(7, 1.0)]
    assert lr_segments(AdversarialSchedule(epochs=12)) == [(5, 1.0), (5, 0.5), (2, pytest.approx(0.1))]


def test_momu_list_shows_the_harmogan_parts(capsys: pytest.CaptureFixture[str]) -> None:
    from momu.cli import main

    assert main(["list"]) == 0
    out = capsys.readouterr().out
    for name in (
        "harmogan_generator",
        "harmogan_cross_modal_discriminator",
        "harmogan_spatiotemporal_discriminator",
        "harmogan",
    ):
        assert name in out
    losses = out.split("losses")[1].split("samplers")[0]
    assert "harmony" in losses


def test_pose_losses_are_the_norms_of_eq_14_and_15() -> None:
    from momu.methods.harmogan.stages import mse_loss

    x = _batch()["motion"]
    shift = torch.zeros_like(x)
    shift[0] += 0.1  # item 0 off by 0.1 everywhere, the others exact
    expected = (0.1**2 * x[0].numel()) ** 0.5 / x.shape[0]
    assert float(mse_loss(x + shift, x)) == pytest.approx(expected, rel=1e-4)
    noise = ENCODERS.build("harmogan_generator").eval()._noise(x, torch.Generator().manual_seed(0))
    assert torch.equal(noise, noise[:, :1].expand_as(noise))  # one noise vector per unit
    per_frame = ENCODERS.build("harmogan_generator", {"noise_per_frame": True})._noise(x, None)
    assert not torch.equal(per_frame[:, 0], per_frame[:, 1])
