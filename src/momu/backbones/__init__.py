"""Built-in backbones; importing this package registers them in momu.registry.BACKBONES."""

from momu.backbones import dit, unet1d  # noqa: F401
