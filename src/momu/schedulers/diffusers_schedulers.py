"""``ddpm`` and ``ddim``: diffusers' noise schedulers behind one small interface.

The schedule arithmetic (β_t, ᾱ_t, forward noising, reverse steps) is diffusers'
(:class:`diffusers.DDPMScheduler`, :class:`diffusers.DDIMScheduler`); momu only wraps them so
that samplers and losses can ask for what they need:

* :meth:`NoiseScheduler.add_noise` — forward diffusion q(z_t | z_0) = N(√ᾱ_t z_0, (1-ᾱ_t) I),
  the closed form of MoMu Eq. 5;
* :meth:`NoiseScheduler.predict_x0` — ẑ_0 = (z_t − √(1−ᾱ_t) ε) / √ᾱ_t (MoMu Alg. 2; the paper
  prints α_t where the DDPM identity needs ᾱ_t, which is used here);
* :attr:`NoiseScheduler.prediction_type` — what a denoiser predicts: ``epsilon`` (the noise, both
  papers), ``sample`` (ẑ_0 itself, as MDM and EDGE do for motion) or ``v_prediction``;
  :meth:`NoiseScheduler.x0_of`, :meth:`NoiseScheduler.eps_of` and :meth:`NoiseScheduler.target`
  translate, so losses and samplers work with any;
* :meth:`NoiseScheduler.begin` — a fresh reverse-process run (its own copy of the diffusers
  scheduler, so two chains, as in cross-guidance, never share state) with ``timesteps`` and
  ``step`` (MoMu Eq. 8–9 for DDPM; DDIM for the 50-step sampling of MoMu §5.1).

Timesteps are diffusers' 0-based indices ``0 … T−1``; paper timestep ``t`` is index ``t − 1``.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass
from typing import Any

import torch
from diffusers import DDIMScheduler, DDPMScheduler
from torch import Tensor

from momu.registry import SCHEDULERS

__all__ = [
    "DDPMConfig",
    "DDIMConfig",
    "NoiseScheduler",
    "SamplingRun",
    "build_ddpm",
    "build_ddim",
]

_BETA_SCHEDULES = ("linear", "scaled_linear", "squaredcos_cap_v2", "sigmoid")
_SPACINGS = ("leading", "trailing", "linspace")
PREDICTION_TYPES = ("epsilon", "sample", "v_prediction")
"""What a denoiser may predict (diffusers' names)."""


@dataclass
class DDPMConfig:
    """DDPM schedule (Ho et al.; MoMu Eq. 5, 8–9; MoFusion supp. B).

    Attributes:
        num_train_timesteps: T (MoMu Table 9 / MoFusion supp. B: 1000).
        beta_start: β_1 (1e-4, MoFusion supp. B).
        beta_end: β_T (0.02, MoFusion supp. B).
        beta_schedule: diffusers schedule name (``linear`` in both papers).
        num_inference_steps: reverse steps used for sampling (DDPM: all T).
        variance_type: posterior variance (``fixed_small`` = σ_t² of MoMu Eq. 9).
        timestep_spacing: how inference timesteps are spread (diffusers' option).
        clip_sample: clip ẑ_0 to ±``clip_sample_range`` in each step (off: latents are unbounded;
            on, it keeps an imperfect ε-model from drifting at high noise levels).
        clip_sample_range: the clipping bound.
        prediction_type: what the denoiser predicts: ``epsilon`` (the noise; MoMu Eq. 6, MoFusion
            Eq. 3), ``sample`` (the clean ẑ_0: its loss weighs every noise level alike, so what only
            the condition can tell — e.g. *when* a dancer steps — is learned at high noise) or
            ``v_prediction`` (the velocity √ᾱ ε − √(1−ᾱ) z_0: like ``sample`` at high noise, like
            ``epsilon`` at low noise, where the fine detail is).
    """

    num_train_timesteps: int = 1000
    beta_start: float = 1e-4
    beta_end: float = 0.02
    beta_schedule: str = "linear"
    num_inference_steps: int = 1000
    variance_type: str = "fixed_small"
    timestep_spacing: str = "leading"
    clip_sample: bool = False
    clip_sample_range: float = 1.0
    prediction_type: str = "epsilon"


@dataclass
class DDIMConfig:
    """DDIM schedule; 50 sampling steps as in MoMu §5.1.

    Attributes:
        num_train_timesteps, beta_start, beta_end, beta_schedule: as :class:`DDPMConfig`.
        num_inference_steps: reverse steps (MoMu §5.1: 50).
        eta: DDIM stochasticity η (0 = deterministic DDIM, 1 = DDPM-like variance).
        timestep_spacing: how inference timesteps are spread (diffusers' option).
        set_alpha_to_one: use ᾱ_prev = 1 at the final step (diffusers' default).
        clip_sample: clip ẑ_0 to ±``clip_sample_range`` in each step (see :class:`DDPMConfig`).
        clip_sample_range: the clipping bound.
        prediction_type: ``epsilon``, ``sample`` or ``v_prediction`` (see :class:`DDPMConfig`).
    """

    num_train_timesteps: int = 1000
    beta_start: float = 1e-4
    beta_end: float = 0.02
    beta_schedule: str = "linear"
    num_inference_steps: int = 50
    eta: float = 0.0
    timestep_spacing: str = "leading"
    set_alpha_to_one: bool = True
    clip_sample: bool = False
    clip_sample_range: float = 1.0
    prediction_type: str = "epsilon"


def _check_common(kind: str, cfg: DDPMConfig | DDIMConfig) -> None:
    if cfg.num_train_timesteps <= 0:
        raise ValueError(f"{kind}.num_train_timesteps must be positive, got {cfg.num_train_timesteps}")
    if not 0 < cfg.num_inference_steps <= cfg.num_train_timesteps:
        raise ValueError(
            f"{kind}.num_inference_steps must be in [1, {cfg.num_train_timesteps}], "
            f"got {cfg.num_inference_steps}"
        )
    if not 0.0 < cfg.beta_start < cfg.beta_end < 1.0:
        raise ValueError(f"{kind}: need 0 < beta_start < beta_end < 1, got {cfg.beta_start}, {cfg.beta_end}")
    if cfg.beta_schedule not in _BETA_SCHEDULES:
        raise ValueError(f"{kind}.beta_schedule {cfg.beta_schedule!r} not one of {_BETA_SCHEDULES}")
    if cfg.clip_sample_range <= 0:
        raise ValueError(f"{kind}.clip_sample_range must be positive, got {cfg.clip_sample_range}")
    if cfg.timestep_spacing not in _SPACINGS:
        raise ValueError(f"{kind}.timestep_spacing {cfg.timestep_spacing!r} not one of {_SPACINGS}")
    if cfg.prediction_type not in PREDICTION_TYPES:
        raise ValueError(f"{kind}.prediction_type {cfg.prediction_type!r} not one of {PREDICTION_TYPES}")


class SamplingRun:
    """One reverse-process run: ``timesteps`` (descending) and ``step``. Owns its scheduler copy."""

    def __init__(self, scheduler: Any, num_inference_steps: int, step_kwargs: dict[str, Any]) -> None:
        self.scheduler = scheduler
        self.scheduler.set_timesteps(num_inference_steps)
        self.timesteps: Tensor = self.scheduler.timesteps.clone()
        self._step_kwargs = step_kwargs

    def step(
        self,
        eps: Tensor,
        t: int | Tensor,
        x: Tensor,
        generator: torch.Generator | list[torch.Generator] | None = None,
    ) -> Tensor:
        """z_{t−Δt} from z_t and the denoiser's output ``eps`` (the noise, ẑ_0 for a ``sample`` or v for
        a ``v_prediction`` predictor; both ``(B, T, C)``)."""
        out = self.scheduler.step(eps, int(t), x, generator=generator, return_dict=True, **self._step_kwargs)
        return out.prev_sample


class NoiseScheduler:
    """A diffusers scheduler plus its sampling settings (what ``SCHEDULERS.build`` returns).

    Args:
        scheduler: the diffusers scheduler (its config is the source of truth for the schedule).
        num_inference_steps: default number of reverse steps.
        step_kwargs: extra keyword arguments for ``scheduler.step`` (e.g. DDIM's ``eta``).
        name: the registry name (for provenance).
    """

    def __init__(
        self,
        scheduler: Any,
        num_inference_steps: int,
        step_kwargs: dict[str, Any] | None = None,
        name: str = "",
    ) -> None:
        self.scheduler = scheduler
        self.num_inference_steps = num_inference_steps
        self.step_kwargs = dict(step_kwargs or {})
        self.name = name

    @property
    def num_train_timesteps(self) -> int:
        """T, the number of training diffusion steps."""
        return int(self.scheduler.config.num_train_timesteps)

    @property
    def alphas_cumprod(self) -> Tensor:
        """``(T,)`` float32 ᾱ_t for diffusers timestep indices 0 … T−1."""
        return self.scheduler.alphas_cumprod

    def _abar(self, t: Tensor, ref: Tensor) -> Tensor:
        t = torch.as_tensor(t, device=self.alphas_cumprod.device).long().reshape(-1)
        if bool((t < 0).any()) or bool((t >= self.num_train_timesteps).any()):
            raise ValueError(f"t: timesteps must be in [0, {self.num_train_timesteps}), got {t.tolist()}")
        abar = self.alphas_cumprod[t].to(device=ref.device, dtype=ref.dtype)
        return abar.reshape(-1, *([1] * (ref.ndim - 1)))

    def add_noise(self, x0: Tensor, noise: Tensor, t: Tensor) -> Tensor:
        """Forward diffusion z_t = √ᾱ_t z_0 + √(1−ᾱ_t) ε (MoMu Eq. 5 in closed form); ``t (B,)``."""
        if x0.shape != noise.shape:
            raise ValueError(f"noise: shape {tuple(noise.shape)} differs from x0 {tuple(x0.shape)}")
        return self.scheduler.add_noise(x0, noise, torch.as_tensor(t, device=x0.device).long().reshape(-1))

    def predict_x0(self, x_t: Tensor, eps: Tensor, t: Tensor) -> Tensor:
        """ẑ_0 = (z_t − √(1−ᾱ_t) ε) / √ᾱ_t (MoMu Alg. 2); ``t (B,)`` or a scalar."""
        abar = self._abar(t, x_t)
        return (x_t - torch.sqrt(1.0 - abar) * eps) / torch.sqrt(abar)

    def predict_eps(self, x_t: Tensor, x0: Tensor, t: Tensor) -> Tensor:
        """ε = (z_t − √ᾱ_t z_0) / √(1−ᾱ_t), the inverse of :meth:`predict_x0`."""
        abar = self._abar(t, x_t)
        return (x_t - torch.sqrt(abar) * x0) / torch.sqrt(1.0 - abar)

    @property
    def prediction_type(self) -> str:
        """What the denoiser predicts: ``epsilon``, ``sample`` or ``v_prediction``."""
        return str(self.scheduler.config.prediction_type)

    def x0_of(self, x_t: Tensor, output: Tensor, t: Tensor) -> Tensor:
        """ẑ_0 from a denoiser's output at ``t``, whatever it predicts (v: ẑ_0 = √ᾱ z_t − √(1−ᾱ) v̂)."""
        if self.prediction_type == "sample":
            return output
        if self.prediction_type == "v_prediction":
            abar = self._abar(t, x_t)
            return torch.sqrt(abar) * x_t - torch.sqrt(1.0 - abar) * output
        return self.predict_x0(x_t, output, t)

    def eps_of(self, x_t: Tensor, output: Tensor, t: Tensor) -> Tensor:
        """ε̂ from a denoiser's output at ``t``, whatever it predicts (v: ε̂ = √(1−ᾱ) z_t + √ᾱ v̂)."""
        if self.prediction_type == "sample":
            return self.predict_eps(x_t, output, t)
        if self.prediction_type == "v_prediction":
            abar = self._abar(t, x_t)
            return torch.sqrt(1.0 - abar) * x_t + torch.sqrt(abar) * output
        return output

    def target(self, x0: Tensor, noise: Tensor, t: Tensor) -> Tensor:
        """The training target of the denoiser's output at ``t``: ``noise`` (epsilon), ``x0`` (sample)
        or the velocity v = √ᾱ ε − √(1−ᾱ) z_0 (v_prediction, Salimans & Ho 2022)."""
        if self.prediction_type == "sample":
            return x0
        if self.prediction_type == "v_prediction":
            abar = self._abar(t, x0)
            return torch.sqrt(abar) * noise - torch.sqrt(1.0 - abar) * x0
        return noise

    def sample_timesteps(
        self, batch: int, generator: torch.Generator | None = None, device: Any = None
    ) -> Tensor:
        """``(batch,)`` training timesteps drawn uniformly from ``[0, T)`` (MoMu Eq. 6)."""
        return torch.randint(0, self.num_train_timesteps, (batch,), generator=generator, device=device)

    def begin(self, num_inference_steps: int | None = None) -> SamplingRun:
        """A fresh reverse-process run over ``num_inference_steps`` (default: the configured number)."""
        n = self.num_inference_steps if num_inference_steps is None else int(num_inference_steps)
        if not 0 < n <= self.num_train_timesteps:
            raise ValueError(f"num_inference_steps must be in [1, {self.num_train_timesteps}], got {n}")
        return SamplingRun(copy.deepcopy(self.scheduler), n, self.step_kwargs)

    def __repr__(self) -> str:
        return (
            f"NoiseScheduler({self.name or type(self.scheduler).__name__}, steps={self.num_inference_steps})"
        )


@SCHEDULERS.register("ddpm", config=DDPMConfig)
def build_ddpm(cfg: DDPMConfig, **deps: object) -> NoiseScheduler:
    """diffusers ``DDPMScheduler`` (ε-prediction unless ``prediction_type``), T = 1000, linear β 1e-4…0.02."""
    _check_common("ddpm", cfg)
    sched = DDPMScheduler(
        num_train_timesteps=cfg.num_train_timesteps,
        beta_start=cfg.beta_start,
        beta_end=cfg.beta_end,
        beta_schedule=cfg.beta_schedule,
        variance_type=cfg.variance_type,
        clip_sample=cfg.clip_sample,
        clip_sample_range=cfg.clip_sample_range,
        prediction_type=cfg.prediction_type,
        timestep_spacing=cfg.timestep_spacing,
    )
    return NoiseScheduler(sched, cfg.num_inference_steps, name="ddpm")


@SCHEDULERS.register("ddim", config=DDIMConfig)
def build_ddim(cfg: DDIMConfig, **deps: object) -> NoiseScheduler:
    """diffusers ``DDIMScheduler`` (ε-prediction unless ``prediction_type``), 50 steps (MoMu §5.1)."""
    _check_common("ddim", cfg)
    if cfg.eta < 0:
        raise ValueError(f"ddim.eta must be >= 0, got {cfg.eta}")
    sched = DDIMScheduler(
        num_train_timesteps=cfg.num_train_timesteps,
        beta_start=cfg.beta_start,
        beta_end=cfg.beta_end,
        beta_schedule=cfg.beta_schedule,
        clip_sample=cfg.clip_sample,
        clip_sample_range=cfg.clip_sample_range,
        set_alpha_to_one=cfg.set_alpha_to_one,
        prediction_type=cfg.prediction_type,
        timestep_spacing=cfg.timestep_spacing,
    )
    return NoiseScheduler(sched, cfg.num_inference_steps, {"eta": cfg.eta}, name="ddim")
