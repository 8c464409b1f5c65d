"""Songs and dances of any length with a trained :class:`~momu.methods.momu.MoMuModel`.

:func:`music_to_motion_long` and :func:`motion_to_music_long` encode the whole input once, generate the
other modality's latent window by window (:func:`momu.generation.stitching.stitched_sample`: windows
inpainted on the frames their neighbours generated, in two batched passes by default) and decode the
stitched latent once. The window is the
model's training window (``MoMuConfig.window_seconds``) unless given, capped by the denoiser's
``max_length``; the overlap is a quarter of it.

This module only *uses* a MoMuModel (its encoders, samplers, backbones and decoders); it adds no state
to it.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

import numpy as np

from momu.generation.stitching import Progress, stitched_sample
from momu.generation.windows import WindowPlan, plan_windows

if TYPE_CHECKING:  # pragma: no cover - typing only
    from momu.methods.momu import MoMuModel

__all__ = [
    "window_frames",
    "usable_schedule",
    "plan_for_seconds",
    "music_to_motion_long",
    "motion_to_music_long",
]

OVERLAP_FRACTION = 0.25
"""Overlap of consecutive windows as a fraction of the window."""


def window_frames(
    model: MoMuModel,
    direction: str,
    window_seconds: float | None = None,
    overlap_seconds: float | None = None,
) -> tuple[int, int]:
    """``(window, overlap)`` in latent frames for generating ``direction`` (``"motion"`` or ``"music"``)."""
    rates = model.rates
    seconds = float(window_seconds if window_seconds is not None else model.cfg.window_seconds)
    window = rates.latent_frames(seconds)
    backbone = model.motion_backbone if direction == "motion" else model.music_backbone
    cap = getattr(backbone, "max_length", None)
    if cap is not None:
        window = min(window, int(cap))
    if overlap_seconds is None:
        overlap = max(1, int(round(OVERLAP_FRACTION * window)))
    else:
        overlap = max(1, int(round(overlap_seconds * rates.latent_rate)))
    if window < 2 or overlap >= window:
        raise ValueError(
            f"window of {window} latent frames with overlap {overlap}: need window > overlap >= 1"
        )
    return window, overlap


def usable_schedule(window: int, overlap: int, schedule: str) -> str:
    """``schedule``, except ``"sequential"`` where a two-pass bridge would have no frame of its own
    (``window <= 2 * overlap``: only models with windows of a few frames)."""
    return "sequential" if schedule == "two_pass" and window <= 2 * overlap else schedule


def plan_for_seconds(
    model: MoMuModel, seconds: float, direction: str = "motion", schedule: str = "two_pass"
) -> WindowPlan:
    """The window plan (latent frames) of a ``seconds``-long input with the default windows."""
    window, overlap = window_frames(model, direction)
    schedule = usable_schedule(window, overlap, schedule)
    return plan_windows(model.rates.latent_frames(seconds), window, overlap, schedule)


def _generate(
    model: MoMuModel,
    direction: str,
    conds: Sequence[Any],
    seeds: Sequence[int],
    guidance_scale: float | None,
    window_seconds: float | None,
    overlap_seconds: float | None,
    progress: Progress | None,
    schedule: str,
) -> list[Any]:
    """Stitched latents of ``direction`` (``"motion"`` or ``"music"``) for per-item condition latents."""
    window, overlap = window_frames(model, direction, window_seconds, overlap_seconds)
    return stitched_sample(
        model.sampler_for(direction),
        model.motion_backbone if direction == "motion" else model.music_backbone,
        conds,
        seeds,
        model.latent_channels,
        window=window,
        overlap=overlap,
        guidance_scale=guidance_scale,
        progress=progress,
        schedule=usable_schedule(window, overlap, schedule),
    )


def music_to_motion_long(
    model: MoMuModel,
    audios: Sequence[np.ndarray],
    sample_rate: int,
    seeds: Sequence[int],
    *,
    guidance_scale: float | None = None,
    window_seconds: float | None = None,
    overlap_seconds: float | None = None,
    progress: Progress | None = None,
    schedule: str = "two_pass",
) -> list[np.ndarray]:
    """Music → motion for songs of any length: one ``(T, J, D)`` motion at ``rates.motion_fps`` per song."""
    conds = [model.condition_from_music(a, sample_rate) for a in audios]
    latents = _generate(
        model, "motion", conds, seeds, guidance_scale, window_seconds, overlap_seconds, progress, schedule
    )
    return [model.decode_motion(z) for z in latents]


def motion_to_music_long(
    model: MoMuModel,
    motions: Sequence[np.ndarray],
    fps: float,
    seeds: Sequence[int],
    *,
    guidance_scale: float | None = None,
    window_seconds: float | None = None,
    overlap_seconds: float | None = None,
    progress: Progress | None = None,
    schedule: str = "two_pass",
) -> list[np.ndarray]:
    """Motion → music for dances of any length: one waveform at ``rates.sample_rate`` per motion."""
    conds = [model.condition_from_motion(m, fps) for m in motions]
    latents = _generate(
        model, "music", conds, seeds, guidance_scale, window_seconds, overlap_seconds, progress, schedule
    )
    return [model.decode_music(z) for z in latents]
