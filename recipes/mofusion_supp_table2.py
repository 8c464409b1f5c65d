"""MoFusion supp table2 (see :func:`momu.methods.mofusion.tables.supp_table2_spec`).

``accelerate launch recipes/mofusion_supp_table2.py [--preset smoke|cpu|paper] ...``
(``--help`` lists the options).
"""

from __future__ import annotations

import sys

from momu.engine.table import run_table
from momu.methods.mofusion.tables import supp_table2_spec

if __name__ == "__main__":
    sys.exit(run_table(supp_table2_spec()))
