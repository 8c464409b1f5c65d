"""Built-in methods; importing this package registers them in momu.registry.METHODS."""

from momu.methods import harmogan, mofusion, momu  # noqa: F401
