"""GAN loss and the two-step generator/discriminator update of MoMu App. A.2 (Eq. 10, lambda2 = 0.5).

Stage 1 of BiCoR-VAE trains the mel-spectrogram VAE with
``L_stage1 = L_recon + lambda1 L_KL + lambda2 L_GAN`` (Eq. 10). "The GAN loss contains two steps: it
first updates the generator part (mel-spectrogram VAE) with L_stage1, and then updates the
additional discriminator" (App. A.2). :func:`two_step_update` performs exactly these two steps.

Adversarial objective (``objective``):

* ``"lsgan"`` (default): least squares, ``L_D = ½E[(D(x) − 1)²] + ½E[D(x̂)²]``,
  ``L_G = E[(D(x̂) − 1)²]``. Chosen because it is the objective of the mel VAE MoMu's Table 8
  reproduces (Make-An-Audio 2's autoencoder, ``disc_loss: mse``) and of the HiFi-GAN/BigVGAN
  family MoMu pairs it with; its non-saturating quadratic penalties give the VAE useful gradients
  even when the discriminator is confident, which a sigmoid cross-entropy loses.
* ``"hinge"``: ``L_D = E[relu(1 − D(x))] + E[relu(1 + D(x̂))]``, ``L_G = −E[D(x̂)]``.
* ``"vanilla"``: non-saturating cross-entropy, ``L_D = E[softplus(−D(x))] + E[softplus(D(x̂))]``,
  ``L_G = E[softplus(−D(x̂))]``.

Weighting: ``lambda2`` is ``weight``. With ``adaptive_weight`` (default), the generator term is
also scaled by ``‖∇_w L_recon‖ / (‖∇_w L_G‖ + 1e-4)`` at the decoder's last layer ``w`` (clamped to
``[0, max_adaptive_weight]``) — the latent-diffusion autoencoder rule in which that 0.5 is the
``disc_weight`` — so the adversarial gradient is commensurate with the reconstruction gradient
whatever the reconstruction reduction. Before ``start_step`` neither the generator term nor the
discriminator update is applied.
"""

from __future__ import annotations

import contextlib
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from typing import Any

import torch
import torch.nn.functional as F
from torch import nn

from momu.registry import LOSSES

__all__ = ["GANLossConfig", "GANLoss", "build_gan_loss", "requires_grad", "two_step_update"]

_OBJECTIVES = ("lsgan", "hinge", "vanilla")


@dataclass
class GANLossConfig:
    """Attributes:
    weight: lambda2 of MoMu Eq. 10 (0.5).
    objective: ``"lsgan"``, ``"hinge"`` or ``"vanilla"`` (module docstring).
    adaptive_weight: scale the generator term by the gradient-norm ratio at the decoder's last layer.
    max_adaptive_weight: clamp of that ratio.
    start_step: first step (0-based) at which the adversarial terms are used.
    discriminator_weight: factor on the discriminator loss.
    """

    weight: float = 0.5
    objective: str = "lsgan"
    adaptive_weight: bool = True
    max_adaptive_weight: float = 1e4
    start_step: int = 0
    discriminator_weight: float = 1.0


class GANLoss(nn.Module):
    """Generator / discriminator objectives over discriminator logits (any shape, e.g. PatchGAN maps)."""

    def __init__(self, cfg: GANLossConfig | None = None) -> None:
        super().__init__()
        cfg = cfg or GANLossConfig()
        if cfg.objective not in _OBJECTIVES:
            raise ValueError(f"gan loss objective must be one of {_OBJECTIVES}, got {cfg.objective!r}")
        if cfg.weight < 0 or cfg.discriminator_weight < 0 or cfg.max_adaptive_weight <= 0:
            raise ValueError("gan loss weights must be >= 0 and max_adaptive_weight > 0")
        if cfg.start_step < 0:
            raise ValueError(f"gan loss start_step must be >= 0, got {cfg.start_step}")
        self.cfg = cfg

    def active(self, step: int) -> bool:
        """Whether the adversarial terms apply at ``step``."""
        return step >= self.cfg.start_step

    def generator_loss(self, fake_logits: torch.Tensor) -> torch.Tensor:
        """``L_G`` (unweighted): small when the discriminator calls reconstructions real."""
        if self.cfg.objective == "lsgan":
            return (fake_logits - 1.0).pow(2).mean()
        if self.cfg.objective == "hinge":
            return -fake_logits.mean()
        return F.softplus(-fake_logits).mean()

    def discriminator_loss(self, real_logits: torch.Tensor, fake_logits: torch.Tensor) -> torch.Tensor:
        """``L_D`` times ``discriminator_weight``: small when real scores high and fake low."""
        if self.cfg.objective == "lsgan":
            loss = 0.5 * ((real_logits - 1.0).pow(2).mean() + fake_logits.pow(2).mean())
        elif self.cfg.objective == "hinge":
            loss = F.relu(1.0 - real_logits).mean() + F.relu(1.0 + fake_logits).mean()
        else:
            loss = F.softplus(-real_logits).mean() + F.softplus(fake_logits).mean()
        return self.cfg.discriminator_weight * loss

    def generator_weight(
        self, reconstruction_loss: torch.Tensor, generator_loss: torch.Tensor, last_layer: torch.Tensor | None
    ) -> torch.Tensor:
        """``lambda2`` times the adaptive ratio (detached scalar); just ``lambda2`` without adaptation."""
        weight = torch.tensor(self.cfg.weight, device=generator_loss.device, dtype=generator_loss.dtype)
        if not self.cfg.adaptive_weight or last_layer is None or not torch.is_grad_enabled():
            return weight
        (g_rec,) = torch.autograd.grad(reconstruction_loss, last_layer, retain_graph=True)
        (g_adv,) = torch.autograd.grad(generator_loss, last_layer, retain_graph=True)
        ratio = g_rec.norm() / (g_adv.norm() + 1e-4)
        return weight * ratio.clamp(0.0, self.cfg.max_adaptive_weight).detach()

    def forward(self, fake_logits: torch.Tensor) -> torch.Tensor:
        """The generator term ``L_G`` (unweighted); see :func:`two_step_update` for the full step."""
        return self.generator_loss(fake_logits)


@LOSSES.register("gan", config=GANLossConfig)
def build_gan_loss(cfg: GANLossConfig) -> GANLoss:
    """Registry factory: the adversarial objective of MoMu Eq. 10."""
    return GANLoss(cfg)


@contextlib.contextmanager
def requires_grad(module: nn.Module, flag: bool) -> Iterator[None]:
    """Temporarily set ``requires_grad`` of every parameter of ``module`` (restored afterwards)."""
    params = list(module.parameters())
    before = [p.requires_grad for p in params]
    for p in params:
        p.requires_grad_(flag)
    try:
        yield
    finally:
        for p, b in zip(params, before):
            p.requires_grad_(b)


def two_step_update(
    vae: nn.Module,
    discriminator: nn.Module,
    x: torch.Tensor,
    *,
    vae_loss: Callable[..., dict[str, torch.Tensor]],
    gan_loss: GANLoss,
    vae_optimizer: torch.optim.Optimizer,
    discriminator_optimizer: torch.optim.Optimizer,
    step: int,
    backward: Callable[[torch.Tensor], Any] | None = None,
    generator: torch.Generator | None = None,
) -> dict[str, float]:
    """One stage-1 iteration of MoMu App. A.2: update the VAE with Eq. 10, then the discriminator.

    1. Generator step: ``out = vae(x)``; ``L = L_recon + lambda1 L_KL + w L_G(D(x̂))`` with
       ``w = gan_loss.generator_weight(...)``; the discriminator's parameters do not require
       gradients during this step (a DDP-wrapped discriminator is called through its ``.module``),
       so only ``vae_optimizer``'s parameters receive gradients.
    2. Discriminator step: ``L_D(D(x), D(x̂.detach()))``; only ``discriminator_optimizer`` steps.

    Args:
        vae: a :class:`momu.encoders.vae.SequenceVAE` (``vae(x)`` returns a ``VAEOutput`` whose
            ``reconstruction`` / ``target`` are what the discriminator judges, e.g. mels ``(B, 80, T)``).
        discriminator: e.g. :class:`momu.encoders.discriminator.MelDiscriminator`.
        x: a batch of VAE inputs.
        vae_loss: :class:`momu.losses.vae.VAELoss` (``kl_weight`` = lambda1).
        step: the global step (the adversarial terms start at ``gan_loss.cfg.start_step``).
        backward: how to back-propagate (``accelerator.backward``; default ``loss.backward()``).

    Returns:
        Floats ``loss`` (Eq. 10), ``reconstruction``, ``kl``, ``generator``, ``generator_weight``,
        ``discriminator`` (0.0 for the adversarial entries before ``start_step``).
    """
    run_backward = backward or (lambda loss: loss.backward())
    active = gan_loss.active(step)

    # Step 1: generator (the VAE) with L_stage1.
    out = vae(x, generator=generator)
    terms = vae_loss(out.reconstruction, out.target, out.posterior)
    total = terms["loss"]
    g_loss = torch.zeros((), device=total.device)
    g_weight = torch.zeros((), device=total.device)
    if active:
        # The frozen discriminator is called unwrapped (no DDP forward bookkeeping for a step that
        # synchronises no discriminator gradients).
        frozen_disc = getattr(discriminator, "module", discriminator)
        with requires_grad(frozen_disc, False):
            g_loss = gan_loss.generator_loss(frozen_disc(out.reconstruction))
            last = getattr(getattr(vae, "module", vae), "last_layer", None)  # unwrap DDP
            g_weight = gan_loss.generator_weight(terms["reconstruction"], g_loss, last)
            total = total + g_weight * g_loss
            vae_optimizer.zero_grad(set_to_none=True)
            run_backward(total)
    else:
        vae_optimizer.zero_grad(set_to_none=True)
        run_backward(total)
    vae_optimizer.step()

    # Step 2: discriminator on real vs detached reconstructions.
    d_loss = torch.zeros((), device=total.device)
    if active:
        discriminator_optimizer.zero_grad(set_to_none=True)
        d_loss = gan_loss.discriminator_loss(
            discriminator(out.target.detach()), discriminator(out.reconstruction.detach())
        )
        run_backward(d_loss)
        discriminator_optimizer.step()

    return {
        "loss": float(total.detach()),
        "reconstruction": float(terms["reconstruction"].detach()),
        "kl": float(terms["kl"].detach()),
        "generator": float(g_loss.detach()),
        "generator_weight": float(g_weight.detach()),
        "discriminator": float(d_loss.detach()),
    }
