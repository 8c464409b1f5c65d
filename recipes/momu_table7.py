"""MoMu-Diffusion Table 7 (ablations).

``accelerate launch recipes/momu_table7.py [--preset smoke|cpu|paper] ...``.

Rows #1–#7 are overrides over ``recipes/configs/momu.yaml`` (see
:func:`momu.methods.momu.recipes.table7_spec`); ``--help`` lists the options.
"""

from __future__ import annotations

import sys
from pathlib import Path

from momu.engine.table import run_table
from momu.methods.momu.recipes import table7_spec

if __name__ == "__main__":
    sys.exit(run_table(table7_spec(Path(__file__).resolve().parent / "configs" / "momu.yaml")))
