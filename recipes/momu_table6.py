"""MoMu-Diffusion Table 6: ``accelerate launch recipes/momu_table6.py [--preset smoke|cpu|paper] ...``.

Options: ``[--data synth|DIR] [--out DIR] [--rows ...] [--seeds ...] [--resume] [key=value ...]``.

See :func:`momu.methods.momu.tables.table6_spec` and docs/recipes_tables_2_6.md; ``--help`` lists the options.
"""

from __future__ import annotations

import sys
from pathlib import Path

from momu.engine.table import run_table
from momu.methods.momu.tables import table6_spec

if __name__ == "__main__":
    configs = Path(__file__).resolve().parent / "configs"
    sys.exit(run_table(table6_spec(configs / "momu.yaml", configs / "momu_tables.yaml")))
