"""Built-in datasets; importing this package registers them in momu.registry.DATASETS."""
