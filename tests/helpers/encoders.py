"""Encoder configurations shared by the encoder and loss tests: small enough for a 2-core CPU."""

from __future__ import annotations

from momu.encoders.vae import VAE1dConfig


def tiny_vae_config() -> VAE1dConfig:
    """A two-level 1D VAE (MoMu App. A.1 layout) at toy width: 4 latent channels, widths 8 and 16,
    one residual block per level and one two-head attention layer; lengths halve once (factor 2)."""
    return VAE1dConfig(
        latent_channels=4,
        base_channels=8,
        channel_mult=[1, 2],
        num_res_blocks=1,
        attention_layers=1,
        attention_heads=2,
    )


TINY_VAE = tiny_vae_config()
