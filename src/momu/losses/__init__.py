"""Built-in losses; importing this package registers them in momu.registry.LOSSES."""

from momu.losses import diffusion, gan, rhythmic_contrastive, vae  # noqa: F401
