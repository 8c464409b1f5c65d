"""MoMu-Diffusion Table 2: ``accelerate launch recipes/momu_table2.py [--preset smoke|cpu|paper] ...``.

Options: ``[--data synth|DIR] [--out DIR] [--rows ...] [--seeds ...] [--resume] [key=value ...]``.

See :func:`momu.methods.momu.tables.table2_spec` and docs/recipes_tables_2_6.md; ``--help`` lists the options.
"""

from __future__ import annotations

import sys
from pathlib import Path

from momu.engine.table import run_table
from momu.methods.momu.tables import table2_spec

if __name__ == "__main__":
    configs = Path(__file__).resolve().parent / "configs"
    sys.exit(run_table(table2_spec(configs / "momu.yaml", configs / "momu_tables.yaml")))
