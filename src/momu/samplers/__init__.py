"""Built-in samplers; importing this package registers them in momu.registry.SAMPLERS."""
