"""Scaled dot-product attention for every momu part, with momu's mixed-precision rule for the CPU.

Every attention layer (the denoisers' :class:`~momu.backbones.blocks.Attention`, the DSTformer and
the encoders' self-attention) calls :func:`scaled_dot_product_attention`, which is PyTorch's
:func:`torch.nn.functional.scaled_dot_product_attention` except in one case: **on the CPU under a
bf16 or fp16 autocast, the attention itself runs in fp32.** PyTorch's CPU flash-attention backward
in bf16 is several times slower than in fp32, so bf16 autocast gained nothing on a MoMu cpu-preset
diffusion step; with the attention in fp32 and every other matmul in bf16 a full 4-s step takes
about 0.6× the fp32 time, though the table's shorter variable-length steps gain almost nothing
(``python benchmarks/bench_momu_training_flops.py --bf16``; numbers in docs/performance.md).
Softmax in fp32 is also what autocast itself does on a GPU's math path. On a GPU nothing changes:
there the lower-precision kernels are the fast ones.
"""

from __future__ import annotations

import torch
import torch.nn.functional as F
from torch import Tensor

__all__ = ["scaled_dot_product_attention"]


def scaled_dot_product_attention(
    q: Tensor, k: Tensor, v: Tensor, attn_mask: Tensor | None = None, dropout_p: float = 0.0
) -> Tensor:
    """``softmax(q kᵀ / √d + mask) v`` over ``(B, H, L, D)`` tensors; boolean ``attn_mask`` (True = attend).

    Returns ``q``'s dtype. Under a lower-precision CPU autocast the inputs are upcast and the kernel
    runs with autocast off (see the module docstring).
    """
    if q.device.type == "cpu" and torch.is_autocast_enabled("cpu"):
        with torch.autocast("cpu", enabled=False):
            out = F.scaled_dot_product_attention(
                q.float(), k.float(), v.float(), attn_mask=attn_mask, dropout_p=dropout_p
            )
        return out.to(q.dtype)
    return F.scaled_dot_product_attention(q, k, v, attn_mask=attn_mask, dropout_p=dropout_p)
