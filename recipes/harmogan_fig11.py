"""HarmoGAN Fig. 11 recipe (metric side of the user study).

``accelerate launch recipes/harmogan_fig11.py [--preset smoke|cpu|paper] [--data DANCE_WITH_MELODY_DIR] ...``

Rows, presets and columns: :func:`momu.methods.harmogan.recipes.fig11_spec`; ``--help`` lists the options.
"""

from __future__ import annotations

import sys
from pathlib import Path

from momu.methods.harmogan.recipes import fig11_spec, run_harmogan

if __name__ == "__main__":
    sys.exit(run_harmogan(fig11_spec(Path(__file__).resolve().parent / "configs" / "harmogan.yaml")))
