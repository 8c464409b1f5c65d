"""``learnable_motion`` trains end to end with the denoiser (MoMu §5.1): the diffusion loss reaches it."""

from __future__ import annotations

import torch

from momu.registry import BACKBONES, ENCODERS, LOSSES


def test_diffusion_loss_trains_the_motion_encoder() -> None:
    torch.manual_seed(0)
    enc = ENCODERS.build(
        "learnable_motion",
        {
            "num_joints": 5,
            "dim_in": 2,
            "dim_feat": 8,
            "dim_rep": 4,
            "depth": 1,
            "num_heads": 2,
            "out_channels": 6,
            "downsample": 2,
        },
    )
    dit = BACKBONES.build(
        "dit",
        {
            "in_channels": 4,
            "cond_channels": 6,
            "cond_embed_dim": 16,
            "hidden": 16,
            "heads": 2,
            "depth": 1,
            "max_length": 64,
            "time_freq_dim": 16,
        },
    )
    loss_fn = LOSSES.build("diffusion", {"cond_drop_prob": 0.0})
    motion = torch.randn(2, 8, 5, 2)
    mask = torch.ones(2, 8, dtype=torch.bool)
    mask[1, 6:] = False
    x0 = torch.randn(2, 4, 4)
    t = torch.tensor([10, 500])
    noise = torch.randn(2, 4, 4)
    params = list(enc.parameters()) + list(dit.parameters())
    opt = torch.optim.Adam(params, lr=3e-3)
    before = {k: v.clone() for k, v in enc.state_dict().items()}
    losses = []
    for _ in range(25):
        cond = enc(motion, mask)
        out = loss_fn(dit, x0, cond, cond_mask=enc.output_mask(mask), t=t, noise=noise)
        opt.zero_grad()
        out.loss.backward()
        grads = [p.grad for p in enc.parameters()]
        assert all(g is not None and torch.isfinite(g).all() for g in grads)
        opt.step()
        losses.append(float(out.loss.detach()))
    assert losses[-1] < 0.7 * losses[0]
    changed = [k for k, v in enc.state_dict().items() if not torch.equal(v, before[k])]
    assert "proj.weight" in changed and any(k.startswith("backbone.") for k in changed)
