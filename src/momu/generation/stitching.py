"""Sequences of any length from a fixed-window diffusion model: overlapping windows stitched by inpainting.

A MoMu denoiser is trained on windows of ``window_seconds`` (4 s at the cpu preset) and its DiT has a
``max_length``; a song is longer. The song's condition latent (the whole song encoded at once: the
BiCoR-VAE encoders are convolutional) is cut into windows of ``W`` latent frames that overlap by ``O``:

* window 0 is sampled with classifier-free guidance (MoMu Eq. 7) on its part of the condition;
* window ``k`` starts ``W − O`` frames after window ``k − 1``; its first ``O`` frames are *known* — the
  last ``O`` frames window ``k − 1`` generated — and it is sampled by inpainting (MoFusion §4.4: the
  known frames are replaced by their forward-diffused values before every denoising step), with CFG on
  the rest. So each window continues the previous one instead of starting afresh.

**Latents, not poses.** MoMu generates in the BiCoR-VAE latent space, so the stitching happens there:
known frames are latent frames, the stitched latent of the whole song is decoded once, and the
(convolutional) decoder sees one continuous sequence — no window edge reaches the decoder. Inpainting
poses would need a decode inside every denoising step and would still leave the decoder's edges at
every window.

Windows of several items (songs) run as one batch per window index (items that have no window ``k``
any more drop out); each item's noise comes from its own seeded generator, so an item's result does
not depend on the batch.

:func:`seam_jumps` and :func:`velocity_jumps` measure what a seam would look like: the change of joint
velocity between consecutive frames, at the window boundaries, against the same statistic of real data.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import torch
from torch import Tensor

from momu.samplers.base import lengths_to_mask
from momu.samplers.inpainting import InpaintingConfig, InpaintingSampler

__all__ = ["WindowPlan", "plan_windows", "stitched_sample", "velocity_jumps", "seam_jumps", "inpainting_like"]

Progress = Callable[[int], None]
"""Called with the number of windows just finished (for a progress bar)."""


@dataclass(frozen=True)
class WindowPlan:
    """Where the windows of one sequence lie (latent frames).

    Attributes:
        length: total frames ``L``.
        starts: start frame of each window.
        ends: end frame (exclusive) of each window.
        overlap: frames each window after the first takes from its predecessor.
    """

    length: int
    starts: tuple[int, ...]
    ends: tuple[int, ...]
    overlap: int

    @property
    def boundaries(self) -> tuple[int, ...]:
        """First newly generated frame of every window after the first (where a seam could show)."""
        return tuple(s + self.overlap for s in self.starts[1:])


def plan_windows(length: int, window: int, overlap: int) -> WindowPlan:
    """Windows of ``window`` frames overlapping by ``overlap`` covering ``length`` frames.

    A sequence no longer than ``window`` is one window. The last window is shortened to end at
    ``length`` (it always generates at least one new frame).
    """
    if window < 2 or not 0 < overlap < window:
        raise ValueError(f"need window >= 2 and 0 < overlap < window, got window={window}, overlap={overlap}")
    if length < 1:
        raise ValueError(f"length must be >= 1, got {length}")
    starts, ends = [0], [min(window, length)]
    while ends[-1] < length:
        start = ends[-1] - overlap
        starts.append(start)
        ends.append(min(start + window, length))
    return WindowPlan(length, tuple(starts), tuple(ends), overlap)


def inpainting_like(sampler: object) -> InpaintingSampler:
    """An inpainting sampler with ``sampler``'s scheduler, steps and guidance scale (a CFG sampler)."""
    cfg = getattr(sampler, "cfg", None)
    scheduler = getattr(sampler, "scheduler", None)
    if cfg is None or scheduler is None:
        raise TypeError(f"cannot stitch with sampler {type(sampler).__name__}: it has no cfg/scheduler")
    return InpaintingSampler(
        InpaintingConfig(
            guidance_scale=float(getattr(cfg, "guidance_scale", 1.0)),
            num_inference_steps=getattr(cfg, "num_inference_steps", None),
        ),
        scheduler,
    )


def _batch(items: Sequence[Tensor]) -> tuple[Tensor, Tensor | None]:
    lengths = [int(x.shape[0]) for x in items]
    out = torch.zeros(len(items), max(lengths), items[0].shape[-1], dtype=items[0].dtype)
    for i, x in enumerate(items):
        out[i, : x.shape[0]] = x
    return out, (None if len(set(lengths)) == 1 else lengths_to_mask(lengths, max(lengths)))


@torch.no_grad()
def stitched_sample(
    sampler: object,
    backbone: Any,
    conds: Sequence[Tensor],
    seeds: Sequence[int],
    channels: int,
    *,
    window: int,
    overlap: int,
    guidance_scale: float | None = None,
    progress: Progress | None = None,
) -> list[Tensor]:
    """One ``(L_i, channels)`` sample per condition ``(L_i, C)``, window by window (module docstring).

    Args:
        sampler: the direction's CFG sampler (its scheduler, steps and guidance are used throughout).
        backbone: the denoiser (eval mode).
        conds: per-item condition latents at the generated sequence's frame rate.
        seeds: per-item seeds (initial noise and step noise of every window).
        window, overlap: window length and overlap in frames (``window <= backbone.max_length``).
        guidance_scale: overrides the sampler's.
        progress: called with 1 after each window index (all items' windows of that index).
    """
    if len(conds) != len(seeds):
        raise ValueError(f"seeds: {len(seeds)} seeds for {len(conds)} inputs")
    max_length = getattr(backbone, "max_length", None)
    if max_length is not None and window > int(max_length):
        raise ValueError(f"window {window} exceeds the backbone's max_length={max_length}")
    plans = [plan_windows(int(c.shape[0]), window, overlap) for c in conds]
    gens = [torch.Generator().manual_seed(int(s)) for s in seeds]
    inpaint = inpainting_like(sampler)
    outs = [torch.zeros(int(c.shape[0]), channels) for c in conds]
    for k in range(max(len(p.starts) for p in plans)):
        live = [i for i, p in enumerate(plans) if k < len(p.starts)]
        spans = [(plans[i].starts[k], plans[i].ends[k]) for i in live]
        cond, mask = _batch([conds[i][s:e].float() for i, (s, e) in zip(live, spans)])
        noise, _ = _batch([torch.randn(e - s, channels, generator=gens[i]) for i, (s, e) in zip(live, spans)])
        item_gens = [gens[i] for i in live]
        if k == 0:
            z = sampler.sample(  # type: ignore[attr-defined]
                backbone,
                noise,
                cond,
                x_mask=mask,
                cond_mask=mask,
                guidance_scale=guidance_scale,
                generator=item_gens,
            )
        else:
            known = torch.zeros_like(noise)
            known_mask = torch.zeros(noise.shape[:2], dtype=torch.bool)
            for b, (i, (s, _)) in enumerate(zip(live, spans)):
                known[b, :overlap] = outs[i][s : s + overlap]
                known_mask[b, :overlap] = True
            z = inpaint.sample(
                backbone,
                known,
                known_mask,
                cond,
                noise=noise,
                x_mask=mask,
                cond_mask=mask,
                generator=item_gens,
                guidance_scale=guidance_scale,
            )
        for b, (i, (s, e)) in enumerate(zip(live, spans)):
            outs[i][s:e] = z[b, : e - s].float().cpu()
        if progress is not None:
            progress(1)
    return outs


def velocity_jumps(motion: np.ndarray, fps: float = 1.0) -> np.ndarray:
    """``(T − 2,)`` joint-velocity jump per frame: the mean over joints of ``|v_t − v_{t−1}| · fps``.

    ``v_t = (x_{t+1} − x_t) · fps`` (units per second), so the jump is an acceleration (units/s²) and
    motions at different frame rates compare. The value at index ``i`` belongs to frame ``i + 1``.
    """
    x = np.asarray(motion, dtype=np.float64)
    if x.ndim != 3 or x.shape[0] < 3:
        raise ValueError(f"motion must be (T >= 3, J, D), got {x.shape}")
    if not fps > 0:
        raise ValueError(f"fps must be > 0, got {fps}")
    v = np.diff(x, axis=0) * fps
    return np.linalg.norm(np.diff(v, axis=0), axis=-1).mean(axis=-1) * fps


def seam_jumps(
    motion: np.ndarray, boundaries: Sequence[int], fps: float = 1.0, radius: int = 1
) -> np.ndarray:
    """The largest :func:`velocity_jumps` within ``radius`` frames of each boundary frame."""
    jumps = velocity_jumps(motion, fps)
    out = []
    for b in boundaries:
        lo, hi = max(0, b - 1 - radius), min(len(jumps), b - 1 + radius + 1)
        if lo < hi:
            out.append(float(jumps[lo:hi].max()))
    return np.asarray(out)
