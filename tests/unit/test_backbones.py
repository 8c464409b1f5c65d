"""Backbones `dit` and `unet1d`: the call protocol, masking, the null condition, defaults."""

from __future__ import annotations

import pytest
import torch

from momu.backbones.blocks import MaskedGroupNorm, check_prefix_mask
from momu.backbones.dit import DiT, DiTConfig
from momu.backbones.unet1d import UNet1D, UNet1DConfig
from momu.registry import BACKBONES


def tiny_dit(**kw: object) -> DiT:
    params = dict(
        in_channels=4, cond_channels=3, cond_embed_dim=16, hidden=32, heads=4, depth=2, max_length=64
    )
    params.update(kw)
    torch.manual_seed(0)
    return BACKBONES.build("dit", params).eval()


def tiny_unet(**kw: object) -> UNet1D:
    params = dict(
        in_channels=4, cond_channels=3, base_channels=16, heads=4, cross_attention_dim=24, norm_groups=4
    )
    params.update(kw)
    torch.manual_seed(0)
    return BACKBONES.build("unet1d", params).eval()


def tiny_dit_aligned(**kw: object) -> DiT:
    return tiny_dit(positions="aligned", **kw)


def tiny_dit_shortcuts(**kw: object) -> DiT:
    return tiny_dit(cond_add=True, time_to_all_tokens=True, **kw)


def tiny_dit_additive(**kw: object) -> DiT:
    """The condition enters by frame-aligned addition only (no condition tokens)."""
    return tiny_dit(positions="aligned", cond_add=True, cond_tokens=False, **kw)


BUILDERS = {
    "dit": tiny_dit,
    "dit_aligned": tiny_dit_aligned,
    "dit_shortcuts": tiny_dit_shortcuts,
    "dit_additive": tiny_dit_additive,
    "unet1d": tiny_unet,
}
ALL = list(BUILDERS)


@pytest.mark.parametrize("name", ["dit", "unet1d"])
def test_default_config_forward_backward(name: str) -> None:
    model = BACKBONES.build(name)
    cfg = model.cfg
    x = torch.randn(2, 8, cfg.in_channels, requires_grad=True)
    cond = torch.randn(2, 6, cfg.cond_channels)
    out = model(x, torch.tensor([0, 999]), cond)
    assert out.shape == x.shape
    out.square().mean().backward()
    assert x.grad is not None and torch.isfinite(x.grad).all()
    grads = [p.grad for p in model.parameters() if p.requires_grad]
    assert sum(g is not None for g in grads) > 0.9 * len(grads)


def test_dit_paper_defaults_are_table9() -> None:
    cfg = DiTConfig()
    assert (cfg.in_channels, cfg.cond_embed_dim, cfg.hidden, cfg.heads, cfg.depth, cfg.proj_kernel_size) == (
        20,
        1024,
        576,
        8,
        4,
        5,
    )


def test_unet_paper_defaults_are_mofusion_supp() -> None:
    cfg = UNet1DConfig()
    assert cfg.heads == 16 and cfg.cross_attention_dim == 1024 and len(cfg.channel_mults) == 3


@pytest.mark.parametrize("name", ALL)
def test_protocol_attributes(name: str) -> None:
    model = BUILDERS[name]()
    assert model.in_channels == 4 and model.cond_channels == 3
    assert model.max_length == (None if name == "unet1d" else 64)


@pytest.mark.parametrize("name", ALL)
def test_dropped_condition_equals_no_condition(name: str) -> None:
    model = BUILDERS[name]()
    x, cond, t = torch.randn(3, 16, 4), torch.randn(3, 5, 3), torch.tensor([1, 50, 900])
    dropped = model(x, t, cond, drop_cond=torch.ones(3, dtype=torch.bool))
    none = model(x, t, None)
    torch.testing.assert_close(dropped, none, atol=1e-5, rtol=1e-5)
    # dropping only item 1 changes item 1 and leaves the others conditional
    partial = model(x, t, cond, drop_cond=torch.tensor([False, True, False]))
    full = model(x, t, cond)
    torch.testing.assert_close(partial[[0, 2]], full[[0, 2]], atol=1e-5, rtol=1e-5)
    torch.testing.assert_close(partial[1], none[1], atol=1e-5, rtol=1e-5)
    assert not torch.allclose(full[1], none[1], atol=1e-4)


@pytest.mark.parametrize("name", ALL)
def test_condition_content_matters_but_padding_does_not(name: str) -> None:
    model = BUILDERS[name]()
    x, t = torch.randn(1, 16, 4), torch.tensor([10])
    cond = torch.randn(1, 5, 3)
    a = model(x, t, cond)
    assert not torch.allclose(a, model(x, t, cond + 1.0), atol=1e-4)
    padded = torch.cat([cond, 50 * torch.randn(1, 4, 3)], dim=1)
    cmask = torch.tensor([[True] * 5 + [False] * 4])
    torch.testing.assert_close(model(x, t, padded, cond_mask=cmask), a, atol=1e-5, rtol=1e-5)


@pytest.mark.parametrize("name", ALL)
def test_batched_variable_length_equals_individual(name: str) -> None:
    model = BUILDERS[name]()
    lengths = [16, 9, 3]
    x = torch.randn(3, 16, 4)
    cond = torch.randn(3, 7, 3)
    t = torch.tensor([5, 500, 999])
    mask = torch.arange(16)[None] < torch.tensor(lengths)[:, None]
    batched = model(x, t, cond, x_mask=mask)
    for i, n in enumerate(lengths):
        alone = model(x[i : i + 1, :n], t[i : i + 1], cond[i : i + 1])
        torch.testing.assert_close(batched[i : i + 1, :n], alone, atol=1e-5, rtol=1e-4)
        assert torch.all(batched[i, n:] == 0)


@pytest.mark.parametrize("name", ALL)
def test_unconditional_model(name: str) -> None:
    model = BUILDERS[name](cond_channels=0)
    x, t = torch.randn(2, 12, 4), torch.tensor([3, 4])
    assert model(x, t).shape == x.shape
    with pytest.raises(ValueError, match="cond: this backbone is unconditional"):
        model(x, t, torch.randn(2, 3, 3))


@pytest.mark.parametrize("length", [1, 7, 8, 13, 24])
def test_unet_any_length(length: int) -> None:
    model = tiny_unet()
    x = torch.randn(2, length, 4)
    assert model(x, torch.tensor([1, 2]), torch.randn(2, 3, 3)).shape == (2, length, 4)


@pytest.mark.parametrize("name", ALL)
def test_bad_inputs_name_the_argument(name: str) -> None:
    model = BUILDERS[name]()
    x, t, c = torch.randn(2, 8, 4), torch.tensor([1, 2]), torch.randn(2, 3, 3)
    with pytest.raises(ValueError, match="x: expected"):
        model(torch.randn(2, 8, 5), t, c)
    with pytest.raises(ValueError, match="t: expected"):
        model(x, torch.tensor([1]), c)
    with pytest.raises(ValueError, match="cond: expected"):
        model(x, t, torch.randn(2, 3, 2))
    with pytest.raises(ValueError, match="x_mask"):
        model(x, t, c, x_mask=torch.tensor([[True, False] * 4] * 2))
    with pytest.raises(ValueError, match="drop_cond"):
        model(x, t, c, drop_cond=torch.tensor([1, 0]))
    with pytest.raises(ValueError, match="x: must be a finite"):
        model(torch.full((2, 8, 4), float("nan")), t, c)


def test_dit_aligned_positions_bound_each_sequence() -> None:
    model = tiny_dit(max_length=10, positions="aligned")
    model(torch.randn(1, 10, 4), torch.tensor([1]), torch.randn(1, 10, 3))  # each ≤ 10
    with pytest.raises(ValueError, match="latent or condition length 11 exceeds dit.max_length=10"):
        model(torch.randn(1, 5, 4), torch.tensor([1]), torch.randn(1, 11, 3))


def test_dit_max_length_is_enforced() -> None:
    model = tiny_dit(max_length=20)
    model(torch.randn(1, 10, 4), torch.tensor([1]), torch.randn(1, 9, 3))  # 10 + 9 + 1 = 20 fits
    with pytest.raises(ValueError, match="exceeds dit.max_length=20"):
        model(torch.randn(1, 11, 4), torch.tensor([1]), torch.randn(1, 9, 3))


@pytest.mark.parametrize("positions", ["concat", "aligned"])
def test_dit_pad_to_max_is_a_no_op(positions: str) -> None:
    a = tiny_dit(positions=positions)
    b = tiny_dit(pad_to_max=True, positions=positions)
    b.load_state_dict(a.state_dict())
    x, t, c = torch.randn(2, 10, 4), torch.tensor([1, 700]), torch.randn(2, 6, 3)
    widths: dict[str, set[int]] = {}
    for name, model in (("a", a), ("b", b)):
        weights: list[torch.Tensor] = []
        for block in model.blocks:
            block.attn.recorder = weights
        out = model(x, t, c)
        widths[name] = {w.shape[-1] for w in weights}
        if name == "a":
            reference = out
    torch.testing.assert_close(out, reference, atol=1e-5, rtol=1e-5)
    capacity = 2 * 64 + 1 if positions == "aligned" else 64  # max_length = 64
    assert widths == {"a": {10 + 6 + 1}, "b": {capacity}}  # b attends over the padded tokens (masked)


@pytest.mark.parametrize(
    "kw, match",
    [
        ({"hidden": 30, "heads": 4}, "divisible"),
        ({"proj_kernel_size": 4}, "odd"),
        ({"depth": 0}, "depth must be positive"),
        ({"positions": "relative"}, "positions"),
        ({"positions": "aligned", "segment_embeddings": False}, "segment_embeddings"),
        ({"cond_tokens": False}, "cond_add"),
        ({"cond_every_block": True}, "cond_every_block=true needs dit.cond_add"),
    ],
)
def test_dit_config_errors(kw: dict[str, object], match: str) -> None:
    with pytest.raises(ValueError, match=match):
        tiny_dit(**kw)


def test_additive_conditioning_attends_over_latent_frames_and_the_timestep_only() -> None:
    model = tiny_dit_additive()
    weights: list[torch.Tensor] = []
    for block in model.blocks:
        block.attn.recorder = weights
    model(torch.randn(2, 10, 4), torch.tensor([3, 4]), torch.randn(2, 10, 3))
    assert weights and all(w.shape[-1] == 10 + 1 for w in weights)  # [x | t]: no condition tokens


def test_every_block_conditioning_starts_as_the_input_addition_and_then_learns() -> None:
    plain = tiny_dit_additive()
    every = tiny_dit_additive(cond_every_block=True)
    every.load_state_dict(plain.state_dict(), strict=False)  # same weights; its block maps start at zero
    x, t, cond = torch.randn(2, 10, 4), torch.tensor([3, 4]), torch.randn(2, 10, 3)
    torch.testing.assert_close(every(x, t, cond), plain(x, t, cond))
    every.train()(x, t, cond).square().sum().backward()
    assert every.block_cond is not None
    assert all(float(proj.weight.grad.abs().sum()) > 0 for proj in every.block_cond)
    with torch.no_grad():
        for proj in every.block_cond:
            proj.weight.normal_(std=0.2)
        moved = every.eval()(x, t, cond) - plain(x, t, cond)
    assert float(moved.abs().max()) > 1e-3
    # the per-block addition carries the condition: a dropped condition is still the null token
    torch.testing.assert_close(every(x, t, cond, drop_cond=torch.tensor([True, True])), every(x, t, None))


def test_null_embedding_is_trained_by_dropped_items() -> None:
    model = tiny_dit().train()
    out = model(
        torch.randn(2, 6, 4),
        torch.tensor([1, 2]),
        torch.randn(2, 4, 3),
        drop_cond=torch.tensor([True, False]),
    )
    out.sum().backward()
    assert model.null_cond is not None and model.null_cond.grad is not None
    assert model.null_cond.grad.abs().sum() > 0


def test_masked_group_norm_matches_group_norm_on_valid_frames() -> None:
    norm = MaskedGroupNorm(2, 4)
    x = torch.randn(1, 4, 10)
    mask = torch.tensor([[True] * 6 + [False] * 4])
    torch.testing.assert_close(norm(x, mask)[..., :6], torch.nn.GroupNorm(2, 4)(x[..., :6]))
    assert torch.all(norm(x, mask)[..., 6:] == 0)


def test_prefix_mask_check() -> None:
    assert check_prefix_mask(torch.tensor([[True, True, False]]), "m").tolist() == [2]
    with pytest.raises(ValueError, match="m: every item"):
        check_prefix_mask(torch.tensor([[False, False]]), "m")
