"""Built-in metrics; importing this package registers them in momu.registry.METRICS."""
