"""Built-in encoders; importing this package registers them in momu.registry.ENCODERS."""

from momu.encoders import bicor_vae, directional_vector, discriminator, learnable_motion, mfcc, waveform  # noqa: F401
