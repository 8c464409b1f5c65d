"""Built-in vocoders; importing this package registers them in momu.registry.VOCODERS."""

from momu.vocoders import bigvgan, griffin_lim  # noqa: F401
