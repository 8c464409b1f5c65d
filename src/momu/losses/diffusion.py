"""``diffusion``: the ε-prediction objective with condition dropout (MoMu Eq. 6, §4 "null" condition).

L = ‖ε_θ(z_t, t, c) − ε‖²₂ with t ~ U{0, …, T−1}, ε ~ N(0, I) and z_t from the scheduler's
closed-form forward diffusion (Eq. 5). A scheduler whose ``prediction_type`` is ``sample`` trains
the denoiser to output ẑ_0 instead, L = ‖x̂_θ(z_t, t, c) − z_0‖²₂ (MDM, EDGE), and ``v_prediction``
the velocity v = √ᾱ ε − √(1−ᾱ) z_0; the output's ε̂ and ẑ_0 are both returned either way. With
probability ``cond_drop_prob`` an item's condition is replaced by the backbone's learned null
embedding (``drop_cond``), which trains the unconditional branch used by classifier-free guidance
(Eq. 7). The mean runs over valid frames only.
"""

from __future__ import annotations

from dataclasses import dataclass

import torch
from torch import Tensor, nn

from momu.registry import LOSSES
from momu.samplers.base import Backbone, resolve_scheduler
from momu.schedulers.diffusers_schedulers import NoiseScheduler

__all__ = ["DiffusionLossConfig", "DiffusionLoss", "DiffusionLossOutput", "build_diffusion_loss"]


@dataclass
class DiffusionLossConfig:
    """ε-prediction loss.

    Attributes:
        cond_drop_prob: probability p of replacing an item's condition by the null embedding
            (the paper does not give p; 0.1 is the common classifier-free-guidance value).
    """

    cond_drop_prob: float = 0.1


@dataclass
class DiffusionLossOutput:
    """Everything a caller may need beyond the scalar (MoFusion's kinematic losses use ``x0_pred``).

    Attributes:
        loss: scalar masked MSE (Eq. 6).
        eps_pred: ``(B, T, C)`` predicted noise.
        noise: ``(B, T, C)`` true noise ε.
        x_t: ``(B, T, C)`` noised input.
        t: ``(B,)`` sampled timesteps.
        x0_pred: ``(B, T, C)`` ẑ_0 = (z_t − √(1−ᾱ_t) ε̂) / √ᾱ_t.
        dropped: ``(B,)`` bool, items trained with the null condition.
    """

    loss: Tensor
    eps_pred: Tensor
    noise: Tensor
    x_t: Tensor
    t: Tensor
    x0_pred: Tensor
    dropped: Tensor


def masked_mse(pred: Tensor, target: Tensor, mask: Tensor | None) -> Tensor:
    """Mean squared error over valid frames: Σ m·(p−y)² / (Σ m · C); ``mask (B, T)`` bool."""
    if mask is None:
        return torch.mean((pred - target) ** 2)
    m = mask[..., None].to(pred.dtype)
    denom = (m.sum() * pred.shape[-1]).clamp_min(1.0)
    return (((pred - target) ** 2) * m).sum() / denom


class DiffusionLoss(nn.Module):
    """MoMu Eq. 6 with CFG condition dropout; call ``loss(backbone, x0, cond, ...)``."""

    def __init__(self, cfg: DiffusionLossConfig, scheduler: NoiseScheduler) -> None:
        super().__init__()
        if not 0.0 <= cfg.cond_drop_prob <= 1.0:
            raise ValueError(f"diffusion.cond_drop_prob must be in [0, 1], got {cfg.cond_drop_prob}")
        self.cfg = cfg
        self.scheduler = scheduler

    def forward(
        self,
        backbone: Backbone,
        x0: Tensor,
        cond: Tensor | None = None,
        *,
        x_mask: Tensor | None = None,
        cond_mask: Tensor | None = None,
        t: Tensor | None = None,
        noise: Tensor | None = None,
        generator: torch.Generator | None = None,
    ) -> DiffusionLossOutput:
        """Noise ``x0 (B, T, C)`` at random (or given) ``t``, predict ε, return the masked MSE.

        Args:
            backbone: the denoiser (backbone protocol).
            x0: clean sequences; padded frames (``x_mask`` False) are ignored.
            cond: ``(B, Tc, Cc)`` condition or ``None`` (unconditional model / null condition).
            t: ``(B,)`` timesteps (default: uniform); ``noise``: ε (default: standard normal).
            generator: seeds t, ε and the dropout draw.
        """
        if x0.ndim != 3:
            raise ValueError(f"x0: expected (B, T, C), got {tuple(x0.shape)}")
        b = x0.shape[0]
        dev = x0.device
        gen_dev = generator.device if generator is not None else dev
        if t is None:
            t = self.scheduler.sample_timesteps(b, generator=generator, device=gen_dev).to(dev)
        if noise is None:
            noise = torch.randn(x0.shape, generator=generator, device=gen_dev, dtype=x0.dtype).to(dev)
        if x_mask is not None:
            keep = x_mask[..., None].to(x0.dtype)
            x0, noise = x0 * keep, noise * keep
        x_t = self.scheduler.add_noise(x0, noise, t)
        if cond is not None and self.cfg.cond_drop_prob > 0:
            dropped = (torch.rand(b, generator=generator, device=gen_dev) < self.cfg.cond_drop_prob).to(dev)
        else:
            dropped = torch.zeros(b, dtype=torch.bool, device=dev)
        output = backbone(
            x_t, t, cond, x_mask=x_mask, cond_mask=cond_mask, drop_cond=dropped if cond is not None else None
        )
        loss = masked_mse(output, self.scheduler.target(x0, noise, t), x_mask)
        eps_pred = self.scheduler.eps_of(x_t, output, t)
        x0_pred = self.scheduler.x0_of(x_t, output, t)
        return DiffusionLossOutput(loss, eps_pred, noise, x_t, t, x0_pred, dropped)


@LOSSES.register("diffusion", config=DiffusionLossConfig)
def build_diffusion_loss(cfg: DiffusionLossConfig, scheduler: object = None, **deps: object) -> DiffusionLoss:
    """Build the ε-prediction loss over ``scheduler`` (a NoiseScheduler or node; default ``ddpm``)."""
    return DiffusionLoss(cfg, resolve_scheduler(scheduler if scheduler is not None else "ddpm"))
