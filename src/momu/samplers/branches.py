"""The unconditional branch of classifier-free guidance as its own forward (an exact fast path).

:func:`momu.samplers.base.guided_eps` runs MoMu Eq. 7's two branches as one batch of ``2B`` with
``drop_cond = [False]*B + [True]*B``. A backbone that turns the condition into tokens (the DiT: one
token per condition frame, a dropped condition is ONE null token) then pads every dropped item to the
condition's length: for a 62-frame window the unconditional half carries 125 tokens, 61 of them
padding that attention masks out. :class:`SeparateNullBranch` wraps such a backbone and runs the
dropped items as a second forward with ``cond=None``; the backbone protocol (docs/protocols.md,
rule 2: a dropped condition *is* the null condition) makes the result the same up to floating-point
summation order. Two forwards instead of one only pay off when a batch is large, so the long-sequence
stitching (:mod:`momu.generation.stitching`) uses it for its batched windows.
"""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import torch
from torch import Tensor

__all__ = ["SeparateNullBranch"]


class SeparateNullBranch:
    """A backbone (protocol of docs/protocols.md) whose dropped-condition items run as ``cond=None``.

    Attributes ``in_channels``, ``cond_channels`` and ``max_length`` and :meth:`parameters` are the
    wrapped backbone's, so samplers treat the wrapper as the backbone itself.
    """

    def __init__(self, backbone: Any) -> None:
        self.backbone = backbone
        self.in_channels: int = backbone.in_channels
        self.cond_channels: int = backbone.cond_channels
        self.max_length: int | None = getattr(backbone, "max_length", None)

    def parameters(self) -> Iterator[torch.nn.Parameter]:
        return iter(self.backbone.parameters())

    def __call__(
        self,
        x: Tensor,
        t: Tensor,
        cond: Tensor | None = None,
        *,
        x_mask: Tensor | None = None,
        cond_mask: Tensor | None = None,
        drop_cond: Tensor | None = None,
    ) -> Tensor:
        """The backbone's output; items with ``drop_cond`` True come from a forward without ``cond``."""
        if cond is None or drop_cond is None:
            return self.backbone(x, t, cond, x_mask=x_mask, cond_mask=cond_mask, drop_cond=drop_cond)
        drop = drop_cond.detach().to("cpu", torch.bool)
        if drop.shape != (x.shape[0],):
            raise ValueError(f"drop_cond: expected shape ({x.shape[0]},), got {tuple(drop.shape)}")
        if bool(drop.all()) or not bool(drop.any()):
            return self.backbone(x, t, cond, x_mask=x_mask, cond_mask=cond_mask, drop_cond=drop_cond)
        kept, dropped = (~drop).nonzero().flatten().to(x.device), drop.nonzero().flatten().to(x.device)

        def pick(m: Tensor | None, idx: Tensor) -> Tensor | None:
            return None if m is None else m.index_select(0, idx)

        with_cond = self.backbone(
            x.index_select(0, kept),
            t.index_select(0, kept),
            cond.index_select(0, kept),
            x_mask=pick(x_mask, kept),
            cond_mask=pick(cond_mask, kept),
        )
        without = self.backbone(
            x.index_select(0, dropped), t.index_select(0, dropped), None, x_mask=pick(x_mask, dropped)
        )
        out = torch.empty((x.shape[0], *with_cond.shape[1:]), dtype=with_cond.dtype, device=with_cond.device)
        out.index_copy_(0, kept, with_cond)
        out.index_copy_(0, dropped, without)
        return out
