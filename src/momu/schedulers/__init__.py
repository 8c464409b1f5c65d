"""Built-in schedulers; importing this package registers them in momu.registry.SCHEDULERS."""

from momu.schedulers import diffusers_schedulers  # noqa: F401
