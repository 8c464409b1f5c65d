"""``momu config show CONFIG.yaml [key=value ...]``: the resolved, validated config."""

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
    cfg = load_config(args.config, args.overrides)
    sys.stdout.write(OmegaConf.to_yaml(cfg))
    return 0
