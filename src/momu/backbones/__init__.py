"""Built-in backbones; importing this package registers them in momu.registry.BACKBONES."""
