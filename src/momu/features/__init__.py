"""Audio and motion features shared by datasets, losses and metrics."""
