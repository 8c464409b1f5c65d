"""``inpainting``: generation with known frames (MoFusion §4.4).

"We first construct noise vectors by forward-diffusing the seed frames to produce P^(t) … for
each time step t wherein the remaining frames are populated with random noise. Then, at each
denoising step, we use a mask δ to ensure that the seed frames are not denoised."

Before every model call at timestep t the known frames are replaced by a fresh forward-diffused
sample q(z_t | z_0^known) (scheduler ``add_noise``); after the last step they are set to the given
values exactly. The unknown frames are denoised with classifier-free guidance (MoMu Eq. 7) when a
condition is given. Presets: seed-conditioned forecasting (the first S frames known) and
in-betweening (keyframes known), see :func:`forecast_mask` and :func:`inbetween_mask`.

A *soft* mask (float weights ``w`` in [0, 1] instead of booleans; not in MoFusion) blends instead of
replacing: ``z_t ← w·q(z_t | z_0^known) + (1 − w)·z_t`` before every call and ``w·known + (1 − w)·z_0``
at the end, so frames with ``w`` below 1 may move towards what the model generates next to them (in the
spirit of the soft-masked transitions of DoubleTake, PriorMDM, Shafir et al. 2023). Weights 0 and 1 give
exactly the hard mask's result.
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

__all__ = ["InpaintingConfig", "InpaintingSampler", "forecast_mask", "inbetween_mask", "build_inpainting"]

PRESETS = ("forecast", "inbetween")


def _default_scheduler() -> dict[str, Any]:
    return {"name": "ddim"}


@dataclass
class InpaintingConfig:
    """Inpainting sampler (MoFusion §4.4).

    Attributes:
        preset: mask used when ``sample`` gets none: ``forecast`` (first ``seed_frames`` known)
            or ``inbetween`` (every ``keyframe_interval``-th frame and the last frame known).
        seed_frames: S of seed-conditioned forecasting (MoFusion §4.4: 40 frames = 2 s).
        keyframe_interval: spacing of in-betweening keyframes in frames (not in the paper).
        guidance_scale: s of MoMu Eq. 7 for the conditional branch.
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
        num_inference_steps: reverse steps; ``None`` uses the scheduler's.
        scheduler: the scheduler node used when none is passed to the factory.
    """

    preset: str = "forecast"
    seed_frames: int = 40
    keyframe_interval: int = 20
    guidance_scale: float = 3.0
    num_inference_steps: int | None = None
    scheduler: Any = field(default_factory=_default_scheduler)
    guidance_interval: list[int] | None = None
    guidance_rescale: float = 0.0
    guidance_parallel: float = 1.0
    noise_temperature: float = 1.0


def forecast_mask(batch: int, length: int, seed_frames: int) -> Tensor:
    """``(batch, length)`` bool mask with the first ``seed_frames`` frames known (MoFusion §4.4)."""
    if not 0 < seed_frames <= length:
        raise ValueError(f"seed_frames must be in [1, {length}], got {seed_frames}")
    mask = torch.zeros(batch, length, dtype=torch.bool)
    mask[:, :seed_frames] = True
    return mask


def inbetween_mask(batch: int, length: int, keyframe_interval: int) -> Tensor:
    """``(batch, length)`` bool mask with frames 0, k, 2k, … and the last frame known (in-betweening)."""
    if keyframe_interval <= 0:
        raise ValueError(f"keyframe_interval must be positive, got {keyframe_interval}")
    mask = torch.zeros(batch, length, dtype=torch.bool)
    mask[:, ::keyframe_interval] = True
    mask[:, -1] = True
    return mask


class InpaintingSampler:
    """Fill in unknown frames around known ones (MoFusion §4.4)."""

    def __init__(self, cfg: InpaintingConfig, scheduler: NoiseScheduler) -> None:
        if cfg.preset not in PRESETS:
            raise ValueError(f"inpainting.preset {cfg.preset!r} not one of {PRESETS}")
        self.cfg = cfg
        self.scheduler = scheduler
        self.guidance = Guidance.of(cfg)
        self.temperature = check_noise_temperature(cfg.noise_temperature)

    def preset_mask(self, batch: int, length: int) -> Tensor:
        """The configured preset's ``(batch, length)`` known-frame mask."""
        if self.cfg.preset == "forecast":
            return forecast_mask(batch, length, self.cfg.seed_frames)
        return inbetween_mask(batch, length, self.cfg.keyframe_interval)

    @torch.no_grad()
    def sample(
        self,
        backbone: Backbone,
        known: Tensor,
        known_mask: Tensor | None = None,
        cond: Tensor | None = None,
        *,
        noise: Tensor | Sequence[int] | None = None,
        x_mask: Tensor | None = None,
        cond_mask: Tensor | None = None,
        generator: Generators = None,
        guidance_scale: float | None = None,
        num_inference_steps: int | None = None,
    ) -> Tensor:
        """Generate a sequence that equals ``known`` where ``known_mask`` is True.

        Args:
            backbone: a denoiser following the backbone protocol (in eval mode).
            known: ``(B, T, C)`` values of the known frames (other frames are ignored).
            known_mask: ``(B, T)`` or ``(B, T, C)`` bool, True = known; or float weights in [0, 1]
                (a soft mask, module docstring); ``None`` = the preset.
            cond: optional ``(B, Tc, Cc)`` condition (e.g. music), guided with Eq. 7.
            noise: initial noise (default: drawn from ``generator`` with ``known``'s shape).
            x_mask, cond_mask: valid-frame masks for variable-length batches.
            generator: one generator, or one per item (an item's noise then depends on its own only).

        Returns:
            ``(B, T, C)``; exactly ``known`` on the known frames (soft mask: where the weight is 1).
        """
        device, dtype = module_device(backbone)
        known = known.to(device=device, dtype=dtype)
        if known.ndim != 3 or known.shape[-1] != backbone.in_channels:
            raise ValueError(f"known: expected (B, T, {backbone.in_channels}), got {tuple(known.shape)}")
        if known_mask is None:
            known_mask = self.preset_mask(known.shape[0], known.shape[1])
        known_mask = known_mask.to(device)
        soft = torch.is_floating_point(known_mask)
        if not soft and known_mask.dtype != torch.bool:
            raise ValueError(f"known_mask: expected a bool or float tensor, got {known_mask.dtype}")
        if soft and not bool(((known_mask >= 0) & (known_mask <= 1)).all()):
            raise ValueError("known_mask: soft weights must lie in [0, 1]")
        if known_mask.ndim == 2:
            known_mask = known_mask[..., None]
        if known_mask.ndim != 3 or known_mask.shape[:2] != known.shape[:2]:
            raise ValueError(
                f"known_mask: shape {tuple(known_mask.shape)} does not match known {tuple(known.shape)}"
            )
        mask = known_mask.expand_as(known)
        if soft:
            weight = mask.to(dtype)

            def keep_known(value: Tensor, x: Tensor) -> Tensor:
                return weight * value + (1.0 - weight) * x

        else:

            def keep_known(value: Tensor, x: Tensor) -> Tensor:
                return torch.where(mask, value, x)

        x_T = make_noise(noise if noise is not None else known.shape, generator, device, dtype)
        x_T = x_T * self.temperature
        if x_T.shape != known.shape:
            raise ValueError(f"noise: shape {tuple(x_T.shape)} differs from known {tuple(known.shape)}")
        scale = self.cfg.guidance_scale if guidance_scale is None else float(guidance_scale)

        def replace_known(x: Tensor, t_int: int) -> Tensor:
            eps = make_noise(known.shape, generator, device, dtype)
            t = torch.full((known.shape[0],), t_int, dtype=torch.long, device=device)
            return keep_known(self.scheduler.add_noise(known, eps, t), x)  # P^(t) on the known frames

        eps_fn = self.guidance.eps_fn(backbone, cond, scale, x_mask=x_mask, cond_mask=cond_mask)

        steps = num_inference_steps if num_inference_steps is not None else self.cfg.num_inference_steps
        out = reverse_loop(
            self.scheduler,
            x_T,
            eps_fn,
            x_mask=x_mask,
            generator=generator,
            num_inference_steps=steps,
            before_step=replace_known,
        )
        out = keep_known(known, out)
        if x_mask is not None:
            out = out * x_mask[..., None].to(dtype)
        return out


@SAMPLERS.register("inpainting", config=InpaintingConfig)
def build_inpainting(cfg: InpaintingConfig, scheduler: Any = None, **deps: Any) -> InpaintingSampler:
    """Build the inpainting sampler over ``scheduler`` (default ``cfg.scheduler``)."""
    return InpaintingSampler(cfg, resolve_scheduler(scheduler if scheduler is not None else cfg.scheduler))
