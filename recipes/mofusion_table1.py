"""MoFusion table1 (see :func:`momu.methods.mofusion.tables.table1_spec`).

``accelerate launch recipes/mofusion_table1.py [--preset smoke|cpu|paper] ...``
(``--help`` lists the options).
"""

from __future__ import annotations

import sys

from momu.engine.table import run_table
from momu.methods.mofusion.tables import table1_spec

if __name__ == "__main__":
    sys.exit(run_table(table1_spec()))
