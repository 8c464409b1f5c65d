"""``momu data ACTION``: make, check and inspect datasets.

Each action lives in its own module listed in ``DATA_ACTION_MODULES``; a module defines
``add_action(actions)`` which adds its parser and sets ``func``.
"""

from __future__ import annotations

import importlib
from typing import Any

DATA_ACTION_MODULES: tuple[str, ...] = (
    "momu.cli.data_synth",
    "momu.cli.data_check",
)


def add_parser(sub: Any) -> None:
    p = sub.add_parser("data", help="make, check and inspect datasets")
    actions = p.add_subparsers(dest="action", metavar="ACTION")
    actions.required = True
    for module in DATA_ACTION_MODULES:
        importlib.import_module(module).add_action(actions)
