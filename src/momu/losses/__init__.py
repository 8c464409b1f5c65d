"""Built-in losses; importing this package registers them in momu.registry.LOSSES."""

from momu.losses import diffusion, gan, harmony, rhythmic_contrastive, vae  # noqa: F401
