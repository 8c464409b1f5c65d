"""Built-in losses; importing this package registers them in momu.registry.LOSSES."""
