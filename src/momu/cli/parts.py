"""``momu list [KIND]``: every registered part with its source."""

from __future__ import annotations

import argparse
import sys
from typing import Any

from momu.registry import KINDS, registry_for


def add_parser(sub: Any) -> None:
    p = sub.add_parser("list", help="list registered parts and where they come from")
    p.add_argument("kind", nargs="?", choices=KINDS, help="only this kind")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    kinds = [args.kind] if args.kind else list(KINDS)
    lines: list[str] = []
    for kind in kinds:
        sources = registry_for(kind).sources()
        lines.append(f"{kind} ({len(sources)})")
        width = max((len(n) for n in sources), default=0)
        lines.extend(f"  {name:<{width}}  {source}" for name, source in sources.items())
    sys.stdout.write("\n".join(lines) + "\n")
    return 0
