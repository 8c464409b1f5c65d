"""Built-in encoders; importing this package registers them in momu.registry.ENCODERS."""
from momu.encoders import learnable_motion  # noqa: F401
from momu.encoders import mfcc  # noqa: F401
from momu.encoders import bicor_vae, directional_vector, discriminator, waveform  # noqa: F401
