"""Built-in samplers; importing this package registers them in momu.registry.SAMPLERS."""

from momu.samplers import cfg, cross_guidance, inpainting  # noqa: F401
