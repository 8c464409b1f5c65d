"""HarmoGAN Fig. 9 recipe (motion quality of the GAN variants).

``accelerate launch recipes/harmogan_fig9.py [--preset smoke|cpu|paper] [--data DANCE_WITH_MELODY_DIR] ...``

Rows, presets and columns: :func:`momu.methods.harmogan.recipes.fig9_spec`; ``--help`` lists the options.
"""

from __future__ import annotations

import sys
from pathlib import Path

from momu.methods.harmogan.recipes import fig9_spec, run_harmogan

if __name__ == "__main__":
    sys.exit(run_harmogan(fig9_spec(Path(__file__).resolve().parent / "configs" / "harmogan.yaml")))
