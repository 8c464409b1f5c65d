"""MoFusion Table 2: text→motion (see :func:`momu.methods.mofusion.tables_text.table2_spec`).

``accelerate launch recipes/mofusion_table2.py [--preset smoke|cpu|paper] ...``
(``--help`` lists the options).
"""

from __future__ import annotations

import sys

from momu.engine.table import run_table
from momu.methods.mofusion.tables_text import table2_spec

if __name__ == "__main__":
    sys.exit(run_table(table2_spec()))
