"""Built-in losses; importing this package registers them in momu.registry.LOSSES."""

from momu.losses import diffusion, gan, harmony, rhythmic_contrastive, scheduled_kinematic, vae  # noqa: F401
