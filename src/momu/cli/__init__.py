"""The ``momu`` command. Each subcommand lives in its own module of this package.

A subcommand module defines ``add_parser(subparsers)``, which adds its parser and sets
``func`` (a callable taking the parsed arguments and returning an exit status).
"""

from __future__ import annotations

import argparse
import importlib
import logging
import os
import sys
from collections.abc import Sequence

from momu.config import ConfigError
from momu.errors import UsageError, UsageParser, fail
from momu.registry import PluginError, RegistryError

__all__ = ["main", "build_parser"]

# Modules providing subcommands, in the order `momu --help` lists them.
SUBCOMMAND_MODULES: tuple[str, ...] = (
    "momu.cli.parts",
    "momu.cli.config_cmd",
    "momu.cli.data_cmd",
    "momu.cli.eval_cmd",
    "momu.cli.extractor_cmd",
    "momu.cli.generate_cmd",
    "momu.cli.train_cmd",
)

USAGE_ERRORS = (ConfigError, UsageError, RegistryError, PluginError)


def build_parser() -> argparse.ArgumentParser:
    from momu import __version__

    parser = UsageParser(
        prog="momu", description="momu: music <-> motion generation (MoMu-Diffusion, MoFusion, HarmoGAN)."
    )
    parser.add_argument("--version", action="version", version=f"momu {__version__}")
    parser.add_argument("-v", "--verbose", action="count", default=0, help="more logging (-vv for debug)")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True
    for module in SUBCOMMAND_MODULES:
        importlib.import_module(module).add_parser(sub)
    return parser


def _openmp_for(argv: Sequence[str]) -> None:
    """``momu generate``: OpenMP threads that wait for each other sleep instead of spinning
    (``OMP_WAIT_POLICY=PASSIVE`` unless the environment sets it; read when torch loads OpenMP, so
    before any import of torch). Generation runs thousands of small parallel operations; on a machine
    whose cores are shared with other jobs a spinning thread that waits for a descheduled one burns its
    time slice: 4-5x slower generation of a 3-minute song with 2 threads at load average 3-4
    (benchmarks/results/bench_long_song_180s.json)."""
    command = next((a for a in argv if not a.startswith("-")), None)
    if command == "generate":
        os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")


def main(argv: Sequence[str] | None = None) -> int:
    """Run the ``momu`` command; returns the exit status (2 for usage and config errors, docs/errors.md)."""
    _openmp_for(list(sys.argv[1:] if argv is None else argv))
    parser = build_parser()
    # Subcommands that take free ``key=value`` overrides after their options (``momu train``) set
    # ``extra_overrides``; everything else is parsed strictly.
    args, extra = parser.parse_known_args(argv)
    if extra:
        if not hasattr(args, "extra_overrides"):
            parser.error(f"unrecognized arguments: {' '.join(extra)}")
        args.extra_overrides = list(extra)
    level = logging.WARNING - 10 * min(args.verbose, 2)
    logging.basicConfig(level=level, format="%(levelname)s %(name)s: %(message)s")
    action = getattr(args, "action", None)
    prog = " ".join(["momu", args.command, *([action] if action else [])])
    try:
        return int(args.func(args) or 0)
    except USAGE_ERRORS as exc:
        return fail(prog, exc)
    except KeyboardInterrupt:  # Ctrl-C: one line, the shell's status for SIGINT (docs/errors.md)
        sys.stderr.write(f"{prog}: interrupted (Ctrl-C)\n")
        return 130
