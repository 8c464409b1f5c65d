"""Building blocks shared by the denoising backbones: timestep embeddings, masked attention,
transformer blocks, masked group normalisation and the backbone-call argument checks.

Sequences are channels-last ``(B, T, C)`` unless a docstring says otherwise. Masks are boolean
with ``True`` = valid frame. Attention goes through :func:`momu.attention.scaled_dot_product_attention`
(PyTorch's SDPA) with a boolean ``(B, 1, 1, Lk)`` key mask, so padded keys receive exactly zero
weight and a padded frame can never change a valid one; a caller that knows every key is valid
passes no mask, which lets SDPA pick its flash kernel on a GPU (docs/performance.md).
"""

from __future__ import annotations

import math

import torch
from diffusers.models.embeddings import get_timestep_embedding
from torch import Tensor, nn

from momu.attention import scaled_dot_product_attention

__all__ = [
    "TimestepEmbedder",
    "sinusoidal_embedding",
    "Attention",
    "FeedForward",
    "TransformerBlock",
    "MaskedGroupNorm",
    "lengths_from_mask",
    "check_prefix_mask",
    "check_backbone_inputs",
]


def sinusoidal_embedding(t: Tensor, dim: int, max_period: float = 10000.0) -> Tensor:
    """Transformer sinusoidal embedding of diffusion timesteps or positions (DDPM/MoFusion §3.3).

    Args:
        t: ``(B,)`` timesteps or positions (integer or float).
        dim: embedding width.
        max_period: the longest wavelength.

    Returns:
        ``(B, dim)`` float32 embedding ``[cos(t·ω_k), sin(t·ω_k)]`` (diffusers' convention with
        ``flip_sin_to_cos=True``).
    """
    if t.ndim != 1:
        raise ValueError(f"t: expected shape (B,), got {tuple(t.shape)}")
    return get_timestep_embedding(
        t, dim, flip_sin_to_cos=True, downscale_freq_shift=0, max_period=int(max_period)
    )


class TimestepEmbedder(nn.Module):
    """Sinusoidal time embedding through a two-layer MLP (MoFusion §3.3; DiT ``t`` token, MoMu §4).

    ``(B,)`` timesteps -> ``(B, out_dim)``.
    """

    def __init__(self, out_dim: int, freq_dim: int = 256, hidden_dim: int | None = None) -> None:
        super().__init__()
        self.freq_dim = freq_dim
        hidden_dim = hidden_dim or out_dim
        self.mlp = nn.Sequential(nn.Linear(freq_dim, hidden_dim), nn.SiLU(), nn.Linear(hidden_dim, out_dim))

    def forward(self, t: Tensor) -> Tensor:
        first = self.mlp[0]
        assert isinstance(first, nn.Linear)
        emb = sinusoidal_embedding(t, self.freq_dim).to(first.weight.dtype)
        return self.mlp(emb)


class Attention(nn.Module):
    """Multi-head (self- or cross-) attention, MoFusion Eq. 8–9: ``Q = W_q x``, ``K = W_k c``, ``V = W_v c``,
    ``softmax(QKᵀ/√d) V``.

    Args:
        dim: query (and output) width.
        heads: number of heads; ``dim`` must be divisible by it.
        context_dim: key/value input width (``None``: ``dim``, self-attention).
        dropout: attention-probability dropout (training only).
    """

    def __init__(self, dim: int, heads: int, context_dim: int | None = None, dropout: float = 0.0) -> None:
        super().__init__()
        if dim % heads:
            raise ValueError(f"attention width {dim} is not divisible by heads={heads}")
        self.heads = heads
        self.dropout = dropout
        context_dim = context_dim or dim
        self.to_q = nn.Linear(dim, dim)
        self.to_k = nn.Linear(context_dim, dim)
        self.to_v = nn.Linear(context_dim, dim)
        self.to_out = nn.Linear(dim, dim)
        self.recorder: list[Tensor] | None = None  # set by an attention recorder (MoFusion Fig. 4)

    def forward(self, x: Tensor, context: Tensor | None = None, key_mask: Tensor | None = None) -> Tensor:
        """``x (B, Lq, dim)``, ``context (B, Lk, context_dim)`` (default ``x``), ``key_mask (B, Lk)`` bool.

        Every query must see at least one valid key (the callers guarantee it).
        """
        context = x if context is None else context
        b, lq, _ = x.shape
        lk = context.shape[1]
        # (B, L, H*D) -> (B, H, L, D)
        q = self.to_q(x).view(b, lq, self.heads, -1).transpose(1, 2)
        k = self.to_k(context).view(b, lk, self.heads, -1).transpose(1, 2)
        v = self.to_v(context).view(b, lk, self.heads, -1).transpose(1, 2)
        attn_mask = None if key_mask is None else key_mask[:, None, None, :]  # (B, 1, 1, Lk)
        if self.recorder is not None:  # explicit softmax(QKᵀ/√d) (Eq. 9) so the weights can be kept
            scores = q @ k.transpose(-1, -2) / math.sqrt(q.shape[-1])  # (B, H, Lq, Lk)
            if attn_mask is not None:
                scores = scores.masked_fill(~attn_mask, float("-inf"))
            weights = scores.softmax(dim=-1)
            self.recorder.append(weights.detach())
            out = weights @ v
        else:
            out = scaled_dot_product_attention(
                q, k, v, attn_mask=attn_mask, dropout_p=self.dropout if self.training else 0.0
            )
        return self.to_out(out.transpose(1, 2).reshape(b, lq, -1))


class FeedForward(nn.Sequential):
    """Position-wise two-layer MLP with GELU (width ``dim·mult``)."""

    def __init__(self, dim: int, mult: float = 4.0, dropout: float = 0.0) -> None:
        inner = int(dim * mult)
        super().__init__(nn.Linear(dim, inner), nn.GELU(), nn.Dropout(dropout), nn.Linear(inner, dim))


class TransformerBlock(nn.Module):
    """Pre-norm transformer block: attention + feed-forward, each residual.

    With ``context_dim`` set the attention is *cross-modal* (queries from the sequence,
    keys/values from the context; MoFusion Fig. 3). Without ``context_dim`` it is
    self-attention: the DiT/FFT block of MoMu §4, and the block of an unconditional U-Net
    (MoFusion §3.3: "the formulation switches to self-attention"). A conditional model's
    unconditional pass uses the learned null context instead (classifier-free guidance).
    """

    def __init__(
        self,
        dim: int,
        heads: int,
        context_dim: int | None = None,
        mlp_ratio: float = 4.0,
        dropout: float = 0.0,
    ) -> None:
        super().__init__()
        self.norm1 = nn.LayerNorm(dim)
        self.context_dim = context_dim
        self.attn = Attention(dim, heads, context_dim=context_dim, dropout=dropout)
        self.norm2 = nn.LayerNorm(dim)
        self.ff = FeedForward(dim, mlp_ratio, dropout)

    def forward(
        self,
        x: Tensor,
        mask: Tensor | None = None,
        context: Tensor | None = None,
        context_mask: Tensor | None = None,
        query_pos: Tensor | None = None,
        context_pos: Tensor | None = None,
    ) -> Tensor:
        """``x (B, L, dim)`` with key mask ``mask (B, L)``; optional ``context (B, Lc, context_dim)``.

        ``query_pos`` (``(B, L, dim)``) and ``context_pos`` (``(B, Lc, context_dim)``) are positional
        encodings added to the attention inputs only (not to the residual stream).
        """
        h = self.norm1(x)
        if query_pos is not None:
            h = h + query_pos
        if self.context_dim is not None:
            if context is None:
                raise ValueError("context: this cross-modal block needs a context (use the null condition)")
            if context_pos is not None:
                context = context + context_pos
            x = x + self.attn(h, context, context_mask)
        else:
            if context is not None:
                raise ValueError("context: this block is self-attention only (context_dim=None)")
            x = x + self.attn(h, None, mask)
        return x + self.ff(self.norm2(x))


class MaskedGroupNorm(nn.GroupNorm):
    """GroupNorm over channels-first ``(B, C, T)`` whose statistics use valid frames only.

    With ``mask=None`` it is exactly :class:`torch.nn.GroupNorm`. With a mask, padded frames
    contribute nothing to the mean/variance, so the valid output does not depend on padding.
    """

    def forward(self, x: Tensor, mask: Tensor | None = None) -> Tensor:  # type: ignore[override]
        if mask is None:
            return super().forward(x)
        b, c, t = x.shape
        g = self.num_groups
        m = mask.to(x.dtype)[:, None, None, :]  # (B, 1, 1, T)
        xg = x.view(b, g, c // g, t)
        count = (m.sum(dim=(2, 3), keepdim=True) * (c // g)).clamp_min(1.0)
        mean = (xg * m).sum(dim=(2, 3), keepdim=True) / count
        var = (((xg - mean) * m) ** 2).sum(dim=(2, 3), keepdim=True) / count
        y = ((xg - mean) / torch.sqrt(var + self.eps)).view(b, c, t)
        if self.affine:
            y = y * self.weight[None, :, None] + self.bias[None, :, None]
        return y * mask.to(x.dtype)[:, None, :]


def lengths_from_mask(mask: Tensor) -> Tensor:
    """``(B,)`` number of valid frames of a ``(B, T)`` boolean mask."""
    return mask.sum(dim=1)


def check_prefix_mask(mask: Tensor, name: str) -> Tensor:
    """Check that ``mask`` (B, T) is boolean, valid frames first then padding; returns the lengths.

    Inside a :func:`torch.compile` graph (``train.compile``) only dtype and shape are checked: the
    value checks read the mask back from the device and would split the graph.

    Raises:
        ValueError: naming ``name`` when the mask is not boolean, has an empty row, or has a
            valid frame after a padded one.
    """
    if mask.dtype != torch.bool or mask.ndim != 2:
        raise ValueError(
            f"{name}: expected a (B, T) bool mask (True = valid), got {mask.dtype} {tuple(mask.shape)}"
        )
    lengths = lengths_from_mask(mask)
    if torch.compiler.is_compiling():  # value checks read the device: skipped in compiled graphs
        return lengths
    if bool((lengths == 0).any()):
        raise ValueError(f"{name}: every item needs at least one valid frame")
    expected = torch.arange(mask.shape[1], device=mask.device)[None, :] < lengths[:, None]
    if not torch.equal(expected, mask):
        raise ValueError(f"{name}: valid frames must come first and padding last (a prefix mask)")
    return lengths


def check_backbone_inputs(
    x: Tensor,
    t: Tensor,
    cond: Tensor | None,
    x_mask: Tensor | None,
    cond_mask: Tensor | None,
    drop_cond: Tensor | None,
    in_channels: int,
    cond_channels: int,
) -> None:
    """Validate one call of the backbone protocol (docs/protocols.md); errors name the argument.

    Inside a :func:`torch.compile` graph the finiteness checks are skipped (they synchronise).
    """
    if x.ndim != 3 or x.shape[-1] != in_channels:
        raise ValueError(f"x: expected (B, T, {in_channels}), got {tuple(x.shape)}")
    b, length = x.shape[:2]
    if length == 0:
        raise ValueError("x: empty sequence (T = 0)")
    if t.shape != (b,):
        raise ValueError(f"t: expected shape ({b},), got {tuple(t.shape)}")
    if x_mask is not None and x_mask.shape != (b, length):
        raise ValueError(f"x_mask: expected shape ({b}, {length}), got {tuple(x_mask.shape)}")
    if cond is not None:
        if cond_channels == 0:
            raise ValueError(
                "cond: this backbone is unconditional (cond_channels=0) but a condition was given"
            )
        if cond.ndim != 3 or cond.shape[0] != b or cond.shape[-1] != cond_channels:
            raise ValueError(f"cond: expected ({b}, Tc, {cond_channels}), got {tuple(cond.shape)}")
        if cond.shape[1] == 0:
            raise ValueError("cond: empty condition sequence (Tc = 0)")
        if cond_mask is not None and cond_mask.shape != cond.shape[:2]:
            raise ValueError(
                f"cond_mask: expected shape {tuple(cond.shape[:2])}, got {tuple(cond_mask.shape)}"
            )
    elif cond_mask is not None:
        raise ValueError("cond_mask given without cond")
    if drop_cond is not None and (drop_cond.shape != (b,) or drop_cond.dtype != torch.bool):
        raise ValueError(
            f"drop_cond: expected a ({b},) bool tensor, got {drop_cond.dtype} {tuple(drop_cond.shape)}"
        )
    if torch.compiler.is_compiling():  # the value checks below would break the graph
        return
    if not torch.is_floating_point(x) or not bool(torch.isfinite(x).all()):
        raise ValueError("x: must be a finite floating-point tensor")
    if cond is not None and not bool(torch.isfinite(cond).all()):
        raise ValueError("cond: contains NaN or infinite values")


def _init_linear(module: nn.Module) -> None:
    """Xavier-uniform weights, zero biases for every Linear inside ``module``."""
    for m in module.modules():
        if isinstance(m, nn.Linear):
            nn.init.xavier_uniform_(m.weight)
            if m.bias is not None:
                nn.init.zeros_(m.bias)


def scaled_init_std(dim: int) -> float:
    """``1/√dim``: the std used for learned embeddings (positions, null condition)."""
    return 1.0 / math.sqrt(dim)


def condition_tokens(
    embed: nn.Module,
    null: nn.Parameter,
    batch: int,
    cond: Tensor | None,
    cond_mask: Tensor | None,
    drop_cond: Tensor | None,
    ref: Tensor,
) -> tuple[Tensor, Tensor]:
    """Embedded condition tokens ``(B, Lc, H)`` and their mask ``(B, Lc)`` (MoMu Eq. 7's ∅).

    Without a condition every item sees one learned null token; items flagged in ``drop_cond``
    (classifier-free-guidance dropout) see the same null token in place of their condition, so
    a dropped condition and no condition give identical outputs.
    """
    null_token = null.to(ref.dtype)
    if cond is None:
        return null_token.expand(batch, 1, -1), torch.ones(batch, 1, dtype=torch.bool, device=ref.device)
    tokens = embed(cond.to(ref.dtype))
    mask = (
        cond_mask
        if cond_mask is not None
        else torch.ones(cond.shape[:2], dtype=torch.bool, device=ref.device)
    )
    if drop_cond is not None:  # no `drop_cond.any()` test: that would wait for the device
        first = torch.zeros_like(mask)
        first[:, 0] = True
        drop = drop_cond[:, None]
        tokens = torch.where(drop[..., None] & first[..., None], null_token, tokens)
        mask = torch.where(drop, first, mask)
    return tokens, mask
