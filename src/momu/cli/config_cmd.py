"""``momu config show CONFIG.yaml [key=value ...]``: the resolved, validated config.

Every key is checked: component nodes against their part's dataclass, everything else against
:class:`~momu.config.schema.RecipeConfig` (a typo such as ``sed=3`` is an error naming the valid keys).
"""

from __future__ import annotations

import argparse
import sys
from typing import Any

from omegaconf import OmegaConf

from momu.config import load_config


def add_parser(sub: Any) -> None:
    p = sub.add_parser("config", help="inspect configs")
    actions = p.add_subparsers(dest="action", metavar="ACTION")
    actions.required = True
    show = actions.add_parser("show", help="print the resolved, validated config")
    show.add_argument("config", help="a YAML config file")
    show.add_argument("overrides", nargs="*", metavar="key=value", help="dotlist overrides")
    show.set_defaults(func=run_show)


def run_show(args: argparse.Namespace) -> int:
    from momu.config.schema import RecipeConfig

    cfg = load_config(args.config, args.overrides, schema=RecipeConfig, fill_defaults=False)
    sys.stdout.write(OmegaConf.to_yaml(cfg))
    return 0
