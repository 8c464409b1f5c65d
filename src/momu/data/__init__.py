"""Built-in datasets; importing this package registers them in momu.registry.DATASETS."""

from momu.data import (  # noqa: F401
    aistpp,
    ballroom,
    d2m,
    dance_with_melody,
    humanml3d,
    loris,
    synth,
)
