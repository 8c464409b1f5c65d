"""``momu train METHOD``: train one method's models on a dataset, no table (:mod:`momu.training`).

    momu train momu --data synth --out runs/momu                       # synth_dance, the cpu preset
    momu train momu --data ../shared/data/dance_with_melody --out runs/dwm
    momu train momu --preset smoke --out /tmp/t method.train_diffusion.steps=10
    momu train momu --out runs/momu --resume                           # after SIGTERM / Ctrl-C / a kill

The result is ``<out>/models/<method>-<hash>/``: ``momu generate dance --model <out>`` uses it.
Exit status (docs/errors.md): 0 done, 2 a bad argument, key, value or data file (one line, nothing
written), 1 the disk filled or failed during training (one line naming the file; finished stages
are kept), 143 stopped by SIGTERM and 130 by Ctrl-C (one line; a stage in training wrote a
checkpoint first: rerun with ``--resume`` to continue from it).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from momu.cli.output_paths import OutputPathError, check_writable_output
from momu.config import ConfigError
from momu.errors import fail, one_line, stopped

__all__ = ["add_parser", "run"]


def add_parser(sub: Any) -> None:
    from momu.training import RECIPES

    p = sub.add_parser("train", help="train a method's models on a dataset (no table)")
    p.add_argument("method", choices=sorted(RECIPES), help="the method to train")
    p.add_argument("--data", default="synth", help="'synth' (synth_dance) or a dataset folder")
    p.add_argument("--dataset", help="registered loader for --data DIR (default: detected from the layout)")
    p.add_argument("--preset", default="cpu", help="smoke | cpu | paper (default cpu)")
    p.add_argument("--out", type=Path, required=True, help="output folder (parts/, models/, train.json)")
    p.add_argument("--seed", type=int, help="training seed (default: the config's)")
    p.add_argument(
        "--resume",
        action="store_true",
        help="continue a stage an interrupted run left half-trained from its last checkpoint under --out",
    )
    p.add_argument(
        "overrides", nargs="*", help="config overrides key=value (e.g. method.train_diffusion.steps=500)"
    )
    p.set_defaults(func=run, extra_overrides=[])


def run(args: argparse.Namespace) -> int:
    from momu.engine.signals import Interrupted, stop_on_signals
    from momu.engine.trainer import ResumeError
    from momu.training import train_method

    overrides = [*args.overrides, *args.extra_overrides]
    bad = [o for o in overrides if "=" not in o]
    if bad:
        sys.stderr.write(f"momu train: error: overrides must be key=value, got {bad}\n")
        return 2
    try:  # a read-only file system, a name too long, a file in the way: before any work
        check_writable_output(args.out, "--out")
    except OutputPathError as exc:
        return fail("momu train", exc)
    try:
        with stop_on_signals():
            result = train_method(
                args.method,
                args.out,
                data=args.data,
                dataset=args.dataset,
                preset=args.preset,
                overrides=overrides,
                seed=args.seed,
                resume=args.resume,
            )
    except (ConfigError, FileNotFoundError, ResumeError) as exc:
        return fail("momu train", exc)
    except Interrupted as exc:
        return stopped(f"momu train: {one_line(exc)}", exc.status)
    except OSError as exc:  # after the work began: a full disk, a failing device (writes are atomic)
        where = f"{exc.filename}: " if exc.filename else ""
        reason = exc.strerror or one_line(exc)
        return fail(
            "momu train",
            f"{where}{reason}; the stages finished so far are kept under --out: free space and rerun the "
            "same command (with --resume to continue a stage from its last checkpoint)",
            status=1,
        )
    sys.stdout.write(f"{result.model}\n")
    return 0
