"""``cfg``: classifier-free guidance sampling (MoMu Eq. 7, Algorithm 1).

ε̂_θ(z_t, t, c) = ε_θ(z_t, t, ∅) + s·(ε_θ(z_t, t, c) − ε_θ(z_t, t, ∅)); the conditional and
unconditional branches run in one batched forward (see :func:`momu.samplers.base.guided_eps`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import torch
from torch import Tensor

from momu.registry import SAMPLERS
from momu.samplers.base import (
    Backbone,
    Generators,
    Guidance,
    check_noise_temperature,
    make_noise,
    module_device,
    resolve_scheduler,
    reverse_loop,
)
from momu.schedulers.diffusers_schedulers import NoiseScheduler

__all__ = ["CFGConfig", "CFGSampler", "build_cfg"]


def _default_scheduler() -> dict[str, Any]:
    return {"name": "ddim"}


@dataclass
class CFGConfig:
    """Classifier-free guidance sampler.

    Attributes:
        guidance_scale: s of MoMu Eq. 7 (the paper only states s > 1; 3.0 is the value of the
            Make-An-Audio line of latent audio diffusion MoMu builds on).
        guidance_interval: ``[low, high]`` training timesteps where the guidance applies (the steps
            outside are conditional, s = 1; :func:`momu.samplers.base.guided_eps`); ``None``: every step.
        guidance_rescale: φ of rescaled guidance (Lin et al. 2024 §3.4,
            :func:`momu.samplers.base.rescale_guided`): 0 (default) is plain Eq. 7, 1 scales the
            guided output to the conditional output's standard deviation.
        guidance_parallel: η of projected guidance (Sadat et al. 2025,
            :func:`momu.samplers.base.project_guided`): the weight of the guidance update's component
            parallel to the conditional output; 1 (default) is plain Eq. 7, 0 keeps only the
            orthogonal component.
        noise_temperature: τ > 0: the initial noise z_T is drawn from N(0, τ²I) (reduced-temperature
            sampling, as Glow's temperature T, Kingma & Dhariwal 2018). 1 (default) is the reverse
            process as trained; below 1 the seed decides less of the output. With a deterministic
            scheduler (DDIM, η = 0: Song et al. 2021 §4.1) z_T is its only randomness; a stochastic
            scheduler's per-step noise is not scaled.
        num_inference_steps: reverse steps; ``None`` uses the scheduler's (DDIM: 50, MoMu §5.1).
        scheduler: the scheduler node used when none is passed to the factory (default ``ddim``).
    """

    guidance_scale: float = 3.0
    num_inference_steps: int | None = None
    scheduler: Any = field(default_factory=_default_scheduler)
    guidance_interval: list[int] | None = None
    guidance_rescale: float = 0.0
    guidance_parallel: float = 1.0
    noise_temperature: float = 1.0


class CFGSampler:
    """Cross-modal generation with classifier-free guidance (MoMu Alg. 1, Eq. 7)."""

    def __init__(self, cfg: CFGConfig, scheduler: NoiseScheduler) -> None:
        self.cfg = cfg
        self.scheduler = scheduler
        self.guidance = Guidance.of(cfg)
        self.temperature = check_noise_temperature(cfg.noise_temperature)

    @torch.no_grad()
    def sample(
        self,
        backbone: Backbone,
        noise: Tensor | Sequence[int],
        cond: Tensor | None = None,
        *,
        x_mask: Tensor | None = None,
        cond_mask: Tensor | None = None,
        generator: Generators = None,
        guidance_scale: float | None = None,
        num_inference_steps: int | None = None,
    ) -> Tensor:
        """Generate ``z_0`` conditioned on ``cond``.

        Args:
            backbone: a denoiser following the backbone protocol (in eval mode).
            noise: initial ``z_T (B, T, C)``, or its shape to draw it from ``generator``.
            cond: ``(B, Tc, Cc)`` condition (e.g. the other modality's latent), or ``None``
                for unconditional sampling.
            x_mask: ``(B, T)`` valid frames for variable-length batches (MoMu §5.3).
            cond_mask: ``(B, Tc)`` valid condition frames.
            generator: seeds the initial noise and stochastic steps (one per item: batch-independent).
            guidance_scale: overrides ``cfg.guidance_scale``.
            num_inference_steps: overrides the configured number of steps.

        Returns:
            ``(B, T, C)`` generated sequence; zero at padded frames.
        """
        device, dtype = module_device(backbone)
        x_T = make_noise(noise, generator, device, dtype) * self.temperature
        if x_T.shape[-1] != backbone.in_channels:
            raise ValueError(f"noise: {x_T.shape[-1]} channels, backbone expects {backbone.in_channels}")
        scale = self.cfg.guidance_scale if guidance_scale is None else float(guidance_scale)

        eps_fn = self.guidance.eps_fn(backbone, cond, scale, x_mask=x_mask, cond_mask=cond_mask)

        steps = num_inference_steps if num_inference_steps is not None else self.cfg.num_inference_steps
        return reverse_loop(
            self.scheduler, x_T, eps_fn, x_mask=x_mask, generator=generator, num_inference_steps=steps
        )


@SAMPLERS.register("cfg", config=CFGConfig)
def build_cfg(cfg: CFGConfig, scheduler: Any = None, **deps: Any) -> CFGSampler:
    """Build the CFG sampler over ``scheduler`` (a NoiseScheduler or node; default ``cfg.scheduler``)."""
    return CFGSampler(cfg, resolve_scheduler(scheduler if scheduler is not None else cfg.scheduler))
