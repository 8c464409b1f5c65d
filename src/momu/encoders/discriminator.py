"""Mel-spectrogram discriminator for the music VAE's GAN loss (MoMu App. A.2, Eq. 10).

MoMu trains the mel-spectrogram VAE with an additional GAN loss "to prevent over-smoothed
mel-spectrogram" (§3.3, App. A.2). The discriminator is a PatchGAN (Isola et al.) over the mel
treated as a one-channel image ``(B, 1, n_mels, T)``: stride-2 4x4 convolutions with LeakyReLU,
then two stride-1 3x3 convolutions to a map of patch logits. Each logit judges a local
time-frequency patch, which is what over-smoothing destroys. GroupNorm replaces PatchGAN's
BatchNorm so the result does not depend on the batch split across processes.

The adversarial objective (LSGAN by default) lives in :mod:`momu.losses.gan`.
"""

from __future__ import annotations

from dataclasses import dataclass

import torch
from torch import nn

from momu.encoders.blocks import group_norm
from momu.registry import ENCODERS

__all__ = ["MelDiscriminatorConfig", "MelDiscriminator", "build_mel_discriminator"]


@dataclass
class MelDiscriminatorConfig:
    """PatchGAN mel discriminator hyperparameters (not specified by MoMu; PatchGAN defaults).

    Attributes:
        mel_bins: mel channels of the input (MoMu App. B.2: 80).
        channels: width of the first convolution.
        num_layers: stride-2 convolutions (each halves frequency and time; width doubles up to
            ``max_channels``). Inputs need at least ``2 ** num_layers`` bins and frames.
        max_channels: width cap.
        negative_slope: LeakyReLU slope.
        norm_groups: maximum GroupNorm group count.
    """

    mel_bins: int = 80
    channels: int = 64
    num_layers: int = 3
    max_channels: int = 512
    negative_slope: float = 0.2
    norm_groups: int = 32


class MelDiscriminator(nn.Module):
    """``(B, n_mels, T)`` log-mel -> ``(B, 1, n_mels / 2^L, T / 2^L)`` patch logits (real > fake)."""

    def __init__(self, cfg: MelDiscriminatorConfig | None = None) -> None:
        super().__init__()
        cfg = cfg or MelDiscriminatorConfig()
        for name in ("mel_bins", "channels", "num_layers", "max_channels", "norm_groups"):
            if getattr(cfg, name) < 1:
                raise ValueError(f"mel_discriminator.{name} must be >= 1, got {getattr(cfg, name)}")
        if cfg.mel_bins < 2**cfg.num_layers:
            raise ValueError(
                f"mel_discriminator: mel_bins={cfg.mel_bins} is too small for num_layers={cfg.num_layers} "
                f"(needs >= {2**cfg.num_layers})"
            )
        self.cfg = cfg
        slope = cfg.negative_slope
        layers: list[nn.Module] = [
            nn.Conv2d(1, cfg.channels, 4, stride=2, padding=1),
            nn.LeakyReLU(slope),
        ]
        ch = cfg.channels
        for _ in range(cfg.num_layers - 1):
            out = min(2 * ch, cfg.max_channels)
            layers += [
                nn.Conv2d(ch, out, 4, stride=2, padding=1),
                group_norm(out, cfg.norm_groups),
                nn.LeakyReLU(slope),
            ]
            ch = out
        layers += [
            nn.Conv2d(ch, ch, 3, padding=1),
            group_norm(ch, cfg.norm_groups),
            nn.LeakyReLU(slope),
            nn.Conv2d(ch, 1, 3, padding=1),
        ]
        self.net = nn.Sequential(*layers)
        self.min_frames = 2**cfg.num_layers

    def forward(self, mel: torch.Tensor) -> torch.Tensor:
        if mel.ndim != 3 or mel.shape[1] != self.cfg.mel_bins:
            raise ValueError(f"mel must be (B, {self.cfg.mel_bins}, T), got {tuple(mel.shape)}")
        if mel.shape[-1] < self.min_frames:
            raise ValueError(f"mel has {mel.shape[-1]} frames; the discriminator needs >= {self.min_frames}")
        return self.net(mel[:, None])


@ENCODERS.register("mel_discriminator", config=MelDiscriminatorConfig)
def build_mel_discriminator(cfg: MelDiscriminatorConfig) -> MelDiscriminator:
    """Registry factory: the PatchGAN mel discriminator of MoMu App. A.2."""
    return MelDiscriminator(cfg)
