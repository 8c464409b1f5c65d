"""HarmoGAN Table I recipe (harmony score h per dance genre).

``accelerate launch recipes/harmogan_table1.py [--preset smoke|cpu|paper] [--data DANCE_WITH_MELODY_DIR] ...``

Rows, presets and columns: :func:`momu.methods.harmogan.recipes.table1_spec`; ``--help`` lists the options.
"""

from __future__ import annotations

import sys
from pathlib import Path

from momu.methods.harmogan.recipes import run_harmogan, table1_spec

if __name__ == "__main__":
    sys.exit(run_harmogan(table1_spec(Path(__file__).resolve().parent / "configs" / "harmogan.yaml")))
