"""VAE loss (reconstruction + lambda KL) and the two-step GAN update of MoMu App. A.2 (Eq. 10)."""

from __future__ import annotations

import math

import pytest
import torch
from tests.helpers.encoders import TINY_VAE

from momu.encoders.bicor_vae import MelVAE
from momu.encoders.discriminator import MelDiscriminator, MelDiscriminatorConfig
from momu.encoders.vae import DiagonalGaussian
from momu.losses.gan import GANLoss, GANLossConfig, requires_grad, two_step_update
from momu.losses.vae import VAELoss, VAELossConfig, reconstruction_error
from momu.registry import LOSSES


def standard_normal(shape: tuple[int, ...] = (2, 3, 4)) -> DiagonalGaussian:
    return DiagonalGaussian(torch.zeros(shape), torch.zeros(shape))


# ----------------------------------------------------------------------------- vae
def test_registered_defaults_are_the_paper_weights() -> None:
    assert LOSSES.build("vae").cfg.kl_weight == 1e-5  # lambda1 = lambda3 (App. A.2)
    gan = LOSSES.build("gan")
    assert gan.cfg.weight == 0.5  # lambda2
    assert LOSSES.build("rhythmic_contrastive").cfg.weight == 1.0  # lambda4


def test_vae_loss_l1_mean_by_hand() -> None:
    loss = VAELoss(VAELossConfig(kl_weight=0.1))
    out = loss(torch.ones(2, 3), torch.zeros(2, 3), standard_normal())
    assert out["reconstruction"].item() == pytest.approx(1.0)
    assert out["kl"].item() == pytest.approx(0.0)
    assert out["loss"].item() == pytest.approx(1.0)


def test_vae_loss_kl_term_and_weight_by_hand() -> None:
    # mean 1, logvar 0: 0.5 per latent element; 2 x 3 elements per item.
    q = DiagonalGaussian(torch.ones(1, 2, 3), torch.zeros(1, 2, 3))
    mean = VAELoss(VAELossConfig(kl_weight=0.5, reduction="mean"))(torch.zeros(1, 4), torch.zeros(1, 4), q)
    assert mean["kl"].item() == pytest.approx(0.5)
    assert mean["loss"].item() == pytest.approx(0.25)
    summed = VAELoss(VAELossConfig(kl_weight=0.5, reduction="sum"))(torch.zeros(1, 4), torch.zeros(1, 4), q)
    assert summed["kl"].item() == pytest.approx(3.0)


def test_reconstruction_sum_reduction_is_per_item_sum_batch_mean() -> None:
    # Item 0 errors 2 everywhere (squared 4, 3 elements = 12); item 1 exact. Batch mean = 6.
    rec = torch.stack([torch.full((3,), 2.0), torch.zeros(3)])
    assert reconstruction_error(rec, torch.zeros(2, 3), "mse", "sum").item() == pytest.approx(6.0)
    assert reconstruction_error(rec, torch.zeros(2, 3), "mse", "mean").item() == pytest.approx(2.0)


def test_reconstruction_mask_ignores_masked_elements() -> None:
    rec = torch.tensor([[1.0, 5.0]])
    mask = torch.tensor([[True, False]])
    assert reconstruction_error(rec, torch.zeros(1, 2), "l1", "mean", mask).item() == pytest.approx(1.0)


def test_velocity_term_by_hand() -> None:
    # A step 0, 0, 1, 1 decoded as a ramp 0, .5, .5, 1: L1 position error mean .25, velocity
    # (diffs 0, 1, 0 vs .5, 0, .5) error mean 2/3. Time is dim 1 of (B, T, C).
    target = torch.tensor([0.0, 0.0, 1.0, 1.0]).view(1, 4, 1)
    ramp = torch.tensor([0.0, 0.5, 0.5, 1.0]).view(1, 4, 1)
    loss = VAELoss(VAELossConfig(kl_weight=0.0, velocity_weight=3.0))
    out = loss(ramp, target, standard_normal(), time_dim=1)
    assert out["reconstruction"].item() == pytest.approx(0.25)
    assert out["velocity"].item() == pytest.approx(2 / 3)
    assert out["loss"].item() == pytest.approx(0.25 + 3.0 * 2 / 3)
    # a constant offset has no velocity error; without a time axis there is no velocity term
    assert loss(target + 1.0, target, standard_normal(), time_dim=1)["velocity"].item() == 0.0
    assert "velocity" not in loss(ramp, target, standard_normal())
    # masked frames: only the pair (frame 0, frame 1) is valid -> |0.5 - 0| = 0.5
    mask = torch.tensor([True, True, False, False]).view(1, 4, 1)
    assert loss(ramp, target, standard_normal(), mask=mask, time_dim=1)["velocity"].item() == pytest.approx(
        0.5
    )
    with pytest.raises(ValueError, match="velocity_weight"):
        VAELoss(VAELossConfig(velocity_weight=-1.0))


def test_vae_loss_errors() -> None:
    with pytest.raises(ValueError, match="shapes differ"):
        VAELoss()(torch.zeros(1, 2), torch.zeros(1, 3), standard_normal())
    with pytest.raises(ValueError, match="reconstruction"):
        VAELoss(VAELossConfig(reconstruction="l3"))
    with pytest.raises(ValueError, match="kl_weight"):
        VAELoss(VAELossConfig(kl_weight=-1.0))


# ----------------------------------------------------------------------------- gan objectives
def test_lsgan_objectives_by_hand() -> None:
    gan = GANLoss(GANLossConfig(objective="lsgan"))
    assert gan.discriminator_loss(torch.ones(4), torch.zeros(4)).item() == pytest.approx(0.0)
    assert gan.discriminator_loss(torch.zeros(4), torch.ones(4)).item() == pytest.approx(1.0)
    assert gan.generator_loss(torch.zeros(4)).item() == pytest.approx(1.0)
    assert gan.generator_loss(torch.ones(4)).item() == pytest.approx(0.0)


def test_hinge_and_vanilla_objectives_by_hand() -> None:
    hinge = GANLoss(GANLossConfig(objective="hinge"))
    assert hinge.discriminator_loss(torch.full((3,), 2.0), torch.full((3,), -2.0)).item() == pytest.approx(
        0.0
    )
    assert hinge.discriminator_loss(torch.zeros(3), torch.zeros(3)).item() == pytest.approx(2.0)
    assert hinge.generator_loss(torch.full((3,), 0.5)).item() == pytest.approx(-0.5)
    vanilla = GANLoss(GANLossConfig(objective="vanilla"))
    assert vanilla.discriminator_loss(torch.zeros(1), torch.zeros(1)).item() == pytest.approx(2 * math.log(2))
    assert vanilla.generator_loss(torch.zeros(1)).item() == pytest.approx(math.log(2))


def test_adaptive_weight_is_the_gradient_norm_ratio() -> None:
    w = torch.tensor([2.0], requires_grad=True)
    rec, g = 3.0 * w.sum(), 4.0 * w.sum()  # gradients 3 and 4 at the "last layer"
    gan = GANLoss(GANLossConfig(weight=0.5))
    assert gan.generator_weight(rec, g, w).item() == pytest.approx(0.5 * 3.0 / (4.0 + 1e-4))
    fixed = GANLoss(GANLossConfig(weight=0.5, adaptive_weight=False))
    assert fixed.generator_weight(rec, g, w).item() == pytest.approx(0.5)


def test_unknown_objective_is_rejected() -> None:
    with pytest.raises(ValueError, match="objective"):
        GANLoss(GANLossConfig(objective="wgan"))


def test_requires_grad_context_restores_flags() -> None:
    lin = torch.nn.Linear(2, 2)
    lin.bias.requires_grad_(False)
    with requires_grad(lin, False):
        assert not lin.weight.requires_grad
    assert lin.weight.requires_grad and not lin.bias.requires_grad


# ----------------------------------------------------------------------------- two-step update
def _setup(vae_lr: float, disc_lr: float, seed: int = 0) -> tuple:
    torch.manual_seed(seed)
    vae = MelVAE(16, TINY_VAE)
    disc = MelDiscriminator(MelDiscriminatorConfig(mel_bins=16, channels=4, num_layers=2))
    opt_v = torch.optim.SGD(vae.parameters(), lr=vae_lr)
    opt_d = torch.optim.SGD(disc.parameters(), lr=disc_lr)
    return vae, disc, opt_v, opt_d


def _snapshot(module: torch.nn.Module) -> dict[str, torch.Tensor]:
    return {k: v.detach().clone() for k, v in module.state_dict().items()}


def _changed(module: torch.nn.Module, before: dict[str, torch.Tensor]) -> bool:
    return any(not torch.equal(v, before[k]) for k, v in module.state_dict().items())


def _step(vae, disc, opt_v, opt_d, step: int = 0, gan_cfg: GANLossConfig | None = None, **kw):  # type: ignore[no-untyped-def]
    mel = torch.randn(2, 16, 8, generator=torch.Generator().manual_seed(1))
    return two_step_update(
        vae,
        disc,
        mel,
        vae_loss=VAELoss(),
        gan_loss=GANLoss(gan_cfg or GANLossConfig()),
        vae_optimizer=opt_v,
        discriminator_optimizer=opt_d,
        step=step,
        generator=torch.Generator().manual_seed(2),
        **kw,
    )


def test_generator_step_updates_only_the_vae() -> None:
    vae, disc, opt_v, opt_d = _setup(vae_lr=0.1, disc_lr=0.0)
    v0, d0 = _snapshot(vae), _snapshot(disc)
    out = _step(vae, disc, opt_v, opt_d)
    assert _changed(vae, v0)
    assert not _changed(disc, d0)
    assert out["generator_weight"] > 0 and out["discriminator"] > 0


def test_discriminator_step_updates_only_the_discriminator() -> None:
    vae, disc, opt_v, opt_d = _setup(vae_lr=0.0, disc_lr=0.1)
    v0, d0 = _snapshot(vae), _snapshot(disc)
    _step(vae, disc, opt_v, opt_d)
    assert not _changed(vae, v0)
    assert _changed(disc, d0)


def test_discriminator_gradient_is_that_of_the_discriminator_loss_alone() -> None:
    # The generator step must not leave gradients on the discriminator: after the update, the
    # discriminator's .grad equals the gradient of L_D on (real, reconstruction before the update).
    vae, disc, opt_v, opt_d = _setup(vae_lr=0.1, disc_lr=0.0)
    mel = torch.randn(2, 16, 8, generator=torch.Generator().manual_seed(1))
    recon = vae(mel, generator=torch.Generator().manual_seed(2)).reconstruction.detach()
    gan = GANLoss()
    expected = torch.autograd.grad(gan.discriminator_loss(disc(mel), disc(recon)), list(disc.parameters()))
    _step(vae, disc, opt_v, opt_d)
    for p, g in zip(disc.parameters(), expected):
        torch.testing.assert_close(p.grad, g)


def test_adversarial_terms_wait_for_start_step() -> None:
    vae, disc, opt_v, opt_d = _setup(vae_lr=0.1, disc_lr=0.1)
    d0 = _snapshot(disc)
    out = _step(vae, disc, opt_v, opt_d, step=4, gan_cfg=GANLossConfig(start_step=5))
    assert not _changed(disc, d0)
    assert out["generator"] == 0.0 and out["discriminator"] == 0.0
    assert out["loss"] == pytest.approx(out["reconstruction"] + 1e-5 * out["kl"], rel=1e-6)


def test_custom_backward_is_used_for_both_steps() -> None:
    vae, disc, opt_v, opt_d = _setup(vae_lr=0.1, disc_lr=0.1)
    calls: list[float] = []

    def backward(loss: torch.Tensor) -> None:
        calls.append(float(loss.detach()))
        loss.backward()

    out = _step(vae, disc, opt_v, opt_d, backward=backward)
    assert calls == [pytest.approx(out["loss"]), pytest.approx(out["discriminator"])]


def test_stage1_loss_is_eq10() -> None:
    vae, disc, opt_v, opt_d = _setup(vae_lr=0.0, disc_lr=0.0)
    out = _step(vae, disc, opt_v, opt_d)
    eq10 = out["reconstruction"] + 1e-5 * out["kl"] + out["generator_weight"] * out["generator"]
    assert out["loss"] == pytest.approx(eq10, rel=1e-6)


def test_gan_training_sharpens_reconstructions() -> None:
    """A few stage-1 steps on a fixed batch reduce the reconstruction error (the loop trains)."""
    vae, disc, _, _ = _setup(0.0, 0.0)
    opt_v = torch.optim.AdamW(vae.parameters(), lr=3e-3)
    opt_d = torch.optim.AdamW(disc.parameters(), lr=3e-3)
    first = _step(vae, disc, opt_v, opt_d)["reconstruction"]
    for i in range(1, 30):
        last = _step(vae, disc, opt_v, opt_d, step=i)["reconstruction"]
    assert last < 0.8 * first
