"""The example plugin's parts, reached through momu's registries by name."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from momu.config import build_component, load_config
from momu.data.types import Clip
from momu.metrics.base import Metric
from momu.registry import BACKBONES, METRICS


def test_parts_are_discovered_with_their_distribution() -> None:
    assert BACKBONES.sources()["residual_mlp"] == "momu-plugin-example==0.1.0"
    assert METRICS.get("motion_jerk").source == "momu-plugin-example==0.1.0"


def test_backbone_follows_the_protocol() -> None:
    cfg = load_config(
        {"backbone": {"name": "residual_mlp", "in_channels": 6, "cond_channels": 4, "hidden": 32}}
    )
    net = build_component(cfg.backbone, "backbones")
    x, t, cond = torch.randn(3, 10, 6), torch.tensor([0, 10, 999]), torch.randn(3, 7, 4)
    out = net(x, t, cond)
    assert out.shape == x.shape
    out.sum().backward()
    dropped = net(x, t, cond, drop_cond=torch.tensor([True, True, True]))
    assert torch.allclose(dropped, net(x, t, None))
    mask = torch.ones(3, 10, dtype=torch.bool)
    mask[:, 8:] = False
    padded = net(x, t, cond, x_mask=mask)
    assert torch.allclose(padded[:, :8], out[:, :8]) and padded[:, 8:].abs().sum() == 0


def test_metric_on_constant_acceleration_is_zero_and_cubic_is_known() -> None:
    metric = METRICS.build("motion_jerk")
    assert isinstance(metric, Metric)
    fps = 10.0
    time = np.arange(20) / fps
    quadratic = np.stack([time**2, time, 0 * time], -1)[:, None, :]
    cubic = np.stack([time**3, 0 * time, 0 * time], -1)[:, None, :]
    assert metric([Clip("a", quadratic, fps)])["motion_jerk"] == pytest.approx(0.0, abs=1e-6)
    assert metric([Clip("b", cubic, fps)])["motion_jerk"] == pytest.approx(6.0, rel=1e-6)


def test_metric_rejects_short_clips() -> None:
    with pytest.raises(ValueError, match="clip 'x' has 2 frames"):
        METRICS.build("motion_jerk")([Clip("x", np.zeros((2, 1, 3)), 30.0)])
