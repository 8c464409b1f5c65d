"""The 1D building blocks and the Gaussian 1D-conv VAE shared by every BiCoR-VAE branch (MoMu App. A.1)."""

from __future__ import annotations

import dataclasses
import math

import pytest
import torch
from tests.helpers.encoders import tiny_vae_config

from momu.encoders.blocks import (
    Downsample1d,
    MiddleBlock1d,
    ResBlock1d,
    SelfAttention,
    SpatialTransformer1d,
    Upsample1d,
    group_norm,
)
from momu.encoders.vae import (
    Decoder1d,
    DiagonalGaussian,
    Encoder1d,
    VAE1dConfig,
    check_vae_config,
    paper_vae_config,
)


def test_group_norm_uses_a_divisor_of_the_width() -> None:
    assert group_norm(20).num_groups == 4  # gcd(20, 32): Table 8's 20 channels are not a multiple of 32
    assert group_norm(64).num_groups == 32
    assert group_norm(7).num_groups == 1


@pytest.mark.parametrize("length", [8, 9, 15])
def test_down_and_upsampling_lengths(length: int) -> None:
    x = torch.randn(2, 6, length)
    assert Downsample1d(6, 2, 5)(x).shape == (2, 6, math.ceil(length / 2))
    assert Upsample1d(6, 2, 5)(x).shape == (2, 6, 2 * length)
    assert ResBlock1d(6, 10, 5)(x).shape == (2, 10, length)


def test_even_kernel_is_rejected() -> None:
    with pytest.raises(ValueError, match="kernel_size"):
        ResBlock1d(4, 4, kernel_size=4)


def test_spatial_transformer_starts_as_identity() -> None:
    # The zero-initialised output projection makes the residual block the identity at init.
    block = SpatialTransformer1d(8, depth=3, heads=2)
    x = torch.randn(2, 8, 5)
    torch.testing.assert_close(block(x), x)


def test_attention_mask_hides_padded_keys() -> None:
    torch.manual_seed(0)
    attn = SelfAttention(8, heads=2)
    x = torch.randn(1, 6, 8)
    mask = torch.tensor([[True, True, True, True, False, False]])
    garbage = x.clone()
    garbage[:, 4:] = 100.0
    torch.testing.assert_close(attn(x, mask)[:, :4], attn(garbage, mask)[:, :4])


def test_middle_block_without_attention() -> None:
    block = MiddleBlock1d(8, attention_layers=0)
    assert block.attn is None
    assert block(torch.randn(1, 8, 4)).shape == (1, 8, 4)


def test_encoder_decoder_shapes_follow_the_downsampling() -> None:
    cfg = VAE1dConfig(
        latent_channels=3,
        base_channels=8,
        channel_mult=[1, 2, 2],
        num_res_blocks=1,
        attention_layers=1,
        attention_heads=2,
        downsample_levels=[0, 1],
    )
    enc, dec = Encoder1d(5, cfg), Decoder1d(5, cfg)
    moments = enc(torch.randn(2, 5, 16))
    assert moments.shape == (2, 6, 4)  # two layers of rate 2: 16 -> 4, mean + logvar
    assert dec(torch.randn(2, 3, 4)).shape == (2, 5, 16)


def test_replicate_padding_has_no_edge_effect() -> None:
    # A latent constant over time decodes to an output constant over time when every convolution
    # continues its edge frame; zero padding makes the first and last frames differ (fake silence).
    torch.manual_seed(0)
    base = dataclasses.replace(tiny_vae_config(), latent_channels=3, norm_groups=4)
    z = torch.ones(1, 3, 6) * torch.tensor([0.5, -1.0, 2.0])[None, :, None]
    outputs = {}
    for mode in ("zeros", "replicate"):
        torch.manual_seed(0)
        outputs[mode] = Decoder1d(4, dataclasses.replace(base, padding_mode=mode))(z).detach()
    flat = outputs["replicate"] - outputs["replicate"][..., :1]
    assert flat.abs().max() < 1e-4  # float32 rounding only
    assert (outputs["zeros"][..., 0] - outputs["zeros"][..., 6]).abs().max() > 1e-3
    # the weights are the same modules: a checkpoint loads whatever the padding mode
    torch.manual_seed(0)
    zeros = Decoder1d(4, base)
    Decoder1d(4, dataclasses.replace(base, padding_mode="replicate")).load_state_dict(zeros.state_dict())
    with pytest.raises(ValueError, match=r"vae\.padding_mode"):
        check_vae_config(VAE1dConfig(padding_mode="circle"))


def test_config_validation_names_the_field() -> None:
    with pytest.raises(ValueError, match=r"vae\.downsample_levels"):
        check_vae_config(VAE1dConfig(channel_mult=[1, 2], downsample_levels=[2]))
    with pytest.raises(ValueError, match=r"vae\.attention_heads"):
        check_vae_config(VAE1dConfig(base_channels=10, channel_mult=[1], attention_heads=3))
    with pytest.raises(ValueError, match=r"vae\.kernel_size"):
        check_vae_config(VAE1dConfig(kernel_size=4))


def test_paper_config_is_table_8() -> None:
    cfg = paper_vae_config()
    assert cfg.latent_channels == 20
    assert cfg.num_res_blocks == 2
    assert cfg.channel_mult == [1, 2, 4]
    assert cfg.attention_layers == 3
    assert cfg.downsample_rate == 2 and cfg.downsample_levels == [0]
    assert cfg.kernel_size == 5


def test_kl_is_zero_for_the_standard_normal_posterior() -> None:
    q = DiagonalGaussian(torch.zeros(3, 5, 4), torch.zeros(3, 5, 4))
    torch.testing.assert_close(q.kl(), torch.zeros(3))


def test_kl_matches_the_closed_form_by_hand() -> None:
    # mean 1, var e: 0.5 * (1 + e - 1 - 1) per element; 2 x 3 elements per item.
    q = DiagonalGaussian(torch.ones(1, 2, 3), torch.ones(1, 2, 3))
    expected = 0.5 * (1.0 + math.e - 2.0) * 6
    torch.testing.assert_close(q.kl(), torch.tensor([expected]))
    # A mask removes the masked frame's contribution.
    torch.testing.assert_close(q.kl(torch.tensor([[True, False]])), torch.tensor([expected / 2]))


def test_kl_agrees_with_torch_distributions() -> None:
    torch.manual_seed(1)
    mean, logvar = torch.randn(2, 3, 4), torch.randn(2, 3, 4)
    q = DiagonalGaussian(mean, logvar)
    ref = torch.distributions.kl_divergence(
        torch.distributions.Normal(mean, (0.5 * logvar).exp()), torch.distributions.Normal(0.0, 1.0)
    )
    torch.testing.assert_close(q.kl(), ref.flatten(1).sum(1))


def test_reparameterised_sample_is_deterministic_per_generator_and_differentiable() -> None:
    mean = torch.zeros(2, 4, 3, requires_grad=True)
    logvar = torch.zeros(2, 4, 3, requires_grad=True)
    q = DiagonalGaussian(mean, logvar)
    a = q.sample(torch.Generator().manual_seed(0))
    b = q.sample(torch.Generator().manual_seed(0))
    torch.testing.assert_close(a, b)
    a.sum().backward()
    assert mean.grad is not None and logvar.grad is not None
    torch.testing.assert_close(mean.grad, torch.ones_like(mean))


def test_logvar_is_clamped() -> None:
    q = DiagonalGaussian(torch.zeros(1, 1, 1), torch.full((1, 1, 1), 1e4))
    assert torch.isfinite(q.var).all()


def test_moments_are_split_channels_last() -> None:
    moments = torch.arange(2 * 4 * 3, dtype=torch.float32).reshape(2, 4, 3)  # (B, 2d, T_z), d = 2
    q = DiagonalGaussian.from_moments(moments)
    assert q.shape == (2, 3, 2)
    torch.testing.assert_close(q.mean[0, :, 0], moments[0, 0])
    torch.testing.assert_close(q.logvar[0, :, 1], moments[0, 3])
