"""MoFusion's parts on CPU: the scheduled kinematic loss trains any ε-backbone; U-Net options."""

from __future__ import annotations

import pytest
import torch

from momu.backbones.unet1d import record_attention
from momu.registry import BACKBONES, LOSSES

_TINY_UNET = {"in_channels": 72, "base_channels": 16, "heads": 4, "cross_attention_dim": 32, "norm_groups": 8}
_TINY_DIT = {
    "in_channels": 72,
    "cond_channels": 80,
    "hidden": 32,
    "heads": 2,
    "depth": 1,
    "cond_embed_dim": 32,
}


@pytest.mark.parametrize(("name", "params"), [("unet1d", _TINY_UNET), ("dit", _TINY_DIT)])
def test_scheduled_kinematic_trains_any_eps_backbone(name: str, params: dict) -> None:
    torch.manual_seed(0)
    net = BACKBONES.build(name, params)
    loss = LOSSES.build("scheduled_kinematic", {})
    opt = torch.optim.AdamW(net.parameters(), lr=1e-3)
    x, c = torch.randn(4, 16, 72), torch.randn(4, 6, 80)
    mask = torch.ones(4, 16, dtype=torch.bool)
    mask[1, 10:] = False
    gen = torch.Generator().manual_seed(0)
    before = None
    for _ in range(3):
        total, logs = loss(net, x, c, x_mask=mask, cond_mask=None, generator=gen)
        opt.zero_grad()
        total.backward()
        opt.step()
        before = before or logs
    assert set(logs) == {"l_da", "l_s", "l_a", "l_m", "l_k_weighted"}
    assert all(torch.isfinite(torch.tensor(v)) for v in logs.values())
    grads = [p.grad for p in net.parameters() if p.grad is not None]
    assert grads and all(torch.isfinite(g).all() for g in grads)


def test_switches_and_schedule_none_leave_the_data_term() -> None:
    torch.manual_seed(0)
    net = BACKBONES.build("unet1d", _TINY_UNET).eval()
    x, c = torch.randn(2, 8, 72), torch.randn(2, 4, 80)
    t, noise = torch.tensor([3, 40]), torch.randn(2, 8, 72)
    plain = LOSSES.build("diffusion", {"cond_drop_prob": 0.0})(net, x, c, t=t, noise=noise).loss
    for params in ({"schedule": "none"}, {"use_s": False, "use_a": False, "use_m": False}):
        total, logs = LOSSES.build("scheduled_kinematic", params)(net, x, c, t=t, noise=noise)
        assert float(total) == pytest.approx(float(plain)) and "l_s" not in logs
    full, logs = LOSSES.build("scheduled_kinematic", {})(net, x, c, t=t, noise=noise)
    assert float(full) > float(plain)
    only_m, logs_m = LOSSES.build("scheduled_kinematic", {"use_s": False, "use_a": False})(
        net, x, c, t=t, noise=noise
    )
    assert logs_m["l_s"] == 0.0 and logs_m["l_a"] == 0.0 and logs_m["l_m"] > 0


def test_bad_loss_config_names_the_key() -> None:
    with pytest.raises(ValueError, match="schedule"):
        LOSSES.build("scheduled_kinematic", {"schedule": "linear"})
    with pytest.raises(ValueError, match="2D"):
        LOSSES.build("scheduled_kinematic", {"skeleton": "openpose14"})


def test_unet_mlp_projection_and_context_positions() -> None:
    torch.manual_seed(0)
    x, t, c = torch.randn(2, 16, 72), torch.tensor([1, 500]), torch.randn(2, 5, 80)
    mlp = BACKBONES.build("unet1d", {**_TINY_UNET, "cond_proj": "mlp"})
    assert isinstance(mlp.cond_proj, torch.nn.Sequential)
    assert mlp(x, t, c).shape == x.shape
    with pytest.raises(ValueError, match="cond_proj"):
        BACKBONES.build("unet1d", {**_TINY_UNET, "cond_proj": "conv"})
    torch.manual_seed(1)
    on = BACKBONES.build("unet1d", _TINY_UNET).eval()
    off = BACKBONES.build("unet1d", {**_TINY_UNET, "context_positions": False}).eval()
    off.load_state_dict(on.state_dict())
    with torch.no_grad():
        assert not torch.allclose(on(x, t, c), off(x, t, c))
        # without context positions the order of the tokens does not matter to cross-attention
        assert torch.allclose(off(x, t, c), off(x, t, c.flip(1)), atol=1e-5)


def test_attention_recorder_returns_maps_and_keeps_outputs() -> None:
    torch.manual_seed(0)
    net = BACKBONES.build("unet1d", _TINY_UNET).eval()
    x, t, c = torch.randn(2, 40, 72), torch.tensor([5, 900]), torch.randn(2, 13, 80)
    cmask = torch.ones(2, 13, dtype=torch.bool)
    cmask[1, 9:] = False
    with torch.no_grad():
        plain = net(x, t, c, cond_mask=cmask)
        with record_attention(net) as maps:
            recorded = net(x, t, c, cond_mask=cmask)
        again = net(x, t, c, cond_mask=cmask)
    torch.testing.assert_close(recorded, plain, atol=1e-5, rtol=1e-5)
    assert torch.equal(again, plain)  # the recorder is removed on exit
    assert list(maps) == ["down0", "down1", "down2", "mid", "up0", "up1", "up2"]
    assert maps["down0"][0].shape == (2, 4, 40, 13) and maps["mid"][0].shape == (2, 4, 5, 13)
    w = maps["mid"][0]
    torch.testing.assert_close(w.sum(-1), torch.ones(2, 4, 5))
    assert float(w[1, ..., 9:].abs().max()) == 0.0  # padded condition frames get no weight
