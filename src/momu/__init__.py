"""momu: music <-> motion generation as registered, swappable parts.

Importing ``momu`` is cheap: the registries load their built-in parts on first use and
third-party plugins only when asked for by name.
"""

from momu._numba_cache import isolate_rank_cache

isolate_rank_cache()  # before anything imports numba: ranks must not fill one kernel cache together

from momu.registry import (  # noqa: E402
    BACKBONES,
    DATASETS,
    ENCODERS,
    LOSSES,
    METHODS,
    METRICS,
    REGISTRIES,
    SAMPLERS,
    SCHEDULERS,
    VOCODERS,
)

__version__ = "0.1.0"

__all__ = [
    "BACKBONES",
    "DATASETS",
    "ENCODERS",
    "LOSSES",
    "METHODS",
    "METRICS",
    "REGISTRIES",
    "SAMPLERS",
    "SCHEDULERS",
    "VOCODERS",
    "__version__",
]
