"""A residual-MLP denoiser that follows momu's backbone protocol."""

from __future__ import annotations

import math
from dataclasses import dataclass

import torch
from torch import nn

from momu.registry import BACKBONES


@dataclass
class ResidualMLPConfig:
    in_channels: int = 16
    cond_channels: int = 0
    hidden: int = 128
    depth: int = 3


def timestep_features(t: torch.Tensor, dim: int) -> torch.Tensor:
    """Sinusoidal features of integer diffusion timesteps: (B,) -> (B, dim)."""
    half = dim // 2
    freqs = torch.exp(-math.log(10_000.0) * torch.arange(half, device=t.device, dtype=torch.float32) / half)
    angles = t.float()[:, None] * freqs[None]
    return torch.cat([angles.sin(), angles.cos()], dim=-1)


class ResidualMLP(nn.Module):
    """Per-frame MLP blocks conditioned on the timestep and the masked mean of the condition."""

    def __init__(self, cfg: ResidualMLPConfig) -> None:
        super().__init__()
        self.in_channels = cfg.in_channels
        self.cond_channels = cfg.cond_channels
        self.max_length = None
        self.hidden = cfg.hidden
        self.inp = nn.Linear(cfg.in_channels, cfg.hidden)
        self.time = nn.Sequential(
            nn.Linear(cfg.hidden, cfg.hidden), nn.SiLU(), nn.Linear(cfg.hidden, cfg.hidden)
        )
        self.cond = nn.Linear(cfg.cond_channels, cfg.hidden) if cfg.cond_channels else None
        self.null_cond = nn.Parameter(torch.zeros(cfg.hidden)) if cfg.cond_channels else None
        self.blocks = nn.ModuleList(
            nn.Sequential(
                nn.LayerNorm(cfg.hidden),
                nn.Linear(cfg.hidden, cfg.hidden),
                nn.SiLU(),
                nn.Linear(cfg.hidden, cfg.hidden),
            )
            for _ in range(cfg.depth)
        )
        self.out = nn.Linear(cfg.hidden, cfg.in_channels)

    def forward(
        self,
        x: torch.Tensor,
        t: torch.Tensor,
        cond: torch.Tensor | None = None,
        *,
        x_mask: torch.Tensor | None = None,
        cond_mask: torch.Tensor | None = None,
        drop_cond: torch.Tensor | None = None,
    ) -> torch.Tensor:
        """x: (B, T, C), t: (B,), cond: (B, Tc, Cc) -> (B, T, C); padded frames do not affect valid ones."""
        if x.shape[-1] != self.in_channels:
            raise ValueError(f"x has {x.shape[-1]} channels, this backbone expects {self.in_channels}")
        context = self.time(timestep_features(t, self.hidden))  # (B, H)
        if self.cond is not None and self.null_cond is not None:
            if cond is None:
                pooled = self.null_cond.expand(x.shape[0], -1)
            else:
                weights = (
                    torch.ones(cond.shape[:2], device=cond.device) if cond_mask is None else cond_mask.float()
                )
                mean = (cond * weights[..., None]).sum(1) / weights.sum(1, keepdim=True).clamp_min(1.0)
                pooled = self.cond(mean)
                if drop_cond is not None:
                    pooled = torch.where(drop_cond[:, None], self.null_cond.expand_as(pooled), pooled)
            context = context + pooled
        h = self.inp(x) + context[:, None]
        for block in self.blocks:
            h = h + block(h)
        out = self.out(h)
        return out if x_mask is None else out * x_mask[..., None]


@BACKBONES.register("residual_mlp", config=ResidualMLPConfig)
def build_residual_mlp(cfg: ResidualMLPConfig) -> ResidualMLP:
    return ResidualMLP(cfg)
