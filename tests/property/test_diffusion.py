"""Hypothesis properties of the diffusion mathematics (MoMu Eq. 5–9, Alg. 2; MoFusion §4.4)."""

from __future__ import annotations

import functools
from typing import Any

import torch
from hypothesis import given, settings
from hypothesis import strategies as st

from momu.registry import BACKBONES, SAMPLERS, SCHEDULERS
from momu.samplers.base import lengths_to_mask
from momu.schedulers.diffusers_schedulers import NoiseScheduler

timesteps = st.integers(min_value=0, max_value=999)
seeds = st.integers(min_value=0, max_value=2**31 - 1)


@functools.cache
def scheduler(name: str) -> NoiseScheduler:
    return SCHEDULERS.build(name)


@functools.cache
def dit(in_ch: int = 3, cond_ch: int = 2, seed: int = 0, positions: str = "concat", add: bool = False) -> Any:
    torch.manual_seed(seed)
    params = dict(in_channels=in_ch, cond_channels=cond_ch, cond_embed_dim=8, hidden=16, heads=2, depth=2)
    extra = {"positions": positions, "cond_add": add, "time_to_all_tokens": add}
    return BACKBONES.build("dit", {**params, "max_length": 96, **extra}).eval()


@functools.cache
def unet() -> Any:
    torch.manual_seed(0)
    params = dict(
        in_channels=3, cond_channels=2, base_channels=8, heads=2, cross_attention_dim=8, norm_groups=2
    )
    return BACKBONES.build("unet1d", params).eval()


@functools.cache
def sampler(name: str, **params: Any) -> Any:
    return SAMPLERS.build(name, params)


def randn(seed: int, *shape: int, dtype: torch.dtype = torch.float32) -> torch.Tensor:
    return torch.randn(*shape, generator=torch.Generator().manual_seed(seed), dtype=dtype)


@given(t=st.lists(timesteps, min_size=1, max_size=4), seed=seeds, name=st.sampled_from(["ddpm", "ddim"]))
@settings(deadline=None)
def test_forward_diffusion_is_the_closed_form(t: list[int], seed: int, name: str) -> None:
    """z_t = √ᾱ_t z_0 + √(1−ᾱ_t) ε with ᾱ_t = Π(1−β_i) (MoMu Eq. 5)."""
    sched = scheduler(name)
    x0 = randn(seed, len(t), 5, 3, dtype=torch.float64)
    eps = randn(seed + 1, len(t), 5, 3, dtype=torch.float64)
    betas = torch.linspace(1e-4, 0.02, 1000, dtype=torch.float64)
    abar = torch.cumprod(1 - betas, 0)[torch.tensor(t)][:, None, None]
    expected = abar.sqrt() * x0 + (1 - abar).sqrt() * eps
    # diffusers stores ᾱ in float32: agreement to ~1e-6 relative
    torch.testing.assert_close(sched.add_noise(x0, eps, torch.tensor(t)), expected, rtol=1e-4, atol=1e-5)


@given(t=st.lists(timesteps, min_size=1, max_size=4), seed=seeds)
@settings(deadline=None)
def test_x0_is_recovered_from_xt_and_eps(t: list[int], seed: int) -> None:
    """ẑ_0(z_t(z_0, ε), ε) = z_0 (MoMu Alg. 2) and ε(z_t, z_0) = ε."""
    sched = scheduler("ddpm")
    x0 = randn(seed, len(t), 4, 2, dtype=torch.float64)
    eps = randn(seed + 1, len(t), 4, 2, dtype=torch.float64)
    tt = torch.tensor(t)
    xt = sched.add_noise(x0, eps, tt)
    torch.testing.assert_close(sched.predict_x0(xt, eps, tt), x0, rtol=1e-7, atol=1e-7)
    torch.testing.assert_close(sched.predict_eps(xt, x0, tt), eps, rtol=1e-7, atol=1e-7)


@given(seed=seeds, scale=st.sampled_from([0.0, 1.0]), steps=st.integers(1, 3))
@settings(deadline=None)
def test_cfg_scale_one_is_conditional_and_zero_unconditional(seed: int, scale: float, steps: int) -> None:
    """MoMu Eq. 7: s = 1 gives ε(c), s = 0 gives ε(∅) — so sampling equals the plain chain."""
    model = dit()
    cfg = sampler("cfg", num_inference_steps=steps, guidance_scale=scale)
    noise, cond = randn(seed, 2, 6, 3), randn(seed + 1, 2, 4, 2)
    guided = cfg.sample(model, noise, cond)
    run = scheduler("ddim").begin(steps)
    x = noise
    for step_t in run.timesteps:
        t = torch.full((2,), int(step_t))
        eps = model(x, t, cond) if scale == 1.0 else model(x, t, None)
        x = run.step(eps, int(step_t), x)
    torch.testing.assert_close(guided, x, atol=1e-4, rtol=1e-4)


@given(seed=seeds, steps=st.integers(1, 4))
@settings(deadline=None)
def test_cross_guidance_with_tc_zero_is_two_unconditional_samplings(seed: int, steps: int) -> None:
    """MoMu Alg. 2 with T_c = 0: no step is guided; each chain is unconditional sampling from its noise."""
    music, motion = dit(3, 2, 1), dit(2, 3, 2)
    noise_a, noise_m = randn(seed, 2, 5, 3), randn(seed + 1, 2, 5, 2)
    cross = sampler("cross_guidance", gamma=0.0, num_inference_steps=steps)
    za, zm = cross.sample(music, motion, noise_a, noise_m)
    uncond = sampler("cfg", num_inference_steps=steps)
    torch.testing.assert_close(za, uncond.sample(music, noise_a, None), atol=1e-5, rtol=1e-5)
    torch.testing.assert_close(zm, uncond.sample(motion, noise_m, None), atol=1e-5, rtol=1e-5)


@given(
    seed=seeds,
    length=st.integers(2, 12),
    data=st.data(),
    name=st.sampled_from(["ddpm", "ddim"]),
)
@settings(deadline=None)
def test_inpainting_leaves_known_frames_exactly(seed: int, length: int, data: Any, name: str) -> None:
    """MoFusion §4.4: at the end the known frames equal the given ones bit for bit."""
    known_mask = torch.tensor(data.draw(st.lists(st.booleans(), min_size=length, max_size=length)))[None]
    known = randn(seed, 1, length, 3) * 3
    inpaint = sampler("inpainting", num_inference_steps=2, scheduler=name)
    out = inpaint.sample(
        dit(), known, known_mask, randn(seed + 1, 1, 4, 2), generator=torch.Generator().manual_seed(seed)
    )
    assert torch.equal(out[0, known_mask[0]], known[0, known_mask[0]])
    assert torch.isfinite(out).all()


@given(
    seed=seeds,
    length=st.integers(1, 10),
    cond_length=st.integers(1, 8),
    extra=st.integers(1, 10),
    cond_extra=st.integers(0, 6),
    pad_value=st.floats(-1e3, 1e3, allow_nan=False),
    t=timesteps,
    backbone=st.sampled_from(["dit", "dit_aligned", "dit_add", "unet1d"]),
)
@settings(deadline=None)
def test_padding_never_changes_the_valid_output(
    seed: int,
    length: int,
    cond_length: int,
    extra: int,
    cond_extra: int,
    pad_value: float,
    t: int,
    backbone: str,
) -> None:
    """MoMu §4 pad-and-truncate: valid outputs do not depend on the pad length or the pad content."""
    model = {
        "dit": dit,
        "dit_aligned": lambda: dit(positions="aligned"),
        "dit_add": lambda: dit(add=True),
        "unet1d": unet,
    }[backbone]()
    x, cond = randn(seed, 1, length, 3), randn(seed + 1, 1, cond_length, 2)
    tt = torch.tensor([t])
    ref = model(x, tt, cond)
    xp = torch.cat([x, torch.full((1, extra, 3), pad_value)], dim=1)
    cp = torch.cat([cond, torch.full((1, cond_extra, 2), -pad_value)], dim=1)
    out = model(
        xp,
        tt,
        cp,
        x_mask=lengths_to_mask([length], length + extra),
        cond_mask=lengths_to_mask([cond_length], cond_length + cond_extra),
    )
    torch.testing.assert_close(out[:, :length], ref, atol=1e-4, rtol=1e-4)
    assert torch.all(out[:, length:] == 0)
