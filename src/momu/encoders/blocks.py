"""Reusable 1D building blocks for the sequence autoencoders (MoMu App. A.1).

MoMu's BiCoR-VAE (MoMu §3.1, App. A.1, Table 8) is "an encoder-decoder architecture, in which the
1D convolutional network and spatial transformer are used": residual Conv1d blocks, a Conv1d
downsampling layer, a middle block holding a (spatial) transformer, and a Conv1d upsampling
layer. This module holds those blocks; :mod:`momu.encoders.vae` assembles them.

Layout: every block here takes and returns **channels-first** sequences ``(B, C, T)`` (what
``nn.Conv1d`` wants); the attention layers rearrange to ``(B, T, C)`` internally.
"""

from __future__ import annotations

import math

import torch
import torch.nn.functional as F
from einops import rearrange
from torch import nn

from momu.attention import scaled_dot_product_attention

__all__ = [
    "group_norm",
    "ResBlock1d",
    "Downsample1d",
    "Upsample1d",
    "SelfAttention",
    "TransformerLayer",
    "SpatialTransformer1d",
    "MiddleBlock1d",
    "PADDING_MODES",
    "set_padding_mode",
]


def group_norm(channels: int, max_groups: int = 32, eps: float = 1e-6) -> nn.GroupNorm:
    """GroupNorm with the largest group count ``<= max_groups`` that divides ``channels``.

    Table 8's small widths (e.g. 20 or 40 channels) are not multiples of the usual 32 groups, so
    the group count is ``gcd(channels, max_groups)`` (1 group = LayerNorm over channels and time).
    """
    if channels < 1:
        raise ValueError(f"channels must be >= 1, got {channels}")
    if max_groups < 1:
        raise ValueError(f"max_groups must be >= 1, got {max_groups}")
    return nn.GroupNorm(math.gcd(channels, max_groups), channels, eps=eps)


def _check_odd_kernel(kernel_size: int) -> None:
    if kernel_size < 1 or kernel_size % 2 == 0:
        raise ValueError(
            f"kernel_size must be a positive odd integer (length-preserving padding), got {kernel_size}"
        )


class ResBlock1d(nn.Module):
    """Pre-activation residual block: ``x + conv(act(norm(conv(act(norm(x))))))``.

    The skip path is a 1x1 convolution when the channel count changes. Length-preserving:
    ``(B, C_in, T) -> (B, C_out, T)``.
    """

    def __init__(
        self,
        in_channels: int,
        out_channels: int | None = None,
        kernel_size: int = 5,
        dropout: float = 0.0,
        norm_groups: int = 32,
    ) -> None:
        super().__init__()
        _check_odd_kernel(kernel_size)
        out_channels = out_channels or in_channels
        pad = kernel_size // 2
        self.in_channels = in_channels
        self.out_channels = out_channels
        self.norm1 = group_norm(in_channels, norm_groups)
        self.conv1 = nn.Conv1d(in_channels, out_channels, kernel_size, padding=pad)
        self.norm2 = group_norm(out_channels, norm_groups)
        self.dropout = nn.Dropout(dropout)
        self.conv2 = nn.Conv1d(out_channels, out_channels, kernel_size, padding=pad)
        self.skip: nn.Module = (
            nn.Conv1d(in_channels, out_channels, 1) if in_channels != out_channels else nn.Identity()
        )

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        h = self.conv1(F.silu(self.norm1(x)))
        h = self.conv2(self.dropout(F.silu(self.norm2(h))))
        return self.skip(x) + h


PADDING_MODES = ("zeros", "replicate", "reflect")


def set_padding_mode(module: nn.Module, mode: str) -> nn.Module:
    """Make every padded ``Conv1d`` inside ``module`` pad with ``mode`` (``zeros``/``replicate``/``reflect``).

    Zero padding (the latent-diffusion default) makes a sequence's first and last frames see a fake
    silence; ``replicate`` continues the edge frame instead. Weights and state-dict keys are unchanged.
    """
    if mode not in PADDING_MODES:
        raise ValueError(f"padding_mode: expected one of {PADDING_MODES}, got {mode!r}")
    for conv in module.modules():
        if isinstance(conv, nn.Conv1d) and any(int(p) > 0 for p in conv.padding):  # type: ignore[union-attr]
            conv.padding_mode = mode  # type: ignore[assignment]  # checked above
    return module


class Downsample1d(nn.Module):
    """Strided Conv1d downsampling (MoMu App. A.1: "downsampled by a Conv1d downsampling layer").

    ``(B, C, T) -> (B, C, ceil(T / factor))``; exactly ``T / factor`` when ``factor`` divides
    ``T`` (the VAEs pad inputs to a multiple of their total factor).
    """

    def __init__(self, channels: int, factor: int = 2, kernel_size: int = 5) -> None:
        super().__init__()
        _check_odd_kernel(kernel_size)
        if factor < 1:
            raise ValueError(f"downsampling factor must be >= 1, got {factor}")
        self.factor = factor
        self.conv = nn.Conv1d(channels, channels, kernel_size, stride=factor, padding=kernel_size // 2)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return self.conv(x)


class Upsample1d(nn.Module):
    """Nearest-neighbour upsampling followed by a Conv1d (MoMu App. A.1 "Conv1d upsampling layer").

    ``(B, C, T) -> (B, C, T * factor)``.
    """

    def __init__(self, channels: int, factor: int = 2, kernel_size: int = 5) -> None:
        super().__init__()
        _check_odd_kernel(kernel_size)
        if factor < 1:
            raise ValueError(f"upsampling factor must be >= 1, got {factor}")
        self.factor = factor
        self.conv = nn.Conv1d(channels, channels, kernel_size, padding=kernel_size // 2)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        if self.factor > 1:
            x = F.interpolate(x, scale_factor=float(self.factor), mode="nearest")
        return self.conv(x)


class SelfAttention(nn.Module):
    """Multi-head self-attention over ``(B, T, C)`` using :func:`momu.attention.scaled_dot_product_attention`.

    ``mask``: optional ``(B, T)`` bool, True = valid frame; padded keys are never attended to.
    """

    def __init__(self, channels: int, heads: int = 4) -> None:
        super().__init__()
        if heads < 1 or channels % heads != 0:
            raise ValueError(f"attention heads ({heads}) must divide the channel count ({channels})")
        self.heads = heads
        self.qkv = nn.Linear(channels, 3 * channels)
        self.out = nn.Linear(channels, channels)

    def forward(self, x: torch.Tensor, mask: torch.Tensor | None = None) -> torch.Tensor:
        q, k, v = rearrange(self.qkv(x), "b t (three h d) -> three b h t d", three=3, h=self.heads)
        attn_mask = None if mask is None else mask[:, None, None, :].to(torch.bool)  # (B, 1, 1, T_k)
        y = scaled_dot_product_attention(q, k, v, attn_mask=attn_mask)
        return self.out(rearrange(y, "b h t d -> b t (h d)"))


class TransformerLayer(nn.Module):
    """Pre-LayerNorm transformer layer: self-attention then a GELU feed-forward, both residual."""

    def __init__(self, channels: int, heads: int = 4, ff_mult: int = 4, dropout: float = 0.0) -> None:
        super().__init__()
        self.norm1 = nn.LayerNorm(channels)
        self.attn = SelfAttention(channels, heads)
        self.norm2 = nn.LayerNorm(channels)
        self.ff = nn.Sequential(
            nn.Linear(channels, ff_mult * channels),
            nn.GELU(),
            nn.Dropout(dropout),
            nn.Linear(ff_mult * channels, channels),
        )

    def forward(self, x: torch.Tensor, mask: torch.Tensor | None = None) -> torch.Tensor:
        x = x + self.attn(self.norm1(x), mask)
        return x + self.ff(self.norm2(x))


class SpatialTransformer1d(nn.Module):
    """The "spatial transformer" of MoMu App. A.1 / Table 8 ("spatial attention layers"), in 1D.

    As in latent-diffusion autoencoders: GroupNorm, a 1x1 projection in, ``depth`` transformer
    layers over time, a zero-initialised 1x1 projection out, and a residual connection, so the
    block starts as the identity. ``(B, C, T) -> (B, C, T)``.
    """

    def __init__(
        self,
        channels: int,
        depth: int = 3,
        heads: int = 4,
        ff_mult: int = 4,
        dropout: float = 0.0,
        norm_groups: int = 32,
    ) -> None:
        super().__init__()
        if depth < 1:
            raise ValueError(f"transformer depth must be >= 1, got {depth}")
        self.norm = group_norm(channels, norm_groups)
        self.proj_in = nn.Conv1d(channels, channels, 1)
        self.layers = nn.ModuleList(TransformerLayer(channels, heads, ff_mult, dropout) for _ in range(depth))
        self.proj_out = nn.Conv1d(channels, channels, 1)
        nn.init.zeros_(self.proj_out.weight)
        assert self.proj_out.bias is not None
        nn.init.zeros_(self.proj_out.bias)

    def forward(self, x: torch.Tensor, mask: torch.Tensor | None = None) -> torch.Tensor:
        h = rearrange(self.proj_in(self.norm(x)), "b c t -> b t c")
        for layer in self.layers:
            h = layer(h, mask)
        return x + self.proj_out(rearrange(h, "b t c -> b c t"))


class MiddleBlock1d(nn.Module):
    """Residual block, spatial transformer (``attention_layers`` layers), residual block.

    ``attention_layers = 0`` drops the transformer (a purely convolutional middle block).
    ``(B, C, T) -> (B, C, T)``.
    """

    def __init__(
        self,
        channels: int,
        kernel_size: int = 5,
        attention_layers: int = 3,
        heads: int = 4,
        dropout: float = 0.0,
        norm_groups: int = 32,
    ) -> None:
        super().__init__()
        if attention_layers < 0:
            raise ValueError(f"attention_layers must be >= 0, got {attention_layers}")
        self.res1 = ResBlock1d(channels, channels, kernel_size, dropout, norm_groups)
        self.attn: nn.Module | None = (
            SpatialTransformer1d(channels, attention_layers, heads, dropout=dropout, norm_groups=norm_groups)
            if attention_layers > 0
            else None
        )
        self.res2 = ResBlock1d(channels, channels, kernel_size, dropout, norm_groups)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        x = self.res1(x)
        if self.attn is not None:
            x = self.attn(x)
        return self.res2(x)
