"""Cross-method mixing: MoFusion's and HarmoGAN's parts on MoMu-Diffusion (issue 33 item 5).

``accelerate launch recipes/mixing.py [--preset smoke|cpu] [--out DIR] [--seeds 0 1 2] ...``.

Rows (overrides over ``recipes/configs/momu.yaml``; :func:`momu.methods.momu.mixing.mixing_spec`):
the MoMu baseline, + MoFusion's scheduled kinematic loss on decoded poses, + HarmoGAN's harmony loss
on decoded poses, + HarmoGAN's MFCC encoder as the music→motion condition. Scored by motion FID,
kinematic beat F1 and the music-following benchmark; every row is compared with the baseline.
The ``cpu`` preset trains a row in about 3 CPU-minutes; ``--help`` lists the options.
"""

from __future__ import annotations

import sys
from pathlib import Path

from momu.engine.table import run_table
from momu.methods.momu.mixing import mixing_spec

if __name__ == "__main__":
    sys.exit(run_table(mixing_spec(Path(__file__).resolve().parent / "configs" / "momu.yaml")))
