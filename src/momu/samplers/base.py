"""What every guidance sampler shares: the backbone protocol, noise, the guided ε (MoMu Eq. 7)
and the reverse loop over a :class:`~momu.schedulers.diffusers_schedulers.NoiseScheduler`.

A sampler is a *strategy* over a scheduler and one or more backbones; the schedule arithmetic is
the scheduler's (diffusers'). Samplers run under ``torch.no_grad`` and do not change a backbone's
train/eval mode: call ``backbone.eval()`` first. Generation is reproducible with a seeded
:class:`torch.Generator` (initial noise and, for stochastic schedulers, every step's noise).

Variable length (MoMu §5.3): a batch of sequences of different lengths is generated at once by
padding to the longest and passing ``x_mask (B, T)`` (True = valid, valid frames first). Padded
frames are held at zero and never influence valid frames.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any, Protocol, runtime_checkable

import torch
from torch import Tensor

from momu.schedulers.diffusers_schedulers import NoiseScheduler

__all__ = [
    "Backbone",
    "EpsFn",
    "Generators",
    "resolve_scheduler",
    "make_noise",
    "check_noise_temperature",
    "module_device",
    "guided_eps",
    "check_guidance_interval",
    "check_guidance_rescale",
    "check_guidance_parallel",
    "project_guided",
    "Guidance",
    "rescale_guided",
    "reverse_loop",
    "lengths_to_mask",
]

EpsFn = Callable[[Tensor, Tensor], Tensor]
"""``eps_fn(x_t (B,T,C), t (B,) long) -> ε̂ (B,T,C)``: the noise estimate a sampler steps with."""


@runtime_checkable
class Backbone(Protocol):
    """The backbone call protocol (docs/protocols.md).

    Attributes:
        in_channels: C of the denoised sequence ``x``.
        cond_channels: Cc of the condition sequence (0 = unconditional).
        max_length: largest supported length (``None`` = any).
    """

    in_channels: int
    cond_channels: int
    max_length: int | None

    def __call__(
        self,
        x: Tensor,
        t: Tensor,
        cond: Tensor | None = None,
        *,
        x_mask: Tensor | None = None,
        cond_mask: Tensor | None = None,
        drop_cond: Tensor | None = None,
    ) -> Tensor: ...


def resolve_scheduler(scheduler: Any) -> NoiseScheduler:
    """A :class:`NoiseScheduler` from an instance, a registry name or a ``{name, **params}`` node."""
    if isinstance(scheduler, NoiseScheduler):
        return scheduler
    from momu.config import build_component

    built = build_component(scheduler, "schedulers")
    if not isinstance(built, NoiseScheduler):
        raise TypeError(f"scheduler: expected a NoiseScheduler, got {type(built).__name__}")
    return built


def module_device(module: Any) -> tuple[torch.device, torch.dtype]:
    """Device and floating dtype of a module's first parameter (CPU float32 without parameters)."""
    params = getattr(module, "parameters", None)
    if callable(params):
        for p in params():
            if torch.is_floating_point(p):
                return p.device, p.dtype
    return torch.device("cpu"), torch.float32


Generators = torch.Generator | list[torch.Generator] | None
"""One generator for the batch, or one per item (each item's noise then depends only on its own
generator, not on the batch it is sampled in), or None (the global RNG)."""


def make_noise(
    noise_or_shape: Tensor | Sequence[int],
    generator: Generators,
    device: torch.device,
    dtype: torch.dtype,
) -> Tensor:
    """The initial z_T ~ N(0, I): the given tensor, or fresh noise of the given ``(B, T, C)`` shape."""
    if isinstance(noise_or_shape, Tensor):
        noise = noise_or_shape.to(device=device, dtype=dtype)
    else:
        shape = tuple(int(s) for s in noise_or_shape)
        if len(shape) != 3 or min(shape) <= 0:
            raise ValueError(f"shape: expected a positive (B, T, C), got {shape}")
        if isinstance(generator, list):
            if len(generator) != shape[0]:
                raise ValueError(f"generator: {len(generator)} generators for a batch of {shape[0]}")
            noise = torch.stack(
                [torch.randn(shape[1:], generator=g, device=g.device, dtype=dtype) for g in generator]
            ).to(device)
        else:
            gen_device = generator.device if generator is not None else device
            noise = torch.randn(shape, generator=generator, device=gen_device, dtype=dtype).to(device)
    if noise.ndim != 3:
        raise ValueError(f"noise: expected (B, T, C), got {tuple(noise.shape)}")
    return noise


def lengths_to_mask(lengths: Sequence[int] | Tensor, max_len: int | None = None) -> Tensor:
    """``(B, max_len)`` bool prefix mask from per-item lengths (MoMu §5.3 variable-length batches)."""
    lens = torch.as_tensor(lengths, dtype=torch.long)
    if lens.ndim != 1 or bool((lens <= 0).any()):
        raise ValueError(f"lengths: expected positive per-item lengths, got {lens.tolist()}")
    total = int(lens.max()) if max_len is None else int(max_len)
    if int(lens.max()) > total:
        raise ValueError(f"lengths: {int(lens.max())} exceeds max_len={total}")
    return torch.arange(total)[None, :] < lens[:, None]


def _check_backbone(backbone: Any, name: str) -> None:
    for attr in ("in_channels", "cond_channels"):
        if not hasattr(backbone, attr):
            raise TypeError(f"{name}: a backbone must have '{attr}' (see docs/protocols.md)")


def check_guidance_interval(interval: Sequence[int] | None) -> tuple[int, int] | None:
    """``guidance_interval`` as ``(low, high)``; a ``ValueError`` naming it unless ``0 <= low <= high``."""
    if interval is None:
        return None
    values = list(interval)
    if len(values) != 2 or any(int(v) != v for v in values) or not 0 <= values[0] <= values[1]:
        raise ValueError(
            f"guidance_interval must be [low, high] timesteps with 0 <= low <= high, got {values}"
        )
    return int(values[0]), int(values[1])


def _unit_weight(value: float, name: str) -> float:
    """``value`` as a float; a ``ValueError`` naming ``name`` unless ``0 <= value <= 1``."""
    out = float(value)
    if not 0.0 <= out <= 1.0:
        raise ValueError(f"{name} must be in [0, 1], got {value}")
    return out


def check_guidance_rescale(rescale: float) -> float:
    """``guidance_rescale`` as a float; a ``ValueError`` naming it unless ``0 <= rescale <= 1``."""
    return _unit_weight(rescale, "guidance_rescale")


def check_guidance_parallel(parallel: float) -> float:
    """``guidance_parallel`` as a float; a ``ValueError`` naming it unless ``0 <= parallel <= 1``."""
    return _unit_weight(parallel, "guidance_parallel")


def check_noise_temperature(temperature: float) -> float:
    """``noise_temperature`` as a float; a ``ValueError`` naming it unless ``temperature > 0``."""
    out = float(temperature)
    if not out > 0.0:
        raise ValueError(f"noise_temperature must be > 0, got {temperature}")
    return out


def project_guided(
    cond_out: Tensor, uncond_out: Tensor, scale: float, parallel: float, x_mask: Tensor | None = None
) -> Tensor:
    """Projected guidance (Sadat et al., ICLR 2025, "Eliminating Oversaturation and Artifacts of High
    Guidance Scales in Diffusion Models", arXiv 2410.02416: the projection of its adaptive projected
    guidance, without momentum or norm threshold; diffusers' ``normalized_guidance``): the guidance update
    ``Δ = cond_out − uncond_out`` is split into its component parallel to ``cond_out`` and the rest,
    and the parallel one is weighted by ``parallel`` (η):
    ``uncond_out + scale · (Δ⊥ + η · Δ∥)``. η = 1 is plain Eq. 7. The parallel component is what
    scales the prediction up (the paper's oversaturation; in a dance, limbs swung wider and faster than
    any training dance), the orthogonal one what moves it towards the condition.

    The projection is per item over its valid frames (``x_mask``) and channels; padded frames are zero
    in both outputs before projecting (the reverse loop zeroes them anyway).
    """
    if parallel == 1.0:
        return uncond_out + scale * (cond_out - uncond_out)
    from diffusers.guiders.adaptive_projected_guidance import normalized_guidance

    if x_mask is not None:
        keep = x_mask.to(cond_out.dtype).reshape(*x_mask.shape, *([1] * (cond_out.ndim - 2)))
        cond_out, uncond_out = cond_out * keep, uncond_out * keep
    return normalized_guidance(cond_out, uncond_out, scale, eta=parallel)


def rescale_guided(guided: Tensor, cond_out: Tensor, rescale: float, x_mask: Tensor | None = None) -> Tensor:
    """Rescaled classifier-free guidance (Lin et al. 2024, "Common Diffusion Noise Schedules and Sample
    Steps are Flawed", §3.4, Eq. 15-16): the guided output scaled to the conditional output's standard
    deviation, ``x_rescaled = guided · σ(cond_out) / σ(guided)``, blended as
    ``rescale · x_rescaled + (1 − rescale) · guided``. A large guidance scale inflates the guided
    output's variance, which in a motion is limbs swung wider and faster than any training dance.

    σ is taken per item over its valid frames (``x_mask``) and channels; without a mask it is
    diffusers' ``rescale_noise_cfg``. ``rescale = 0`` returns ``guided`` unchanged.
    """
    if rescale == 0.0:
        return guided
    dims = tuple(range(1, guided.ndim))
    if x_mask is None:
        std_g = guided.std(dim=dims, keepdim=True)
        std_c = cond_out.std(dim=dims, keepdim=True)
    else:
        w = x_mask.to(guided.dtype).reshape(*x_mask.shape, *([1] * (guided.ndim - 2))).expand_as(guided)
        n = w.sum(dim=dims, keepdim=True).clamp_min(2.0)

        def masked_std(v: Tensor) -> Tensor:
            mean = (v * w).sum(dim=dims, keepdim=True) / n
            return (((v - mean) ** 2 * w).sum(dim=dims, keepdim=True) / (n - 1)).sqrt()

        std_g, std_c = masked_std(guided), masked_std(cond_out)
    rescaled = guided * (std_c / std_g.clamp_min(1e-12))
    return rescale * rescaled + (1.0 - rescale) * guided


def guided_eps(
    backbone: Backbone,
    x: Tensor,
    t: Tensor,
    cond: Tensor | None,
    scale: float,
    *,
    x_mask: Tensor | None = None,
    cond_mask: Tensor | None = None,
    interval: tuple[int, int] | None = None,
    rescale: float = 0.0,
    parallel: float = 1.0,
) -> Tensor:
    """Classifier-free guidance, MoMu Eq. 7: ε̂ = ε(z_t, t, ∅) + s·(ε(z_t, t, c) − ε(z_t, t, ∅)).

    The conditional and unconditional passes run as ONE batched forward of ``2B`` items, the
    second half with ``drop_cond=True`` (the learned null embedding). Without a condition (or for
    an unconditional backbone) it is the plain unconditional ε; at ``s = 1`` it is the conditional
    ε alone, computed in one pass (the unconditional half would cancel).

    With ``interval = (low, high)`` the guidance applies only at training timesteps ``low <= t <=
    high`` and the step is conditional (``s = 1``) elsewhere: guidance in a limited interval
    (Kynkäänniemi et al. 2024, "Applying Guidance in a Limited Interval Improves Sample and
    Distribution Quality in Diffusion Models"). Guided low-noise steps add high-frequency detail,
    which in a motion is jitter (docs/diffusion.md, "cfg"). ``rescale`` > 0 rescales the guided output
    towards the conditional one's standard deviation (:func:`rescale_guided`); ``parallel`` < 1 weights
    the guidance update's component parallel to the conditional output (:func:`project_guided`).

    Args:
        x: ``(B, T, C)`` noisy sequence; ``t``: ``(B,)`` timesteps; ``cond``: ``(B, Tc, Cc)``.
        scale: guidance scale s (1 = conditional, 0 = unconditional).
        rescale: φ of rescaled guidance in [0, 1] (0: plain Eq. 7).
        parallel: η of projected guidance in [0, 1] (1: plain Eq. 7).
    """
    b = x.shape[0]
    if interval is not None and cond is not None:
        inside = (t >= interval[0]) & (t <= interval[1])
        if not bool(inside.any()):
            scale = 1.0
        elif not bool(inside.all()):
            raise ValueError("guidance_interval: the items of a batch are at different timesteps")
    if cond is None or backbone.cond_channels == 0:
        if cond is not None:
            raise ValueError("cond: given to an unconditional backbone (cond_channels=0)")
        return backbone(x, t, None, x_mask=x_mask)
    if scale == 1.0:  # ε(∅) + 1·(ε(c) − ε(∅)) = ε(c): one conditional pass (MoFusion uses no CFG)
        return backbone(x, t, cond, x_mask=x_mask, cond_mask=cond_mask)
    drop = torch.cat([torch.zeros(b, dtype=torch.bool), torch.ones(b, dtype=torch.bool)]).to(x.device)
    out = backbone(
        torch.cat([x, x]),
        torch.cat([t, t]),
        torch.cat([cond, cond]),
        x_mask=None if x_mask is None else torch.cat([x_mask, x_mask]),
        cond_mask=None if cond_mask is None else torch.cat([cond_mask, cond_mask]),
        drop_cond=drop,
    )
    eps_c, eps_u = out.chunk(2)
    return rescale_guided(project_guided(eps_c, eps_u, scale, parallel, x_mask), eps_c, rescale, x_mask)


@dataclass(frozen=True)
class Guidance:
    """A guidance sampler's checked ``guidance_interval``, ``guidance_rescale`` and
    ``guidance_parallel`` (:func:`guided_eps`)."""

    interval: tuple[int, int] | None = None
    rescale: float = 0.0
    parallel: float = 1.0

    @classmethod
    def of(cls, cfg: Any) -> Guidance:
        """From a sampler config with ``guidance_interval``, ``guidance_rescale``, ``guidance_parallel``."""
        interval = check_guidance_interval(cfg.guidance_interval)
        rescale = check_guidance_rescale(cfg.guidance_rescale)
        return cls(interval, rescale, check_guidance_parallel(cfg.guidance_parallel))

    def eps_fn(
        self,
        backbone: Backbone,
        cond: Tensor | None,
        scale: float,
        *,
        x_mask: Tensor | None = None,
        cond_mask: Tensor | None = None,
    ) -> EpsFn:
        """The guided ε̂ (MoMu Eq. 7 with these settings) a reverse loop steps with."""

        def eps(x: Tensor, t: Tensor) -> Tensor:
            return guided_eps(
                backbone,
                x,
                t,
                cond,
                scale,
                x_mask=x_mask,
                cond_mask=cond_mask,
                interval=self.interval,
                rescale=self.rescale,
                parallel=self.parallel,
            )

        return eps


def reverse_loop(
    scheduler: NoiseScheduler,
    x_T: Tensor,
    eps_fn: EpsFn,
    *,
    x_mask: Tensor | None = None,
    generator: Generators = None,
    num_inference_steps: int | None = None,
    before_step: Callable[[Tensor, int], Tensor] | None = None,
) -> Tensor:
    """Run the reverse process z_T -> z_0 (MoMu Alg. 1) with the scheduler's ``step``.

    Args:
        x_T: ``(B, T, C)`` initial noise.
        eps_fn: noise estimate at ``(z_t, t)``.
        x_mask: ``(B, T)`` valid frames; padded frames are held at zero.
        before_step: optional ``f(z_t, t) -> z_t`` applied before each model call (inpainting).
    """
    if isinstance(generator, list) and len(generator) != x_T.shape[0]:
        raise ValueError(f"generator: {len(generator)} generators for a batch of {x_T.shape[0]}")
    run = scheduler.begin(num_inference_steps)
    keep = None if x_mask is None else x_mask[..., None].to(x_T.dtype)
    x = x_T if keep is None else x_T * keep
    b = x.shape[0]
    for step_t in run.timesteps:
        t_int = int(step_t)
        if before_step is not None:
            x = before_step(x, t_int)
        t = torch.full((b,), t_int, dtype=torch.long, device=x.device)
        eps = eps_fn(x, t)
        x = run.step(eps, t_int, x, generator=generator)
        if keep is not None:
            x = x * keep
    return x
