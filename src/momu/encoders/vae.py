"""Gaussian 1D-convolutional VAE: encoder, decoder, reparameterisation and KL (MoMu §3.1, App. A.1).

Every BiCoR-VAE branch (keypoint motion, mel-spectrogram music, and the Table 7 alternatives:
unit bone directions, raw waveform) is the same network over a different representation:

* :class:`Encoder1d`: Conv1d in, per level ``num_res_blocks`` residual blocks at
  ``base_channels * channel_mult[i]`` channels, a strided Conv1d downsampling layer after the
  levels listed in ``downsample_levels``, a middle block (residual, spatial transformer with
  ``attention_layers`` layers, residual), GroupNorm/SiLU and a Conv1d to ``2 * latent_channels``
  moments (mean, log-variance).
* :class:`Decoder1d`: the mirror image, with ``num_res_blocks + 1`` residual blocks per level and
  nearest-neighbour + Conv1d upsampling.
* :class:`DiagonalGaussian`: the posterior ``q(z|x) = N(mu, diag(sigma^2))``, reparameterised
  sampling ``z = mu + sigma * eps`` and the closed-form ``KL(q || N(0, I))``.
* :class:`SequenceVAE`: the base class of every branch; subclasses only say how their input maps
  to a channels-first ``(B, C, T)`` tensor and back.

Latents are **channels-last** ``(B, T_z, d)`` (the layout of the diffusion backbones).

Table 8 mapping (:class:`VAE1dConfig`): "Hidden channels 20" is the latent width ``d``
(``latent_channels``; Table 9's "Input channels 20" of the denoiser is the same number),
"Residual blocks 2" -> ``num_res_blocks``, "Channel multiplier [1,2,4]" -> ``channel_mult``,
"Spatial attention layers 3" -> ``attention_layers`` (transformer layers of the middle block),
"Downsampling rate 2" -> ``downsample_rate`` of the single Conv1d downsampling layer App. A.1
describes (``downsample_levels = [0]``), "Kernel size of Conv1d 5" -> ``kernel_size``. Table 8's
numbers match the configuration of Make-An-Audio 2's 1D mel VAE (latent 20, mult [1,2,4], 2
residual blocks, kernel 5, one downsampling layer). The base width is not in Table 8:
:func:`paper_vae_config` uses 192, which makes this implementation's two branches total 216.7M
parameters, Table 8's "Total Params 213M" (Make-An-Audio 2's width 384 would give 865M here,
because our middle block holds 3 full transformer layers at 4x the base width).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field

import torch
import torch.nn.functional as F
from einops import rearrange
from torch import nn

from momu.encoders.blocks import (
    PADDING_MODES,
    Downsample1d,
    MiddleBlock1d,
    ResBlock1d,
    Upsample1d,
    group_norm,
    set_padding_mode,
)

__all__ = [
    "VAE1dConfig",
    "paper_vae_config",
    "check_vae_config",
    "DiagonalGaussian",
    "Encoder1d",
    "Decoder1d",
    "VAEOutput",
    "SequenceVAE",
]

LOGVAR_MIN = -30.0
LOGVAR_MAX = 20.0


@dataclass
class VAE1dConfig:
    """Hyperparameters of one Gaussian 1D-conv VAE branch (MoMu Table 8).

    Attributes:
        latent_channels: latent width ``d`` (Table 8 "Hidden channels" = 20).
        base_channels: width of the first level (not in Table 8; 192 in :func:`paper_vae_config`,
            matching Table 8's 213M parameters; small by default so the part trains on a CPU).
        channel_mult: per-level width multipliers (Table 8: [1, 2, 4]).
        num_res_blocks: residual blocks per encoder level (Table 8: 2; the decoder has one more).
        attention_layers: transformer layers in the middle "spatial transformer" (Table 8: 3;
            0 = purely convolutional).
        attention_heads: heads of those layers (must divide ``base_channels * channel_mult[-1]``).
        downsample_rate: stride of each Conv1d downsampling layer (Table 8: 2).
        downsample_levels: encoder levels followed by a downsampling layer (App. A.1: one layer,
            after the first level). Total downsampling = ``downsample_rate ** len(downsample_levels)``.
        kernel_size: Conv1d kernel size (Table 8: 5; odd).
        dropout: dropout inside residual blocks and transformer feed-forwards.
        norm_groups: maximum GroupNorm group count (the largest divisor of the width is used).
        padding_mode: padding of every convolution: ``"zeros"`` (latent-diffusion autoencoders,
            the default) or ``"replicate"``/``"reflect"`` (no zero-padding edge artefacts in the
            first and last decoded frames; :func:`momu.encoders.blocks.set_padding_mode`).
    """

    latent_channels: int = 20
    base_channels: int = 32
    channel_mult: list[int] = field(default_factory=lambda: [1, 2, 4])
    num_res_blocks: int = 2
    attention_layers: int = 3
    attention_heads: int = 4
    downsample_rate: int = 2
    downsample_levels: list[int] = field(default_factory=lambda: [0])
    kernel_size: int = 5
    dropout: float = 0.0
    norm_groups: int = 32
    padding_mode: str = "zeros"


def paper_vae_config(**overrides: object) -> VAE1dConfig:
    """The MoMu Table 8 branch configuration at its published size (base width 192, ~108M parameters).

    Two such branches (motion + mel) total 216.7M parameters; Table 8 reports 213M.
    """
    return dataclasses.replace(VAE1dConfig(base_channels=192, attention_heads=8), **overrides)  # type: ignore[arg-type]


def check_vae_config(cfg: VAE1dConfig, where: str = "vae") -> None:
    """Raise ``ValueError`` naming the first invalid field of ``cfg`` (``where`` prefixes it)."""

    def bad(name: str, why: str) -> ValueError:
        return ValueError(f"{where}.{name}: {why} (got {getattr(cfg, name)!r})")

    for name in ("latent_channels", "base_channels", "downsample_rate", "norm_groups", "attention_heads"):
        if int(getattr(cfg, name)) < 1:
            raise bad(name, "must be >= 1")
    if cfg.num_res_blocks < 1:
        raise bad("num_res_blocks", "must be >= 1")
    if cfg.attention_layers < 0:
        raise bad("attention_layers", "must be >= 0")
    if not cfg.channel_mult or any(int(m) < 1 for m in cfg.channel_mult):
        raise bad("channel_mult", "must be a non-empty list of positive integers")
    levels = list(cfg.downsample_levels)
    if len(set(levels)) != len(levels) or any(not 0 <= int(i) < len(cfg.channel_mult) for i in levels):
        raise bad("downsample_levels", f"must be distinct level indices in [0, {len(cfg.channel_mult) - 1}]")
    if cfg.kernel_size < 1 or cfg.kernel_size % 2 == 0:
        raise bad("kernel_size", "must be a positive odd integer")
    if not 0.0 <= cfg.dropout < 1.0:
        raise bad("dropout", "must be in [0, 1)")
    if cfg.padding_mode not in PADDING_MODES:
        raise bad("padding_mode", f"must be one of {PADDING_MODES}")
    top = cfg.base_channels * cfg.channel_mult[-1]
    if cfg.attention_layers > 0 and top % cfg.attention_heads != 0:
        raise bad("attention_heads", f"must divide the middle-block width {top}")


class DiagonalGaussian:
    """Diagonal Gaussian posterior ``N(mean, exp(logvar))`` over channels-last latents ``(B, T_z, d)``.

    The log-variance is clamped to [-30, 20] (as in latent-diffusion autoencoders) so ``exp`` never
    overflows.
    """

    def __init__(self, mean: torch.Tensor, logvar: torch.Tensor) -> None:
        if mean.shape != logvar.shape:
            raise ValueError(f"mean {tuple(mean.shape)} and logvar {tuple(logvar.shape)} shapes differ")
        self.mean = mean
        self.logvar = logvar.clamp(LOGVAR_MIN, LOGVAR_MAX)

    @classmethod
    def from_moments(cls, moments: torch.Tensor) -> DiagonalGaussian:
        """From encoder moments ``(B, 2d, T_z)`` (mean channels first, then log-variance)."""
        mean, logvar = rearrange(moments, "b c t -> b t c").chunk(2, dim=-1)
        return cls(mean, logvar)

    @property
    def std(self) -> torch.Tensor:
        return torch.exp(0.5 * self.logvar)

    @property
    def var(self) -> torch.Tensor:
        return torch.exp(self.logvar)

    @property
    def shape(self) -> torch.Size:
        return self.mean.shape

    def sample(self, generator: torch.Generator | None = None) -> torch.Tensor:
        """Reparameterised sample ``mean + std * eps``, ``eps ~ N(0, I)`` (differentiable)."""
        device = generator.device if generator is not None else self.mean.device
        eps = torch.randn(self.mean.shape, generator=generator, device=device, dtype=self.mean.dtype)
        return self.mean + self.std * eps.to(self.mean.device)

    def mode(self) -> torch.Tensor:
        return self.mean

    def kl(self, mask: torch.Tensor | None = None) -> torch.Tensor:
        """``KL(q || N(0, I))`` per item ``(B,)``: ``0.5 * sum(mean^2 + var - 1 - logvar)`` over ``(T_z, d)``.

        ``mask``: optional ``(B, T_z)`` bool, True = valid latent frame; invalid frames add nothing.
        """
        per = 0.5 * (self.mean.pow(2) + self.var - 1.0 - self.logvar)  # (B, T_z, d)
        if mask is not None:
            per = per * mask[..., None].to(per.dtype)
        return per.flatten(1).sum(dim=1)

    def detach(self) -> DiagonalGaussian:
        return DiagonalGaussian(self.mean.detach(), self.logvar.detach())


def _level_widths(cfg: VAE1dConfig) -> list[int]:
    return [cfg.base_channels * int(m) for m in cfg.channel_mult]


class Encoder1d(nn.Module):
    """``(B, in_channels, T) -> (B, 2 * latent_channels, T / downsample)`` moments (MoMu App. A.1)."""

    def __init__(self, in_channels: int, cfg: VAE1dConfig) -> None:
        super().__init__()
        check_vae_config(cfg)
        widths = _level_widths(cfg)
        k, pad = cfg.kernel_size, cfg.kernel_size // 2
        self.conv_in = nn.Conv1d(in_channels, widths[0], k, padding=pad)
        self.levels = nn.ModuleList()
        ch = widths[0]
        for i, width in enumerate(widths):
            blocks: list[nn.Module] = []
            for _ in range(cfg.num_res_blocks):
                blocks.append(ResBlock1d(ch, width, k, cfg.dropout, cfg.norm_groups))
                ch = width
            if i in cfg.downsample_levels:
                blocks.append(Downsample1d(ch, cfg.downsample_rate, k))
            self.levels.append(nn.Sequential(*blocks))
        self.mid = MiddleBlock1d(
            ch, k, cfg.attention_layers, cfg.attention_heads, cfg.dropout, cfg.norm_groups
        )
        self.norm_out = group_norm(ch, cfg.norm_groups)
        self.conv_out = nn.Conv1d(ch, 2 * cfg.latent_channels, k, padding=pad)
        set_padding_mode(self, cfg.padding_mode)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        h = self.conv_in(x)
        for level in self.levels:
            h = level(h)
        h = self.mid(h)
        return self.conv_out(F.silu(self.norm_out(h)))


class Decoder1d(nn.Module):
    """``(B, latent_channels, T_z) -> (B, out_channels, T_z * downsample)``, the encoder's mirror."""

    def __init__(self, out_channels: int, cfg: VAE1dConfig) -> None:
        super().__init__()
        check_vae_config(cfg)
        widths = _level_widths(cfg)
        k, pad = cfg.kernel_size, cfg.kernel_size // 2
        ch = widths[-1]
        self.conv_in = nn.Conv1d(cfg.latent_channels, ch, k, padding=pad)
        self.mid = MiddleBlock1d(
            ch, k, cfg.attention_layers, cfg.attention_heads, cfg.dropout, cfg.norm_groups
        )
        self.levels = nn.ModuleList()
        for i in reversed(range(len(widths))):
            blocks: list[nn.Module] = []
            if i in cfg.downsample_levels:
                blocks.append(Upsample1d(ch, cfg.downsample_rate, k))
            for _ in range(cfg.num_res_blocks + 1):
                blocks.append(ResBlock1d(ch, widths[i], k, cfg.dropout, cfg.norm_groups))
                ch = widths[i]
            self.levels.append(nn.Sequential(*blocks))
        self.norm_out = group_norm(ch, cfg.norm_groups)
        self.conv_out = nn.Conv1d(ch, out_channels, k, padding=pad)
        set_padding_mode(self, cfg.padding_mode)

    def forward(self, z: torch.Tensor) -> torch.Tensor:
        h = self.mid(self.conv_in(z))
        for level in self.levels:
            h = level(h)
        return self.conv_out(F.silu(self.norm_out(h)))


@dataclass
class VAEOutput:
    """What :meth:`SequenceVAE.forward` returns.

    Attributes:
        reconstruction: the decoded representation (same layout as ``target``), before
            :meth:`SequenceVAE.realize`; the reconstruction loss compares these two.
        target: the input in the branch's representation (:meth:`SequenceVAE.represent`).
        posterior: ``q(z|x)``.
        latent: the latent that was decoded ``(B, T_z, d)`` (a sample, or the mean).
    """

    reconstruction: torch.Tensor
    target: torch.Tensor
    posterior: DiagonalGaussian
    latent: torch.Tensor


class SequenceVAE(nn.Module):
    """Base of every BiCoR-VAE branch: a Gaussian 1D-conv VAE over one modality.

    A subclass maps its input to a *representation* (:meth:`represent`, identity unless the branch
    re-encodes its input, e.g. unit bone directions), the representation to channels-first
    ``(B, C, steps)`` (:meth:`to_channels`) and back (:meth:`from_channels`), and a decoded
    representation to the input space (:meth:`realize`). One latent frame covers
    ``frames_per_latent`` input frames (``frames_per_step * total downsampling``). Inputs whose
    length is not a multiple of that are padded (edge replication) and decoded outputs cropped.

    Class attributes: ``modality`` (``"motion"`` or ``"music"``), ``input_kind`` (``"keypoints"``,
    ``"bone_directions"``, ``"mel"``, ``"waveform"``).
    """

    modality: str = ""
    input_kind: str = ""

    def __init__(self, channels: int, cfg: VAE1dConfig, frames_per_step: int = 1) -> None:
        super().__init__()
        check_vae_config(cfg)
        if channels < 1:
            raise ValueError(f"channels must be >= 1, got {channels}")
        if frames_per_step < 1:
            raise ValueError(f"frames_per_step must be >= 1, got {frames_per_step}")
        self.cfg = cfg
        self.channels = channels
        self.latent_channels = cfg.latent_channels
        self.downsample_factor = cfg.downsample_rate ** len(cfg.downsample_levels)
        self.frames_per_step = frames_per_step
        self.frames_per_latent = frames_per_step * self.downsample_factor
        self.encoder = Encoder1d(channels, cfg)
        self.decoder = Decoder1d(channels, cfg)

    # ---------------------------------------------------------------- representation hooks
    def represent(self, x: torch.Tensor) -> torch.Tensor:
        """Input -> representation the VAE reconstructs (identity by default)."""
        return x

    def realize(self, rep: torch.Tensor) -> torch.Tensor:
        """Decoded representation -> input space (identity by default)."""
        return rep

    def to_channels(self, rep: torch.Tensor) -> torch.Tensor:  # pragma: no cover - abstract
        """Representation -> channels-first ``(B, C, steps)``."""
        raise NotImplementedError

    def from_channels(self, y: torch.Tensor, length: int) -> torch.Tensor:  # pragma: no cover - abstract
        """Channels-first ``(B, C, steps)`` -> representation cropped to ``length`` input frames."""
        raise NotImplementedError

    def input_length(self, x: torch.Tensor) -> int:  # pragma: no cover - abstract
        """Number of input frames (motion frames, mel frames or samples) of ``x``."""
        raise NotImplementedError

    # ---------------------------------------------------------------- lengths
    def latent_length(self, num_frames: int) -> int:
        """Latent frames for ``num_frames`` input frames: ``ceil(num_frames / frames_per_latent)``."""
        return math.ceil(num_frames / self.frames_per_latent)

    @property
    def last_layer(self) -> torch.Tensor:
        """The decoder's output-convolution weight (for the adaptive GAN weight of :mod:`momu.losses.gan`)."""
        return self.decoder.conv_out.weight

    def _pad_steps(self, h: torch.Tensor) -> torch.Tensor:
        extra = (-h.shape[-1]) % self.downsample_factor
        return F.pad(h, (0, extra), mode="replicate") if extra else h

    # ---------------------------------------------------------------- VAE
    def _encode_rep(self, rep: torch.Tensor) -> DiagonalGaussian:
        return DiagonalGaussian.from_moments(self.encoder(self._pad_steps(self.to_channels(rep))))

    def encode(self, x: torch.Tensor) -> DiagonalGaussian:
        """``q(z|x)`` with channels-last latents ``(B, latent_length(input_length(x)), d)``."""
        return self._encode_rep(self.represent(x))

    def decode_representation(self, z: torch.Tensor, length: int | None = None) -> torch.Tensor:
        """Latent ``(B, T_z, d)`` -> representation of ``length`` input frames (default: all).

        "All" is ``T_z * frames_per_latent`` frames.
        """
        if z.ndim != 3 or z.shape[-1] != self.latent_channels:
            raise ValueError(f"z must be (B, T_z, {self.latent_channels}), got {tuple(z.shape)}")
        full = z.shape[1] * self.frames_per_latent
        length = full if length is None else int(length)
        if not 0 < length <= full:
            raise ValueError(f"length must be in [1, {full}] for {z.shape[1]} latent frames, got {length}")
        return self.from_channels(self.decoder(rearrange(z, "b t c -> b c t")), length)

    def decode(self, z: torch.Tensor, length: int | None = None) -> torch.Tensor:
        """Latent ``(B, T_z, d)`` -> input space, ``length`` frames (default ``T_z * frames_per_latent``)."""
        return self.realize(self.decode_representation(z, length))

    def forward(
        self, x: torch.Tensor, sample: bool = True, generator: torch.Generator | None = None
    ) -> VAEOutput:
        """Encode, sample (or take the mean when ``sample`` is False), decode the representation."""
        target = self.represent(x)
        posterior = self._encode_rep(target)
        z = posterior.sample(generator) if sample else posterior.mode()
        recon = self.decode_representation(z, self.input_length(x))
        return VAEOutput(reconstruction=recon, target=target, posterior=posterior, latent=z)
