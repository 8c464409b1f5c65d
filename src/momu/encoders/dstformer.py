"""DSTformer: a compact dual-stream spatio-temporal transformer over joint sequences.

MoMu-Diffusion uses a MotionBERT encoder (Zhu et al., ICCV 2023, ref. [51] of the MoMu paper)
twice: as the motion classifier behind its motion FID / Mean KLD / Diversity (MoMu App. B.5)
and as the learnable motion encoder that conditions motion→music generation on the noisy
Floor Exercise and Figure Skating keypoints (MoMu §5.1, Tables 3–4). This module is that one
network, shared by :mod:`momu.metrics.extractors` and :mod:`momu.encoders.learnable_motion`.

Architecture (MotionBERT §3.2, "DSTformer"), for a motion ``x`` of shape ``(B, T, J, D)``:

1. joint embedding ``Linear(D, C)`` plus a learned spatial (per-joint) embedding ``(J, C)`` and
   a fixed sinusoidal temporal embedding over frames (MotionBERT learns a temporal table of
   243 frames; the sinusoid lets any clip length through — documented deviation);
2. ``depth`` dual-stream layers. Each layer runs two branches on the same input:
   ``ST`` = spatial block (attention across the J joints of one frame) then temporal block
   (attention across the T frames of one joint), and ``TS`` = temporal then spatial.
   The branches are fused by an adaptive per-token weight
   ``α = softmax(Linear([x_ST, x_TS]))``: ``x = α₀·x_ST + α₁·x_TS`` (initialised to ½, ½ as in
   MotionBERT);
3. LayerNorm and a ``Linear(C, dim_rep)`` + ``tanh`` "pre-logits" representation.

Output: ``(B, T, J, dim_rep)``. Attention is :func:`momu.attention.scaled_dot_product_attention`
(PyTorch's SDPA).

Padding: an optional ``mask (B, T)`` (True = valid frame) is applied as a key mask in every
temporal attention, and the spatial attention never mixes frames, so the output on the valid
frames does not depend on how many padded frames follow or what they contain (tested).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import torch
from torch import nn

from momu.attention import scaled_dot_product_attention

__all__ = ["DSTformerConfig", "DSTformer", "sinusoidal_embedding"]


@dataclass
class DSTformerConfig:
    """Hyperparameters of :class:`DSTformer`.

    MotionBERT's own sizes are ``dim_feat=512, dim_rep=512, depth=5, num_heads=8, mlp_ratio=2``;
    the defaults here are a compact version that trains in seconds on a CPU.

    Attributes:
        num_joints: J, joints per frame (14 for ``openpose14`` …).
        dim_in: D, coordinates per joint (2 for image keypoints, 3 for 3D positions).
        dim_feat: C, the width of every attention block.
        dim_rep: width of the output representation.
        depth: number of dual-stream (ST + TS) layers.
        num_heads: attention heads (must divide ``dim_feat``).
        mlp_ratio: hidden width of each block's MLP, in multiples of ``dim_feat``.
        dropout: dropout on attention weights and MLP activations (training only).
    """

    num_joints: int = 14
    dim_in: int = 2
    dim_feat: int = 64
    dim_rep: int = 64
    depth: int = 2
    num_heads: int = 4
    mlp_ratio: float = 2.0
    dropout: float = 0.0

    def __post_init__(self) -> None:
        for name in ("num_joints", "dim_in", "dim_feat", "dim_rep", "depth", "num_heads"):
            value = getattr(self, name)
            if not isinstance(value, int) or value < 1:
                raise ValueError(f"DSTformerConfig.{name} must be a positive integer, got {value!r}")
        if self.dim_feat % self.num_heads:
            raise ValueError(
                f"DSTformerConfig.dim_feat ({self.dim_feat}) must be divisible by "
                f"num_heads ({self.num_heads})"
            )
        if self.mlp_ratio <= 0:
            raise ValueError(f"DSTformerConfig.mlp_ratio must be > 0, got {self.mlp_ratio}")
        if not 0.0 <= self.dropout < 1.0:
            raise ValueError(f"DSTformerConfig.dropout must be in [0, 1), got {self.dropout}")


def sinusoidal_embedding(length: int, dim: int, *, device: torch.device | None = None) -> torch.Tensor:
    """Transformer sinusoidal position table ``(length, dim)`` (Vaswani et al. 2017).

    Row ``t`` holds ``sin(t / 10000^(2i/dim))`` in even columns and ``cos(…)`` in odd ones.
    """
    position = torch.arange(length, dtype=torch.float32, device=device)[:, None]
    div = torch.exp(torch.arange(0, dim, 2, dtype=torch.float32, device=device) * (-math.log(10000.0) / dim))
    table = torch.zeros(length, dim, device=device)
    table[:, 0::2] = torch.sin(position * div)
    table[:, 1::2] = torch.cos(position * div)[:, : dim // 2]
    return table


class _Attention(nn.Module):
    """Multi-head self-attention over the second-to-last axis of ``(N, L, C)``."""

    def __init__(self, dim: int, num_heads: int, dropout: float) -> None:
        super().__init__()
        self.num_heads = num_heads
        self.qkv = nn.Linear(dim, dim * 3)
        self.proj = nn.Linear(dim, dim)
        self.dropout = dropout

    def forward(self, x: torch.Tensor, key_mask: torch.Tensor | None = None) -> torch.Tensor:
        n, length, dim = x.shape
        qkv = self.qkv(x).reshape(n, length, 3, self.num_heads, dim // self.num_heads)
        q, k, v = qkv.permute(2, 0, 3, 1, 4)  # each (N, heads, L, C/heads)
        attn_mask = None if key_mask is None else key_mask[:, None, None, :]  # (N, 1, 1, L)
        out = scaled_dot_product_attention(
            q, k, v, attn_mask=attn_mask, dropout_p=self.dropout if self.training else 0.0
        )
        return self.proj(out.transpose(1, 2).reshape(n, length, dim))


class _Block(nn.Module):
    """Pre-norm transformer block attending across joints (``spatial``) or frames (``temporal``)."""

    def __init__(self, cfg: DSTformerConfig, mode: str) -> None:
        super().__init__()
        if mode not in ("spatial", "temporal"):
            raise ValueError(f"block mode must be 'spatial' or 'temporal', got {mode!r}")
        self.mode = mode
        dim = cfg.dim_feat
        hidden = max(1, int(round(dim * cfg.mlp_ratio)))
        self.norm1 = nn.LayerNorm(dim)
        self.attn = _Attention(dim, cfg.num_heads, cfg.dropout)
        self.norm2 = nn.LayerNorm(dim)
        self.mlp = nn.Sequential(
            nn.Linear(dim, hidden), nn.GELU(), nn.Dropout(cfg.dropout), nn.Linear(hidden, dim)
        )

    def _attend(self, x: torch.Tensor, mask: torch.Tensor | None) -> torch.Tensor:
        b, t, j, c = x.shape
        if self.mode == "spatial":
            out = self.attn(x.reshape(b * t, j, c))  # (B*T, J, C): joints of one frame
            return out.reshape(b, t, j, c)
        seq = x.permute(0, 2, 1, 3).reshape(b * j, t, c)  # (B*J, T, C): frames of one joint
        key_mask = None if mask is None else mask.repeat_interleave(j, dim=0)  # (B*J, T)
        out = self.attn(seq, key_mask)
        return out.reshape(b, j, t, c).permute(0, 2, 1, 3)

    def forward(self, x: torch.Tensor, mask: torch.Tensor | None) -> torch.Tensor:
        x = x + self._attend(self.norm1(x), mask)
        return x + self.mlp(self.norm2(x))


class _DualStreamLayer(nn.Module):
    """One DSTformer layer: ST and TS branches fused by adaptive weights (MotionBERT Eq. 5)."""

    def __init__(self, cfg: DSTformerConfig) -> None:
        super().__init__()
        self.st_spatial = _Block(cfg, "spatial")
        self.st_temporal = _Block(cfg, "temporal")
        self.ts_temporal = _Block(cfg, "temporal")
        self.ts_spatial = _Block(cfg, "spatial")
        self.fusion = nn.Linear(2 * cfg.dim_feat, 2)
        nn.init.zeros_(self.fusion.weight)  # MotionBERT: equal stream weights at initialisation
        nn.init.constant_(self.fusion.bias, 0.5)

    def forward(self, h: torch.Tensor, mask: torch.Tensor | None) -> torch.Tensor:
        x_st = self.st_temporal(self.st_spatial(h, mask), mask)
        x_ts = self.ts_spatial(self.ts_temporal(h, mask), mask)
        alpha = self.fusion(torch.cat([x_st, x_ts], dim=-1)).softmax(dim=-1)  # (B, T, J, 2)
        return x_st * alpha[..., 0:1] + x_ts * alpha[..., 1:2]


class DSTformer(nn.Module):
    """Dual-stream spatio-temporal transformer ``(B, T, J, D) -> (B, T, J, dim_rep)``.

    See the module docstring for the architecture and the padding guarantee.
    """

    def __init__(self, cfg: DSTformerConfig | None = None) -> None:
        super().__init__()
        self.cfg = cfg = cfg or DSTformerConfig()
        self.joints_embed = nn.Linear(cfg.dim_in, cfg.dim_feat)
        self.pos_embed = nn.Parameter(torch.zeros(1, 1, cfg.num_joints, cfg.dim_feat))
        nn.init.trunc_normal_(self.pos_embed, std=0.02)
        self.layers = nn.ModuleList(_DualStreamLayer(cfg) for _ in range(cfg.depth))
        self.norm = nn.LayerNorm(cfg.dim_feat)
        self.pre_logits = nn.Sequential(nn.Linear(cfg.dim_feat, cfg.dim_rep), nn.Tanh())

    @property
    def out_channels(self) -> int:
        """Width of the representation (``dim_rep``)."""
        return self.cfg.dim_rep

    def check_input(self, x: torch.Tensor, mask: torch.Tensor | None = None) -> None:
        """Raise ``ValueError`` naming the argument when ``x``/``mask`` do not fit this network."""
        cfg = self.cfg
        if x.ndim != 4 or x.shape[2] != cfg.num_joints or x.shape[3] != cfg.dim_in:
            raise ValueError(
                f"motion must have shape (B, T, {cfg.num_joints}, {cfg.dim_in}) "
                f"(batch, frames, joints, coords), got {tuple(x.shape)}"
            )
        if x.shape[1] < 1:
            raise ValueError("motion has no frames (T = 0)")
        if mask is not None:
            if mask.shape != x.shape[:2] or mask.dtype != torch.bool:
                raise ValueError(
                    f"mask must be a bool tensor of shape (B, T) = {tuple(x.shape[:2])}, "
                    f"got {mask.dtype} {tuple(mask.shape)}"
                )
            if not bool(mask.any(dim=1).all()):
                raise ValueError("mask: every sequence needs at least one valid (True) frame")

    def forward(self, x: torch.Tensor, mask: torch.Tensor | None = None) -> torch.Tensor:
        """Encode ``x (B, T, J, D)`` (``mask (B, T)`` bool, True = valid) to ``(B, T, J, dim_rep)``."""
        self.check_input(x, mask)
        _, t, _, _ = x.shape
        h = self.joints_embed(x) + self.pos_embed
        h = h + sinusoidal_embedding(t, self.cfg.dim_feat, device=x.device).to(h.dtype)[None, :, None, :]
        for layer in self.layers:
            h = layer(h, mask)
        return self.pre_logits(self.norm(h))
