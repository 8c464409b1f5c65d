"""``cross_guidance``: joint motion–music sampling with two cross-modal denoisers (MoMu Eq. 8–9, Alg. 2).

Both latents start from Gaussian noise. For T ≥ t > T_c each is denoised *unconditionally*
(MoMu Eq. 8–9); for T_c ≥ t > 0 each is denoised with classifier-free guidance (Eq. 7)
conditioned on the *other* modality's current clean estimate
ẑ_0 = (z_t − √(1−ᾱ_t)·ε_θ(z_t, t, ∅)) / √ᾱ_t (Alg. 2), with T_c = γ·T.

Timestep convention: the paper counts t = 1 … T, diffusers indexes 0 … T−1, so a diffusers step
``t`` is guided when ``t + 1 ≤ T_c``. T_c = 0 (γ = 0) therefore never guides, and γ = 1 always.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import torch
from torch import Tensor

from momu.registry import SAMPLERS
from momu.samplers.base import Backbone, Generators, make_noise, module_device, resolve_scheduler
from momu.schedulers.diffusers_schedulers import NoiseScheduler

__all__ = ["CrossGuidanceConfig", "CrossGuidanceSampler", "build_cross_guidance"]


def _default_scheduler() -> dict[str, Any]:
    return {"name": "ddim"}


@dataclass
class CrossGuidanceConfig:
    """Cross-guidance joint sampler (MoMu §4, Alg. 2, Table 10).

    Attributes:
        gamma: γ with T_c = γ·T (MoMu: 0.5; Table 10 sweeps 0.1–0.9).
        guidance_scale: s of Eq. 7 used once guidance starts (see :class:`momu.samplers.cfg.CFGConfig`).
        music_guidance_scale, motion_guidance_scale: s for θ_a (music) and θ_m (motion) when they
            should differ (a table samples joint rows with the same scales as its cross rows);
            ``None`` uses ``guidance_scale``.
        num_inference_steps: reverse steps; ``None`` uses the scheduler's.
        scheduler: the scheduler node used when none is passed to the factory.
    """

    gamma: float = 0.5
    guidance_scale: float = 3.0
    music_guidance_scale: float | None = None
    motion_guidance_scale: float | None = None
    num_inference_steps: int | None = None
    scheduler: Any = field(default_factory=_default_scheduler)


class CrossGuidanceSampler:
    """Joint generation with a motion→music denoiser θ_a and a music→motion denoiser θ_m."""

    def __init__(self, cfg: CrossGuidanceConfig, scheduler: NoiseScheduler) -> None:
        if not 0.0 <= cfg.gamma <= 1.0:
            raise ValueError(f"cross_guidance.gamma must be in [0, 1], got {cfg.gamma}")
        self.cfg = cfg
        self.scheduler = scheduler

    @property
    def scales(self) -> tuple[float, float]:
        """Guidance scales ``(s_a, s_m)`` of θ_a and θ_m (each falls back to ``guidance_scale``)."""
        c = self.cfg
        music = c.guidance_scale if c.music_guidance_scale is None else c.music_guidance_scale
        motion = c.guidance_scale if c.motion_guidance_scale is None else c.motion_guidance_scale
        return float(music), float(motion)

    @property
    def t_c(self) -> int:
        """T_c = γ·T in paper timesteps (rounded)."""
        return int(round(self.cfg.gamma * self.scheduler.num_train_timesteps))

    @torch.no_grad()
    def sample(
        self,
        music_backbone: Backbone,
        motion_backbone: Backbone,
        music_noise: Tensor | Sequence[int],
        motion_noise: Tensor | Sequence[int],
        *,
        music_mask: Tensor | None = None,
        motion_mask: Tensor | None = None,
        generator: Generators = None,
        num_inference_steps: int | None = None,
    ) -> tuple[Tensor, Tensor]:
        """Jointly generate ``(z_a, z_m)`` (music latent, motion latent), MoMu Alg. 2.

        Args:
            music_backbone: θ_a, denoises music latents conditioned on motion latents
                (``cond_channels`` = motion latent channels).
            motion_backbone: θ_m, denoises motion latents conditioned on music latents.
            music_noise, motion_noise: initial noise ``(B, T_a, C_a)``/``(B, T_m, C_m)`` or their
                shapes (drawn from ``generator``, music first).
            music_mask, motion_mask: ``(B, T)`` valid frames (variable length, MoMu §5.3).
            generator: seeds the initial noise and stochastic steps; a list of one generator per
                item makes each item's sample depend on its own generator only.

        Returns:
            ``(music_latent, motion_latent)``.
        """
        if music_backbone.cond_channels != motion_backbone.in_channels:
            raise ValueError(
                f"music_backbone.cond_channels={music_backbone.cond_channels} must equal "
                f"motion_backbone.in_channels={motion_backbone.in_channels}"
            )
        if motion_backbone.cond_channels != music_backbone.in_channels:
            raise ValueError(
                f"motion_backbone.cond_channels={motion_backbone.cond_channels} must equal "
                f"music_backbone.in_channels={music_backbone.in_channels}"
            )
        device, dtype = module_device(music_backbone)
        z_a = make_noise(music_noise, generator, device, dtype)
        z_m = make_noise(motion_noise, generator, device, dtype)
        if z_a.shape[0] != z_m.shape[0]:
            raise ValueError(f"music/motion batch sizes differ: {z_a.shape[0]} vs {z_m.shape[0]}")
        keep_a = None if music_mask is None else music_mask[..., None].to(dtype)
        keep_m = None if motion_mask is None else motion_mask[..., None].to(dtype)
        if keep_a is not None:
            z_a = z_a * keep_a
        if keep_m is not None:
            z_m = z_m * keep_m
        steps = num_inference_steps if num_inference_steps is not None else self.cfg.num_inference_steps
        run_a = self.scheduler.begin(steps)
        run_m = self.scheduler.begin(steps)
        s_a, s_m = self.scales
        t_c = self.t_c
        b = z_a.shape[0]
        for step_t in run_a.timesteps:
            t_int = int(step_t)
            t = torch.full((b,), t_int, dtype=torch.long, device=device)
            eps_a = music_backbone(z_a, t, None, x_mask=music_mask)  # ε_θa(z_a(t), t, ∅)
            eps_m = motion_backbone(z_m, t, None, x_mask=motion_mask)  # ε_θm(z_m(t), t, ∅)
            if t_int + 1 <= t_c:  # T_c ≥ t > 0: cross guidance with the other's ẑ_0 (Alg. 2)
                x0_a = self.scheduler.x0_of(z_a, eps_a, t)
                x0_m = self.scheduler.x0_of(z_m, eps_m, t)
                cond_a = music_backbone(z_a, t, x0_m, x_mask=music_mask, cond_mask=motion_mask)
                cond_m = motion_backbone(z_m, t, x0_a, x_mask=motion_mask, cond_mask=music_mask)
                eps_a = eps_a + s_a * (cond_a - eps_a)  # Eq. 7
                eps_m = eps_m + s_m * (cond_m - eps_m)
            z_a = run_a.step(eps_a, t_int, z_a, generator=generator)
            z_m = run_m.step(eps_m, t_int, z_m, generator=generator)
            if keep_a is not None:
                z_a = z_a * keep_a
            if keep_m is not None:
                z_m = z_m * keep_m
        return z_a, z_m


@SAMPLERS.register("cross_guidance", config=CrossGuidanceConfig)
def build_cross_guidance(
    cfg: CrossGuidanceConfig, scheduler: Any = None, **deps: Any
) -> CrossGuidanceSampler:
    """Build the cross-guidance sampler over ``scheduler`` (default ``cfg.scheduler``)."""
    return CrossGuidanceSampler(cfg, resolve_scheduler(scheduler if scheduler is not None else cfg.scheduler))
