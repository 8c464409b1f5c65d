"""Built-in encoders; importing this package registers them in momu.registry.ENCODERS."""

from momu.encoders import (  # noqa: F401
    bicor_vae,
    clip_text,
    directional_vector,
    discriminator,
    harmogan_discriminators,
    harmogan_generator,
    learnable_motion,
    mfcc,
    rhythm,
    text_transformer,
    waveform,
)
