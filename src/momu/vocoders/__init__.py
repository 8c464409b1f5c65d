"""Built-in vocoders; importing this package registers them in momu.registry.VOCODERS."""
