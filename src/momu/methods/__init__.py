"""Built-in methods; importing this package registers them in momu.registry.METHODS."""
