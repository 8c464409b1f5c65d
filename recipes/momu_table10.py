"""MoMu-Diffusion Table 10 (cross-guidance step T_c = γT): ``accelerate launch recipes/momu_table10.py ...``.

Rows γ ∈ {0.9, 0.7, 0.5, 0.3, 0.1} are overrides over ``recipes/configs/momu.yaml`` (see
:func:`momu.methods.momu.recipes.table10_spec`); all rows share one trained model.
"""

from __future__ import annotations

import sys
from pathlib import Path

from momu.engine.table import run_table
from momu.methods.momu.recipes import table10_spec

if __name__ == "__main__":
    sys.exit(run_table(table10_spec(Path(__file__).resolve().parent / "configs" / "momu.yaml")))
