"""Schedulers `ddpm`/`ddim`, samplers `cfg`/`cross_guidance`/`inpainting`, loss `diffusion`."""

from __future__ import annotations

from typing import Any

import pytest
import torch
from torch import Tensor

from momu.losses.diffusion import DiffusionLoss, masked_mse
from momu.registry import BACKBONES, LOSSES, SAMPLERS, SCHEDULERS
from momu.samplers.base import guided_eps, lengths_to_mask, project_guided, rescale_guided
from momu.samplers.inpainting import forecast_mask, inbetween_mask
from momu.schedulers.diffusers_schedulers import NoiseScheduler


def tiny_dit(in_ch: int = 4, cond_ch: int = 3, seed: int = 0) -> Any:
    torch.manual_seed(seed)
    params = dict(in_channels=in_ch, cond_channels=cond_ch, cond_embed_dim=16, hidden=32, heads=4, depth=2)
    return BACKBONES.build("dit", {**params, "max_length": 128}).eval()


class CountingBackbone(torch.nn.Module):
    """Wraps a backbone and records the batch size of every call."""

    def __init__(self, inner: Any) -> None:
        super().__init__()
        self.inner = inner
        self.in_channels = inner.in_channels
        self.cond_channels = inner.cond_channels
        self.max_length = inner.max_length
        self.calls: list[int] = []

    def forward(self, x: Tensor, t: Tensor, cond: Tensor | None = None, **kw: Any) -> Tensor:
        self.calls.append(x.shape[0])
        return self.inner(x, t, cond, **kw)


# ---------------------------------------------------------------------------------- schedulers
def test_scheduler_defaults_follow_the_papers() -> None:
    ddim = SCHEDULERS.build("ddim")
    ddpm = SCHEDULERS.build("ddpm")
    assert isinstance(ddim, NoiseScheduler) and ddim.num_inference_steps == 50
    assert ddpm.num_train_timesteps == ddim.num_train_timesteps == 1000
    betas = ddpm.scheduler.betas
    assert betas[0].item() == pytest.approx(1e-4) and betas[-1].item() == pytest.approx(0.02)
    torch.testing.assert_close(ddim.alphas_cumprod, torch.cumprod(1 - betas, 0))
    assert len(ddim.begin().timesteps) == 50 and len(ddpm.begin(10).timesteps) == 10


def test_sampling_runs_do_not_share_state() -> None:
    sched = SCHEDULERS.build("ddim")
    a, b = sched.begin(5), sched.begin(20)
    assert len(a.timesteps) == 5 and len(b.timesteps) == 20


@pytest.mark.parametrize(
    "params, match",
    [
        ({"num_inference_steps": 0}, "num_inference_steps"),
        ({"beta_start": 0.1, "beta_end": 0.01}, "beta_start"),
        ({"clip_sample_range": 0.0}, "clip_sample_range"),
    ],
)
def test_scheduler_config_errors(params: dict[str, Any], match: str) -> None:
    with pytest.raises(ValueError, match=match):
        SCHEDULERS.build("ddim", params)


def test_timestep_range_is_checked() -> None:
    with pytest.raises(ValueError, match=r"t: timesteps must be in \[0, 1000\)"):
        SCHEDULERS.build("ddpm").predict_x0(torch.zeros(1, 2, 3), torch.zeros(1, 2, 3), torch.tensor([1000]))


# ---------------------------------------------------------------------------------- cfg
def test_cfg_runs_both_branches_in_one_batched_forward() -> None:
    model = CountingBackbone(tiny_dit())
    sampler = SAMPLERS.build("cfg", {"num_inference_steps": 4})
    out = sampler.sample(model, (2, 10, 4), torch.randn(2, 6, 3), generator=torch.Generator().manual_seed(0))
    assert out.shape == (2, 10, 4)
    assert model.calls == [4, 4, 4, 4]  # one forward of 2B items per step


def test_guided_eps_is_eq7() -> None:
    model = tiny_dit()
    x, t, c = torch.randn(2, 8, 4), torch.tensor([100, 100]), torch.randn(2, 5, 3)
    eps_c = model(x, t, c)
    eps_u = model(x, t, None)
    torch.testing.assert_close(
        guided_eps(model, x, t, c, 2.5), eps_u + 2.5 * (eps_c - eps_u), atol=1e-5, rtol=1e-5
    )


def test_guidance_rescale_is_lin_et_al_and_diffusers() -> None:
    """Rescaled guidance (Lin et al. 2024 §3.4): φ = 1 gives the guided output with the conditional one's
    standard deviation, φ = 0 plain Eq. 7, and without a mask it is diffusers' ``rescale_noise_cfg``."""
    from diffusers.guiders.guider_utils import rescale_noise_cfg

    model = tiny_dit()
    x, t, c = torch.randn(2, 8, 4), torch.tensor([100, 100]), torch.randn(2, 5, 3)
    eps_c = model(x, t, c)
    plain = guided_eps(model, x, t, c, 6.0)
    full = guided_eps(model, x, t, c, 6.0, rescale=1.0)
    torch.testing.assert_close(full.std(dim=(1, 2)), eps_c.std(dim=(1, 2)), atol=1e-5, rtol=1e-5)
    assert (plain.std(dim=(1, 2)) > eps_c.std(dim=(1, 2))).all()  # what rescaling undoes
    torch.testing.assert_close(guided_eps(model, x, t, c, 6.0, rescale=0.0), plain)
    for phi in (0.3, 0.7, 1.0):
        expected = rescale_noise_cfg(plain, eps_c, guidance_rescale=phi)
        torch.testing.assert_close(guided_eps(model, x, t, c, 6.0, rescale=phi), expected)


def test_guidance_rescale_ignores_padded_frames() -> None:
    """With ``x_mask`` the standard deviations are over each item's valid frames: what the padding holds
    does not change the rescaled valid frames."""
    guided, cond_out = torch.randn(2, 10, 4) * 3.0, torch.randn(2, 10, 4)
    mask = torch.ones(2, 10, dtype=torch.bool)
    mask[1, 6:] = False
    out = rescale_guided(guided, cond_out, 1.0, mask)
    valid = out[1, :6]
    torch.testing.assert_close(valid.std(), cond_out[1, :6].std(), atol=1e-5, rtol=1e-5)
    changed = guided.clone()
    changed[1, 6:] = 100.0
    torch.testing.assert_close(rescale_guided(changed, cond_out, 1.0, mask)[1, :6], valid)
    torch.testing.assert_close(out[0], rescale_guided(guided[:1], cond_out[:1], 1.0)[0])


def _guided_sample(name: str, params: dict[str, Any], cond: Tensor) -> Tensor:
    """A 3-step DDPM sample of the ``name`` sampler (``cfg`` or ``inpainting`` with nothing known) at
    guidance 5 with ``params``, the same noise every call."""
    node = {"num_inference_steps": 3, "guidance_scale": 5.0, "scheduler": {"name": "ddpm"}}
    sampler = SAMPLERS.build(name, {**node, **params})
    gen = torch.Generator().manual_seed(3)
    if name == "cfg":
        return sampler.sample(tiny_dit(), (1, 6, 4), cond, generator=gen)
    known, mask = torch.zeros(1, 6, 4), torch.zeros(1, 6, dtype=torch.bool)
    return sampler.sample(tiny_dit(), known, mask, cond, generator=gen)


def test_projected_guidance_drops_the_parallel_component() -> None:
    """Projected guidance (Sadat et al. 2025): η = 1 is plain Eq. 7; at η = 0 what guidance adds to the
    unconditional output is the update's part orthogonal to the conditional output (per item), so the
    guided output grows less than plain CFG's when the update points along the prediction."""
    cond_out = torch.randn(2, 8, 4)
    uncond_out = 0.5 * cond_out + 0.1 * torch.randn(2, 8, 4)  # the update is mostly parallel
    plain = uncond_out + 6.0 * (cond_out - uncond_out)
    torch.testing.assert_close(project_guided(cond_out, uncond_out, 6.0, 1.0), plain)
    out = project_guided(cond_out, uncond_out, 6.0, 0.0)
    added = (out - uncond_out) / 6.0
    torch.testing.assert_close((added * cond_out).sum(dim=(1, 2)), torch.zeros(2), atol=1e-5, rtol=0)
    assert (out.norm(dim=(1, 2)) < plain.norm(dim=(1, 2))).all()
    half = project_guided(cond_out, uncond_out, 6.0, 0.5)
    torch.testing.assert_close(half, (out + plain) / 2)  # η weights the parallel part linearly


def test_projected_guidance_ignores_padded_frames() -> None:
    """With ``x_mask`` the projection is over each item's valid frames: what the padding holds does not
    change the valid frames, and an unpadded item is as without a mask."""
    cond_out, uncond_out = torch.randn(2, 10, 4), torch.randn(2, 10, 4)
    mask = torch.ones(2, 10, dtype=torch.bool)
    mask[1, 6:] = False
    out = project_guided(cond_out, uncond_out, 5.0, 0.0, mask)
    changed = cond_out.clone()
    changed[1, 6:] = 100.0
    torch.testing.assert_close(project_guided(changed, uncond_out, 5.0, 0.0, mask)[1, :6], out[1, :6])
    torch.testing.assert_close(out[0], project_guided(cond_out[:1], uncond_out[:1], 5.0, 0.0)[0])


@pytest.mark.parametrize("name", ["cfg", "inpainting"])
def test_guidance_parallel_config(name: str) -> None:
    """``guidance_parallel`` changes a guided sample (1 is the default, plain CFG), a value outside [0, 1]
    is named, and the long-sequence stitching keeps it."""
    from momu.generation.stitching import inpainting_like

    cond = torch.randn(1, 6, 3)

    def run(params: dict[str, Any]) -> Tensor:
        return _guided_sample(name, params, cond)

    assert torch.equal(run({"guidance_parallel": 1.0}), run({}))
    assert not torch.allclose(run({"guidance_parallel": 0.0}), run({}))
    with pytest.raises(ValueError, match="guidance_parallel"):
        SAMPLERS.build(name, {"guidance_parallel": -0.5})
    if name == "cfg":
        assert inpainting_like(SAMPLERS.build(name, {"guidance_parallel": 0.25})).guidance.parallel == 0.25


@pytest.mark.parametrize("name", ["cfg", "inpainting"])
def test_guidance_rescale_config(name: str) -> None:
    """``guidance_rescale`` changes a guided sample, and a value outside [0, 1] is named."""
    cond = torch.randn(1, 6, 3)

    def run(params: dict[str, Any]) -> Tensor:
        return _guided_sample(name, params, cond)

    assert torch.equal(run({"guidance_rescale": 0.0}), run({}))
    assert not torch.allclose(run({"guidance_rescale": 0.7}), run({}))
    with pytest.raises(ValueError, match="guidance_rescale"):
        SAMPLERS.build(name, {"guidance_rescale": 1.5})


@pytest.mark.parametrize("name", ["cfg", "inpainting"])
def test_guidance_interval_guides_only_the_steps_inside_it(name: str) -> None:
    """``guidance_interval`` (Kynkäänniemi et al. 2024): steps at timesteps outside it are conditional
    (one pass of B items, s = 1), steps inside are guided; an interval holding every step is plain CFG."""
    cond = torch.randn(2, 10, 3)
    node = {
        "num_inference_steps": 4,
        "guidance_scale": 5.0,
        "scheduler": {"name": "ddpm", "timestep_spacing": "trailing"},
    }

    def run(params: dict[str, Any]) -> tuple[Tensor, list[int]]:
        model = CountingBackbone(tiny_dit())
        sampler = SAMPLERS.build(name, {**node, **params})
        gens = [torch.Generator().manual_seed(s) for s in (1, 2)]
        if name == "cfg":
            return sampler.sample(model, (2, 10, 4), cond, generator=gens), model.calls
        known, mask = torch.zeros(2, 10, 4), torch.zeros(2, 10, dtype=torch.bool)
        return sampler.sample(model, known, mask, cond, generator=gens), model.calls

    plain, calls = run({})
    assert calls == [4, 4, 4, 4]
    everywhere, _ = run({"guidance_interval": [0, 999]})
    assert torch.equal(everywhere, plain)
    conditional, _ = run({"guidance_scale": 1.0})
    first_only, calls = run({"guidance_interval": [999, 999]})  # trailing DDPM steps: 999, 749, 499, 249
    assert calls == [4, 2, 2, 2]  # the first step guided, the other three conditional
    assert not torch.equal(first_only, plain) and not torch.equal(first_only, conditional)
    with pytest.raises(ValueError, match="guidance_interval"):
        SAMPLERS.build(name, {"guidance_interval": [500, 100]})


def test_stitching_keeps_the_guidance_interval() -> None:
    from momu.generation.stitching import inpainting_like

    sampler = SAMPLERS.build(
        "cfg", {"guidance_scale": 8.0, "guidance_interval": [250, 999], "guidance_rescale": 0.7}
    )
    assert inpainting_like(sampler).guidance.interval == (250, 999)
    assert inpainting_like(sampler).guidance.rescale == 0.7


def test_sampling_is_reproducible_with_a_seeded_generator() -> None:
    model = tiny_dit()
    sampler = SAMPLERS.build("cfg", {"num_inference_steps": 3, "scheduler": {"name": "ddpm"}})
    cond = torch.randn(1, 4, 3)
    runs = [
        sampler.sample(model, (1, 6, 4), cond, generator=torch.Generator().manual_seed(7)) for _ in range(2)
    ]
    torch.testing.assert_close(runs[0], runs[1], rtol=0, atol=0)
    other = sampler.sample(model, (1, 6, 4), cond, generator=torch.Generator().manual_seed(8))
    assert not torch.allclose(runs[0], other)


def test_per_item_generators_make_stochastic_samples_batch_independent() -> None:
    model = tiny_dit()
    sampler = SAMPLERS.build("cfg", {"num_inference_steps": 3, "scheduler": {"name": "ddpm"}})
    cond = torch.randn(2, 4, 3)

    def gens(*seeds: int) -> list[torch.Generator]:
        return [torch.Generator().manual_seed(s) for s in seeds]

    batched = sampler.sample(model, (2, 6, 4), cond, generator=gens(7, 8))
    torch.manual_seed(0)  # the global RNG plays no part
    second = sampler.sample(model, (1, 6, 4), cond[1:], generator=gens(8))
    torch.testing.assert_close(batched[1:], second, atol=1e-5, rtol=1e-5)
    assert not torch.allclose(batched[0], batched[1])
    with pytest.raises(ValueError, match="2 generators for a batch of 3"):
        sampler.sample(model, (3, 6, 4), torch.randn(3, 4, 3), generator=gens(1, 2))
    with pytest.raises(ValueError, match="1 generators for a batch of 2"):
        sampler.sample(model, torch.randn(2, 6, 4), cond, generator=gens(1))


def test_variable_length_batch_equals_individual_generation() -> None:
    """MoMu §5.3: one padded batch of different lengths = each length generated alone (DDIM, η=0)."""
    model = tiny_dit()
    sampler = SAMPLERS.build("cfg", {"num_inference_steps": 5})
    lengths = [12, 7, 3]
    noise = torch.randn(3, 12, 4)
    cond = torch.randn(3, 12, 3)
    mask = lengths_to_mask(lengths)
    batched = sampler.sample(model, noise, cond, x_mask=mask, cond_mask=mask)
    for i, n in enumerate(lengths):
        alone = sampler.sample(model, noise[i : i + 1, :n], cond[i : i + 1, :n])
        torch.testing.assert_close(batched[i : i + 1, :n], alone, atol=1e-4, rtol=1e-4)
        assert torch.all(batched[i, n:] == 0)


def test_lengths_to_mask() -> None:
    assert lengths_to_mask([2, 1], 3).tolist() == [[True, True, False], [True, False, False]]
    with pytest.raises(ValueError, match="lengths"):
        lengths_to_mask([0, 2])


def test_sampler_uses_a_given_scheduler_instance() -> None:
    sched = SCHEDULERS.build("ddim", {"num_inference_steps": 2})
    sampler = SAMPLERS.build("cfg", {}, scheduler=sched)
    assert sampler.scheduler is sched
    model = CountingBackbone(tiny_dit())
    sampler.sample(model, (1, 5, 4), torch.randn(1, 5, 3))
    assert len(model.calls) == 2


# ---------------------------------------------------------------------------------- cross guidance
def test_cross_guidance_uses_the_other_modality_only_after_t_c() -> None:
    music = CountingBackbone(tiny_dit(in_ch=4, cond_ch=3, seed=1))
    motion = CountingBackbone(tiny_dit(in_ch=3, cond_ch=4, seed=2))
    sampler = SAMPLERS.build("cross_guidance", {"gamma": 0.5, "num_inference_steps": 10})
    assert sampler.t_c == 500
    za, zm = sampler.sample(music, motion, (2, 8, 4), (2, 8, 3), generator=torch.Generator().manual_seed(0))
    assert za.shape == (2, 8, 4) and zm.shape == (2, 8, 3)
    # DDIM "leading" timesteps 900 … 0: paper t = 901 … 1; t ≤ 500 guided -> 5 of 10 steps need 2 calls
    assert len(music.calls) == 10 + 5 and len(motion.calls) == 10 + 5


def test_cross_guidance_channel_mismatch_is_an_error() -> None:
    sampler = SAMPLERS.build("cross_guidance", {"num_inference_steps": 2})
    with pytest.raises(ValueError, match="cond_channels"):
        sampler.sample(tiny_dit(4, 3), tiny_dit(3, 5), (1, 4, 4), (1, 4, 3))
    with pytest.raises(ValueError, match="gamma"):
        SAMPLERS.build("cross_guidance", {"gamma": 1.5})


def test_cross_guidance_gamma_one_differs_from_unconditional() -> None:
    music, motion = tiny_dit(4, 3, seed=1), tiny_dit(3, 4, seed=2)
    noise_a, noise_m = torch.randn(1, 6, 4), torch.randn(1, 6, 3)
    outs = []
    for gamma in (0.0, 1.0):
        s = SAMPLERS.build("cross_guidance", {"gamma": gamma, "num_inference_steps": 4})
        outs.append(s.sample(music, motion, noise_a, noise_m))
    assert not torch.allclose(outs[0][0], outs[1][0], atol=1e-4)


# ---------------------------------------------------------------------------------- inpainting
def test_masks_presets() -> None:
    assert forecast_mask(1, 5, 2).tolist() == [[True, True, False, False, False]]
    assert inbetween_mask(1, 7, 3).tolist() == [[True, False, False, True, False, False, True]]
    with pytest.raises(ValueError, match="seed_frames"):
        forecast_mask(1, 5, 6)


@pytest.mark.parametrize("preset", ["forecast", "inbetween"])
def test_inpainting_presets_keep_known_frames(preset: str) -> None:
    model = tiny_dit()
    sampler = SAMPLERS.build(
        "inpainting", {"preset": preset, "seed_frames": 4, "keyframe_interval": 3, "num_inference_steps": 3}
    )
    known = torch.randn(2, 10, 4)
    out = sampler.sample(model, known, cond=torch.randn(2, 10, 3), generator=torch.Generator().manual_seed(0))
    mask = sampler.preset_mask(2, 10)
    assert torch.equal(out[mask], known[mask])
    assert not torch.allclose(out[~mask], known[~mask])


def test_inpainting_bad_mask_is_an_error() -> None:
    sampler = SAMPLERS.build("inpainting", {"num_inference_steps": 2})
    with pytest.raises(ValueError, match="known_mask"):
        sampler.sample(tiny_dit(), torch.randn(1, 6, 4), torch.ones(1, 5, dtype=torch.bool))
    with pytest.raises(ValueError, match="preset"):
        SAMPLERS.build("inpainting", {"preset": "outpaint"})


def test_soft_inpainting_with_weights_zero_and_one_is_hard_inpainting() -> None:
    sampler = SAMPLERS.build("inpainting", {"num_inference_steps": 4})
    known, cond = torch.randn(2, 10, 4), torch.randn(2, 10, 3)
    hard = torch.zeros(2, 10, dtype=torch.bool)
    hard[:, :3] = True
    hard[1, -2:] = True

    def run(mask: Tensor) -> Tensor:
        gens = [torch.Generator().manual_seed(s) for s in (1, 2)]
        return sampler.sample(tiny_dit(), known, mask, cond, generator=gens)

    assert torch.equal(run(hard.float()), run(hard))
    soft = hard.float()
    soft[:, 2] = 0.5  # may move; weight-1 frames are kept exactly
    out = run(soft)
    assert torch.equal(out[:, :2], known[:, :2]) and torch.equal(out[1, -2:], known[1, -2:])
    assert not torch.equal(out[:, 2], known[:, 2])
    with pytest.raises(ValueError, match="known_mask"):
        sampler.sample(tiny_dit(), known, soft * 2.0, cond)


def test_separate_null_branch_gives_the_batched_cfg_result() -> None:
    """The unconditional CFG branch run as its own forward without the condition (protocol rule 2) is
    the batched forward's result, with padded items too."""
    from momu.samplers.branches import SeparateNullBranch

    model = tiny_dit()
    x, t, cond = torch.randn(3, 9, 4), torch.tensor([5, 500, 900]), torch.randn(3, 9, 3)
    mask = lengths_to_mask([9, 6, 4], 9)
    for x_mask in (None, mask):
        batched = guided_eps(model, x, t, cond, 3.0, x_mask=x_mask, cond_mask=x_mask)
        counting = CountingBackbone(model)
        split = guided_eps(SeparateNullBranch(counting), x, t, cond, 3.0, x_mask=x_mask, cond_mask=x_mask)
        assert counting.calls == [3, 3]
        torch.testing.assert_close(split, batched, atol=1e-5, rtol=1e-5)
    wrapped = SeparateNullBranch(model)
    assert (wrapped.in_channels, wrapped.cond_channels, wrapped.max_length) == (4, 3, 128)
    all_dropped = torch.ones(3, dtype=torch.bool)
    torch.testing.assert_close(wrapped(x, t, cond, drop_cond=all_dropped), model(x, t, None))


# ---------------------------------------------------------------------------------- loss
class OracleBackbone(torch.nn.Module):
    """Knows that x0 = 0, so ε = x_t / √(1−ᾱ_t) exactly."""

    in_channels, cond_channels, max_length = 2, 0, None

    def __init__(self, sched: NoiseScheduler) -> None:
        super().__init__()
        self.sched = sched

    def forward(self, x: Tensor, t: Tensor, cond: Tensor | None = None, **kw: Any) -> Tensor:
        return self.sched.predict_eps(x, torch.zeros_like(x), t)


def test_diffusion_loss_is_zero_for_the_oracle_and_mean_square_noise_for_zero() -> None:
    loss = LOSSES.build("diffusion")
    assert isinstance(loss, DiffusionLoss)
    x0 = torch.zeros(3, 5, 2)
    out = loss(OracleBackbone(loss.scheduler), x0, generator=torch.Generator().manual_seed(0))
    assert out.loss.item() == pytest.approx(0.0, abs=1e-8)
    zero = CountingBackbone(OracleBackbone(loss.scheduler))
    zero.forward = lambda x, t, cond=None, **kw: torch.zeros_like(x)  # type: ignore[method-assign]
    res = loss(zero, x0, generator=torch.Generator().manual_seed(1))
    assert res.loss.item() == pytest.approx(res.noise.square().mean().item())


def test_diffusion_loss_ignores_padded_frames() -> None:
    loss = LOSSES.build("diffusion", {"cond_drop_prob": 0.0})
    model = tiny_dit()
    x0 = torch.randn(2, 8, 4)
    cond = torch.randn(2, 8, 3)
    mask = lengths_to_mask([8, 5])
    kw = dict(t=torch.tensor([10, 700]), noise=torch.randn(2, 8, 4))
    a = loss(model, x0, cond, x_mask=mask, cond_mask=mask, **kw)
    x0b = x0.clone()
    x0b[1, 5:] = 99.0
    b = loss(model, x0b, cond, x_mask=mask, cond_mask=mask, **kw)
    assert a.loss.item() == pytest.approx(b.loss.item(), rel=1e-5)


def test_masked_mse_by_hand() -> None:
    pred = torch.tensor([[[1.0], [3.0]]])
    assert masked_mse(pred, torch.zeros_like(pred), torch.tensor([[True, False]])).item() == 1.0
    assert masked_mse(pred, torch.zeros_like(pred), None).item() == 5.0


@pytest.mark.parametrize("p, expected", [(0.0, 0), (1.0, 6)])
def test_condition_dropout_probability(p: float, expected: int) -> None:
    loss = LOSSES.build("diffusion", {"cond_drop_prob": p})
    out = loss(
        tiny_dit(), torch.randn(6, 4, 4), torch.randn(6, 4, 3), generator=torch.Generator().manual_seed(0)
    )
    assert int(out.dropped.sum()) == expected


def test_training_a_tiny_dit_reduces_the_loss() -> None:
    torch.manual_seed(0)
    model = tiny_dit().train()
    loss = LOSSES.build("diffusion", {"cond_drop_prob": 0.0})
    x0 = torch.sin(torch.linspace(0, 6, 12))[None, :, None].repeat(4, 1, 4)
    cond = torch.randn(4, 12, 3)
    t, noise = torch.tensor([50, 300, 600, 900]), torch.randn(4, 12, 4)
    opt = torch.optim.Adam(model.parameters(), lr=3e-3)
    first = None
    for _ in range(30):
        value = loss(model, x0, cond, t=t, noise=noise).loss
        first = value.item() if first is None else first
        opt.zero_grad()
        value.backward()
        opt.step()
    assert value.item() < 0.3 * first


@pytest.mark.parametrize("name", ["cfg", "inpainting"])
def test_noise_temperature_scales_the_initial_noise(name: str) -> None:
    """``noise_temperature`` τ draws z_T from N(0, τ²I): with a deterministic DDIM (η = 0) the sample is
    the one from the noise τ·z at τ = 1; 1 is the default, a value ≤ 0 is named, and the long-sequence
    stitching keeps it."""
    from momu.generation.stitching import inpainting_like

    cond, z = torch.randn(1, 6, 3), torch.randn(1, 6, 4)
    node = {"num_inference_steps": 4, "guidance_scale": 3.0, "scheduler": {"name": "ddim", "eta": 0.0}}
    backbone = tiny_dit()

    def run(temperature: float | None, noise: Tensor) -> Tensor:
        params = {} if temperature is None else {"noise_temperature": temperature}
        sampler = SAMPLERS.build(name, {**node, **params})
        if name == "cfg":
            return sampler.sample(backbone, noise, cond)
        known, mask = torch.zeros(1, 6, 4), torch.zeros(1, 6, dtype=torch.bool)
        return sampler.sample(backbone, known, mask, cond, noise=noise)

    torch.testing.assert_close(run(0.6, z), run(1.0, 0.6 * z))
    assert not torch.allclose(run(0.6, z), run(None, z))
    torch.testing.assert_close(run(None, z), run(1.0, z))
    with pytest.raises(ValueError, match="noise_temperature"):
        SAMPLERS.build(name, {"noise_temperature": 0.0})
    if name == "cfg":
        assert inpainting_like(SAMPLERS.build(name, {"noise_temperature": 0.5})).temperature == 0.5
