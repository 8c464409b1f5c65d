"""HarmoGAN Fig. 12 recipe (harmony score and hit rate on the Dance data).

``accelerate launch recipes/harmogan_fig12.py [--preset smoke|cpu|paper] [--data DANCE_WITH_MELODY_DIR] ...``

Rows, presets and columns: :func:`momu.methods.harmogan.recipes.fig12_spec`; ``--help`` lists the options.
"""

from __future__ import annotations

import sys
from pathlib import Path

from momu.methods.harmogan.recipes import fig12_spec, run_harmogan

if __name__ == "__main__":
    sys.exit(run_harmogan(fig12_spec(Path(__file__).resolve().parent / "configs" / "harmogan.yaml")))
