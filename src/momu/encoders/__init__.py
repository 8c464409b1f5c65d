"""Built-in encoders; importing this package registers them in momu.registry.ENCODERS."""
