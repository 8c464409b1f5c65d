"""Built-in losses; importing this package registers them in momu.registry.LOSSES."""

from momu.losses import diffusion  # noqa: F401
from momu.losses import gan, rhythmic_contrastive, vae  # noqa: F401
