"""HarmoGAN Table II recipe (hit rate per dance genre).

``accelerate launch recipes/harmogan_table2.py [--preset smoke|cpu|paper] [--data DANCE_WITH_MELODY_DIR] ...``

Rows, presets and columns: :func:`momu.methods.harmogan.recipes.table2_spec`; ``--help`` lists the options.
"""

from __future__ import annotations

import sys
from pathlib import Path

from momu.methods.harmogan.recipes import run_harmogan, table2_spec

if __name__ == "__main__":
    sys.exit(run_harmogan(table2_spec(Path(__file__).resolve().parent / "configs" / "harmogan.yaml")))
