"""MoFusion's one trainable stage: the ε-backbone (and a from-scratch text encoder) under Eq. 4."""

from __future__ import annotations

from typing import Any

import torch
from torch import Tensor, nn

from momu.engine.every_parameter import with_every_parameter
from momu.losses.scheduled_kinematic import ScheduledKinematicLoss
from momu.methods.momu.stages import stage_step

__all__ = ["MoFusionStage", "encode_text", "stage_step"]


def encode_text(encoder: Any, texts: list[str], device: torch.device) -> tuple[Tensor, Tensor]:
    """Token outputs ``(B, L, width)`` and mask ``(B, L)`` of captions (no grad through a frozen encoder)."""
    ids, mask = encoder.tokenize(texts)
    ids, mask = ids.to(device), mask.to(device)
    if any(p.requires_grad for p in encoder.parameters()):
        return encoder(ids, mask), mask
    with torch.no_grad():
        return encoder(ids, mask), mask


class MoFusionStage(nn.Module):
    """Backbone + loss (+ text encoder): ``forward(batch) -> (L_t, logs)`` for the shared engine."""

    def __init__(
        self, backbone: nn.Module, loss: ScheduledKinematicLoss, text_encoder: nn.Module | None
    ) -> None:
        super().__init__()
        self.backbone = backbone
        self.loss = loss
        self.text_encoder = text_encoder

    def forward(self, batch: dict[str, Any]) -> tuple[Tensor, dict[str, Tensor]]:
        x = batch["x"]
        cond_mask: Tensor | None
        if self.text_encoder is not None:
            cond, cond_mask = encode_text(self.text_encoder, list(batch["text"]), x.device)
        else:
            cond, cond_mask = batch["cond"], batch.get("cond_mask")
        total, logs = self.loss(self.backbone, x, cond, x_mask=batch.get("x_mask"), cond_mask=cond_mask)
        return with_every_parameter(self, total), logs
