"""Built-in schedulers; importing this package registers them in momu.registry.SCHEDULERS."""
