"""Losses on a diffusion model's clean estimate decoded to joint positions (cross-method mixing).

A latent diffusion model (MoMu) predicts ε (or v, or x₀) in a latent space; a loss written for poses
(MoFusion's kinematic terms, HarmoGAN's harmony loss) needs joint positions. The diffusion stage
decodes the denoiser's x̂₀ (:meth:`NoiseScheduler.x0_of`) through the frozen motion decoder, and
hands each such loss a :class:`DecodedMotion`. A loss that can be used this way implements
:class:`DecodedMotionLoss`: ``decoded_loss(d) -> (per-sample loss (B,), logs)`` plus
``schedules_itself`` (whether its value already carries a time weighting λ(t), as MoFusion's Eq. 4
does; otherwise the caller weights it by ᾱ_t — :func:`alpha_bar_weight`, MoFusion's schedule: at
high noise x̂₀ is a blur that carries no poses or beats, and its loss would only add noise).

The math of every loss stays in its own module (:mod:`momu.losses.scheduled_kinematic`,
:mod:`momu.losses.harmony`); this module only defines what they receive.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol, runtime_checkable

import torch
from torch import Tensor

__all__ = ["DecodedMotion", "DecodedMotionLoss", "alpha_bar_weight", "frame_mask"]


@dataclass
class DecodedMotion:
    """One batch of decoded clean estimates and what a loss on them may need.

    Attributes:
        pred: ``(B, T, J, D)`` joint positions decoded from the denoiser's x̂₀ (differentiable).
        target: ``(B, T, J, D)`` joint positions decoded from the clean x₀ (no gradient).
        fps: frame rate of ``pred`` / ``target``.
        t: ``(B,)`` diffusion time steps of the batch.
        alphas_cumprod: ``(T_train,)`` the training scheduler's ᾱ.
        skeleton: the joint layout's name (:mod:`momu.features.skeletons`).
        mask: ``(B, T)`` valid frames, or ``None`` (all valid).
        music_beats: the salient audio beats of each item's music as ``(times (B, K) s from the item's
            first frame, saliency (B, K), mask (B, K))`` (:func:`momu.losses.harmony.pad_targets`), or
            ``None`` when no loss asked for them.
    """

    pred: Tensor
    target: Tensor
    fps: float
    t: Tensor
    alphas_cumprod: Tensor
    skeleton: str
    mask: Tensor | None = None
    music_beats: tuple[Tensor, Tensor, Tensor] | None = None


@runtime_checkable
class DecodedMotionLoss(Protocol):
    """A loss part usable on decoded clean estimates (module docstring)."""

    schedules_itself: bool
    needs_music_beats: bool

    def decoded_loss(self, d: DecodedMotion) -> tuple[Tensor, dict[str, Tensor]]: ...


def alpha_bar_weight(t: Tensor, alphas_cumprod: Tensor, ref: Tensor) -> Tensor:
    """ᾱ_t per sample ``(B,)`` in ``ref``'s dtype and device (MoFusion Eq. 4's λ_k^(t))."""
    return alphas_cumprod.to(ref.device)[t.long().to(ref.device)].to(ref.dtype)


def frame_mask(latent_mask: Tensor | None, frames_per_latent: int) -> Tensor | None:
    """A latent-frame mask ``(B, T_z)`` as a motion-frame mask ``(B, T_z · frames_per_latent)``."""
    if latent_mask is None:
        return None
    return torch.repeat_interleave(latent_mask, int(frames_per_latent), dim=1)
