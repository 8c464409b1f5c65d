"""Sequences of any length from a fixed-window diffusion model: overlapping windows stitched by inpainting.

A MoMu denoiser is trained on windows of ``window_seconds`` (4 s at the cpu preset) and its DiT has a
``max_length``; a song is longer. The song's condition latent (the whole song encoded at once: the
BiCoR-VAE encoders are convolutional) is cut into windows of ``W`` latent frames
(:mod:`momu.generation.windows` places them):

* a window with no known frames is sampled with classifier-free guidance (MoMu Eq. 7) on its part of
  the condition;
* a window with known frames — the first ``O`` frames that the window before it generated, and in the
  ``two_pass`` schedule also the last ``O`` frames that the window after it generated — is sampled by
  inpainting (MoFusion §4.4: the known frames are replaced by their forward-diffused values before
  every denoising step), with CFG on the rest. So each window continues its neighbours instead of
  starting afresh.

A bridge of the ``two_pass`` schedule must meet fixed frames at *both* ends; with hard replacement its
last new frames jump onto the next anchor more often than a sequential window's first frames do
(benchmarks/bench_long_song.py). So a bridge's known frames are a *soft* mask (:func:`ramp`: weight 1 at
the bridge's outer edges down to ``1/O`` next to its new frames; :mod:`momu.samplers.inpainting`): the
known frames nearest the new ones may move towards them, and the outer edge — where the anchor takes
over — is kept exactly. The sequential schedule keeps every known frame exactly (hard mask).

``two_pass`` (the default) samples all anchors of all items as batches of windows, then all bridges;
``sequential`` samples window ``k`` of every item after window ``k − 1`` (items that have no window
``k`` any more drop out). Each window's noise comes from its own seeded generator
(:func:`momu.generation.windows.window_generator`; sequential: one generator per item for all its
windows), so an item's result does not depend on the batch it is sampled in.

**Latents, not poses.** MoMu generates in the BiCoR-VAE latent space, so the stitching happens there:
known frames are latent frames, the stitched latent of the whole song is decoded once, and the
(convolutional) decoder sees one continuous sequence — no window edge reaches the decoder. Inpainting
poses would need a decode inside every denoising step and would still leave the decoder's edges at
every window.

:func:`seam_jumps` and :func:`velocity_jumps` measure what a seam would look like: the change of joint
velocity between consecutive frames, at the window boundaries, against the same statistic of real data.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
import torch
from torch import Tensor

from momu.generation.windows import SCHEDULES, WindowPlan, plan_windows, window_generator
from momu.samplers.base import lengths_to_mask
from momu.samplers.branches import SeparateNullBranch
from momu.samplers.inpainting import InpaintingConfig, InpaintingSampler

__all__ = [
    "WindowPlan",
    "plan_windows",
    "stitched_sample",
    "velocity_jumps",
    "seam_jumps",
    "inpainting_like",
    "MAX_BATCH_FRAMES",
]

Progress = Callable[[int], None]
"""Called with the number of windows just finished (for a progress bar)."""

MAX_BATCH_FRAMES = 2048
"""Latent frames (windows × window length) sampled in one batch by the two-pass schedule: 33 windows
of the cpu preset's 62 frames; bounds memory for long windows and large models."""

SPLIT_MIN_WINDOWS = 4
"""Batches of at least this many windows run CFG's unconditional branch as its own forward
(:class:`momu.samplers.branches.SeparateNullBranch`); smaller ones gain little from it, and a song of
one window then is exactly one-window generation (``MoMuModel.music_to_motion``)."""


def inpainting_like(sampler: object) -> InpaintingSampler:
    """An inpainting sampler with ``sampler``'s scheduler, steps, guidance scale, interval, rescale,
    parallel weight and noise temperature (a CFG sampler)."""
    cfg = getattr(sampler, "cfg", None)
    scheduler = getattr(sampler, "scheduler", None)
    if cfg is None or scheduler is None:
        raise TypeError(f"cannot stitch with sampler {type(sampler).__name__}: it has no cfg/scheduler")
    return InpaintingSampler(
        InpaintingConfig(
            guidance_scale=float(getattr(cfg, "guidance_scale", 1.0)),
            num_inference_steps=getattr(cfg, "num_inference_steps", None),
            guidance_interval=getattr(cfg, "guidance_interval", None),
            guidance_rescale=float(getattr(cfg, "guidance_rescale", 0.0)),
            guidance_parallel=float(getattr(cfg, "guidance_parallel", 1.0)),
            noise_temperature=float(getattr(cfg, "noise_temperature", 1.0)),
        ),
        scheduler,
    )


def ramp(frames: int, soft: bool) -> Tensor:
    """Weights of a run of ``n = frames`` known frames that starts next to the unknown frames (a run
    that ends there takes them reversed): ``1/n, 2/n, …, 1`` (soft: the frames nearest the unknown ones
    may move most, the outermost is kept exactly), or all True (hard: every known frame kept)."""
    if not soft:
        return torch.ones(frames, dtype=torch.bool)
    return torch.arange(1, frames + 1, dtype=torch.float32) / frames


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
    schedule: str = "two_pass",
    max_batch_frames: int = MAX_BATCH_FRAMES,
    soft_edges: bool = True,
) -> list[Tensor]:
    """One ``(L_i, channels)`` sample per condition ``(L_i, C)``, window by window (module docstring).

    Args:
        sampler: the direction's CFG sampler (its scheduler, steps and guidance are used throughout).
        backbone: the denoiser (eval mode).
        conds: per-item condition latents at the generated sequence's frame rate.
        seeds: per-item seeds (initial noise and step noise of every window).
        window, overlap: window length and overlap in frames (``window <= backbone.max_length``).
        guidance_scale: overrides the sampler's.
        progress: called with the number of windows (of all items) finished after each batch.
        schedule: ``"two_pass"`` (batched anchors, then batched bridges; needs ``window > 2 * overlap``)
            or ``"sequential"`` (:mod:`momu.generation.windows`).
        max_batch_frames: two-pass only: at most this many latent frames (windows × ``window``) per
            batch (at least one window).
        soft_edges: two-pass only: a bridge's known frames are a soft mask (module docstring); False
            keeps every known frame exactly, as the sequential schedule does.
    """
    if len(conds) != len(seeds):
        raise ValueError(f"seeds: {len(seeds)} seeds for {len(conds)} inputs")
    if schedule not in SCHEDULES:
        raise ValueError(f"schedule {schedule!r} not one of {SCHEDULES}")
    max_length = getattr(backbone, "max_length", None)
    if max_length is not None and window > int(max_length):
        raise ValueError(f"window {window} exceeds the backbone's max_length={max_length}")
    plans = [plan_windows(int(c.shape[0]), window, overlap, schedule) for c in conds]
    outs = [torch.zeros(int(c.shape[0]), channels) for c in conds]
    job = _Job(sampler, backbone, conds, channels, guidance_scale, soft_edges and schedule == "two_pass")
    if schedule == "sequential":
        gens = [torch.Generator().manual_seed(int(s)) for s in seeds]
        for k in range(max(len(p.starts) for p in plans)):
            live = [i for i, p in enumerate(plans) if k < len(p.starts)]
            job.run([(i, k) for i in live], plans, outs, [gens[i] for i in live])
            if progress is not None:
                progress(1)
        return outs
    # two-pass: windows are independent within a pass, so batch them (and, in large batches, drop the
    # padded null-condition tokens of the unconditional CFG branch: the same result, less work)
    per_batch = max(1, int(max_batch_frames) // window)
    for p in range(2):
        todo = [(i, k) for i, plan in enumerate(plans) if p < len(plan.passes()) for k in plan.passes()[p]]
        for b in range(0, len(todo), per_batch):
            chunk = todo[b : b + per_batch]
            job.backbone = SeparateNullBranch(backbone) if len(chunk) >= SPLIT_MIN_WINDOWS else backbone
            job.run(chunk, plans, outs, [window_generator(seeds[i], k) for i, k in chunk])
            if progress is not None:
                progress(len(chunk))
    return outs


class _Job:
    """Samples a batch of windows ``(item, window index)`` and writes them into the items' outputs."""

    def __init__(
        self,
        sampler: object,
        backbone: Any,
        conds: Sequence[Tensor],
        channels: int,
        scale: float | None,
        soft: bool,
    ) -> None:
        self.sampler, self.backbone, self.conds = sampler, backbone, conds
        self.channels, self.scale, self.soft = channels, scale, soft
        self.inpaint = inpainting_like(sampler)
        self.raw: dict[tuple[int, int], Tensor] = {}  # every window's own output, (item, window index)

    def run(
        self,
        windows: Sequence[tuple[int, int]],
        plans: Sequence[WindowPlan],
        outs: list[Tensor],
        gens: list[torch.Generator],
    ) -> None:
        spans = [(plans[i].starts[k], plans[i].ends[k]) for i, k in windows]
        cond, mask = _batch([self.conds[i][s:e].float() for (i, _), (s, e) in zip(windows, spans)])
        noise, _ = _batch([torch.randn(e - s, self.channels, generator=g) for (s, e), g in zip(spans, gens)])
        known_frames = [plans[i].known(k) for i, k in windows]
        if not any(h or t for h, t in known_frames):
            z = self.sampler.sample(  # type: ignore[attr-defined]
                self.backbone,
                noise,
                cond,
                x_mask=mask,
                cond_mask=mask,
                guidance_scale=self.scale,
                generator=gens,
            )
        else:
            known = torch.zeros_like(noise)
            soft = self.soft
            known_mask = torch.zeros(noise.shape[:2], dtype=noise.dtype if soft else torch.bool)
            for b, ((i, k), (s, e), (head, tail)) in enumerate(zip(windows, spans, known_frames)):
                if head:  # the window before it generated these frames
                    before = plans[i].starts[k - 1]
                    known[b, :head] = self.raw[i, k - 1][s - before : s - before + head]
                    known_mask[b, :head] = ramp(head, soft).flip(0)
                if tail:  # and the window after it these
                    after = plans[i].starts[k + 1]
                    known[b, e - s - tail : e - s] = self.raw[i, k + 1][e - tail - after : e - after]
                    known_mask[b, e - s - tail : e - s] = ramp(tail, soft)
            z = self.inpaint.sample(
                self.backbone,
                known,
                known_mask,
                cond,
                noise=noise,
                x_mask=mask,
                cond_mask=mask,
                generator=gens,
                guidance_scale=self.scale,
            )
        for b, ((i, k), (s, e)) in enumerate(zip(windows, spans)):
            self.raw[i, k] = z[b, : e - s].float().cpu()
            outs[i][s:e] = self.raw[i, k]


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
