"""End to end: the `diffusion` loss trains a `dit` that the `cfg` sampler then follows (MoMu Eq. 6–7).

Toy task with a hand-known answer: the clean sequence is 1.5 × the (white-noise) condition, so
a model that uses its condition generates it almost exactly, while with a shuffled condition the
expected squared error is that of two independent N(0, 2.25) draws, 2 × 2.25 = 4.5.
"""

from __future__ import annotations

import pytest
import torch

from momu.registry import BACKBONES, LOSSES, SAMPLERS


def pairs(n: int, g: torch.Generator) -> tuple[torch.Tensor, torch.Tensor]:
    cond = torch.randn(n, 16, 2, generator=g)
    return 1.5 * cond, cond


def test_trained_dit_follows_its_condition() -> None:
    torch.manual_seed(0)
    params = dict(in_channels=2, cond_channels=2, cond_embed_dim=32, hidden=32, heads=4, depth=2)
    model = BACKBONES.build("dit", {**params, "max_length": 40, "cond_add": True})
    loss_fn = LOSSES.build("diffusion", {"cond_drop_prob": 0.1})
    opt = torch.optim.AdamW(model.parameters(), lr=2e-3)
    g = torch.Generator().manual_seed(0)
    for _ in range(200):
        x0, cond = pairs(64, g)
        out = loss_fn(model, x0, cond, generator=g)
        opt.zero_grad()
        out.loss.backward()
        opt.step()
    model.eval()
    x0, cond = pairs(16, torch.Generator().manual_seed(123))
    sampler = SAMPLERS.build(
        "cfg", {"guidance_scale": 2.0, "scheduler": {"name": "ddpm", "num_inference_steps": 100}}
    )
    matched = sampler.sample(model, (16, 16, 2), cond, generator=torch.Generator().manual_seed(1))
    shuffled = sampler.sample(model, (16, 16, 2), cond.roll(1, 0), generator=torch.Generator().manual_seed(1))
    err_matched = (matched - x0).square().mean().item()
    err_shuffled = (shuffled - x0).square().mean().item()
    assert err_shuffled == pytest.approx(4.5, rel=0.5)
    assert err_matched < 0.1 * err_shuffled
