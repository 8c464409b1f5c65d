"""``momu eval --gen DIR --gt DIR --metrics m1,m2 [--fps F] [--out FILE.json]``.

Evaluates a folder of generated motions (``.npy``, ``(T, J, D)``, or the ``.npz`` that ``momu
generate`` writes) and/or music (``.wav``/``.flac``/``.ogg``/``.opus``/``.mp3``) against a folder of
references, pairing files by stem (``a.npy`` ↔ ``a.npy``, ``a.wav`` ↔ ``a.wav``). A generated item
that lacks a modality takes it from its reference — the conditioning input: generated dances (motion
only) are scored against the reference music, generated music (``.wav`` only) against the reference
motion. A metric never scores a filled-in modality (``beat_scores`` of motion-only folders is an
error, not F1 = 1); generated and reference motion must share a skeleton and a frame rate (a
``.npz`` carries both; a ``<stem>.json`` beside a ``.npy`` may give them). Any registered metric
runs by name, plugins included; ``--set NAME.KEY=VALUE`` sets a metric parameter. Prints a table;
``--out`` writes JSON with the scores, each metric's provenance (source, config, specification), its
warnings and its errors.

Exit status: 0 every metric scored; 1 a metric failed (the others are still reported and
written); 2 a usage or input error (nothing computed, nothing written).
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

__all__ = ["add_parser"]


def add_parser(sub: Any) -> None:
    p = sub.add_parser(
        "eval",
        help="score generated motion/music folders against references with registered metrics",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("--gen", required=True, type=Path, help="folder of generated motions (.npy/.npz), audio")
    p.add_argument("--gt", required=True, type=Path, help="folder of reference motions (.npy/.npz), audio")
    p.add_argument(
        "--metrics", required=True, help="comma-separated registered metric names (momu list metrics)"
    )
    p.add_argument("--fps", type=float, default=60.0, help="motion frame rate in fps (default 60, AIST++)")
    p.add_argument("--skeleton", default=None, help="joint layout name (default: inferred from (J, D))")
    p.add_argument("--out", type=Path, default=None, help="write scores + provenance to this JSON file")
    p.add_argument(
        "--set",
        dest="params",
        action="append",
        default=[],
        metavar="METRIC.KEY=VALUE",
        help="metric parameter, e.g. bas.variant=mint (repeatable)",
    )
    p.set_defaults(func=_run)


def _run(args: argparse.Namespace) -> int:
    from momu.cli.eval_inputs import EvalInputError, collect_folder
    from momu.errors import UsageError

    for folder in (args.gen, args.gt):  # a missing folder answers before the metrics load (6 s)
        try:
            collect_folder(folder)
        except EvalInputError as exc:
            raise UsageError(str(exc)) from None
    from momu.cli.eval_run import run

    return run(args)
