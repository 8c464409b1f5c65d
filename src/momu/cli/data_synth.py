"""``momu data synth --out DIR [...]``: write the built-in ``synth_dance`` dataset to disk.

Writes ``DIR/manifest.json``, ``DIR/audio/<id>.wav`` and ``DIR/motion/<id>.npy`` (see
:mod:`momu.data.synth.store`); the same options and seed always give byte-identical files. At most
``MAX_CLIPS`` clips, and only when the disk has room for the dataset's estimated size. Read
the copy back with the ``synth_dance`` dataset's ``root=DIR`` option or
:func:`momu.data.synth.load_written`.
"""

from __future__ import annotations

import argparse
import sys
from typing import Any

from tqdm import tqdm

from momu.data.synth import STYLE_NAMES, SynthConfig, write_dataset
from momu.data.synth.dataset import validate_config
from momu.data.synth.store import MAX_CLIPS, check_room
from momu.errors import EXIT_PROBLEMS, UsageError, fail
from momu.features.skeletons import SKELETON_NAMES
from momu.io import FolderBusyError, check_output_dir

__all__ = ["add_action", "config_from_args", "run"]


def add_action(actions: Any) -> None:
    """Add the ``synth`` action to the ``momu data`` sub-parsers."""
    d = SynthConfig()
    p = actions.add_parser(
        "synth",
        help="write the synthetic paired music/dance dataset (synth_dance) to a folder",
        description=__doc__.split("\n\n")[0] if __doc__ else None,
    )
    p.add_argument("--out", required=True, metavar="DIR", help="output folder (created; must be empty)")
    p.add_argument(
        "--overwrite", action="store_true", help="replace a non-empty --out folder once the new copy is done"
    )
    p.add_argument(
        "--clips",
        type=int,
        default=d.num_clips,
        metavar="N",
        help=f"number of clips (%(default)s; at most {MAX_CLIPS:,}, and as many as the free space holds)",
    )
    p.add_argument(
        "--seconds",
        type=float,
        default=d.min_seconds,
        metavar="S",
        help="clip length in seconds (%(default)s)",
    )
    p.add_argument(
        "--max-seconds",
        type=float,
        default=None,
        metavar="S",
        help="draw each clip's length uniformly from [--seconds, --max-seconds]",
    )
    p.add_argument(
        "--skeleton", default=d.skeleton, choices=SKELETON_NAMES, help="joint layout (%(default)s)"
    )
    p.add_argument("--seed", type=int, default=d.seed, metavar="K", help="dataset seed (%(default)s)")
    p.add_argument(
        "--fps", type=float, default=None, metavar="F", help="motion frame rate (skeleton's default)"
    )
    p.add_argument(
        "--sample-rate", type=int, default=d.sample_rate, metavar="HZ", help="audio rate (%(default)s)"
    )
    p.add_argument(
        "--styles",
        nargs="+",
        default=list(d.styles),
        metavar="STYLE",
        help=f"styles among {', '.join(STYLE_NAMES)}",
    )
    p.add_argument(
        "--jitter",
        type=float,
        default=d.phase_jitter,
        metavar="SEC",
        help="motion-beat timing jitter, s (%(default)s)",
    )
    p.add_argument(
        "--motion-noise",
        type=float,
        default=d.motion_noise,
        metavar="RAD",
        help="joint-angle noise (%(default)s)",
    )
    p.add_argument(
        "--root-centred", action="store_true", help="store root-relative motion + trajectory (3D only)"
    )
    p.add_argument("--float-wav", action="store_true", help="write 32-bit float wavs instead of 16-bit PCM")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.set_defaults(func=run)


def config_from_args(args: argparse.Namespace) -> SynthConfig:
    """The :class:`SynthConfig` the parsed options describe (not yet validated)."""
    return SynthConfig(
        num_clips=args.clips,
        min_seconds=args.seconds,
        max_seconds=args.max_seconds if args.max_seconds is not None else args.seconds,
        fps=args.fps,
        sample_rate=args.sample_rate,
        skeleton=args.skeleton,
        styles=list(args.styles),
        seed=args.seed,
        phase_jitter=args.jitter,
        motion_noise=args.motion_noise,
        root_centred=args.root_centred,
    )


def run(args: argparse.Namespace) -> int:
    """Write the dataset; exit status 0, 2 with a one-line error for invalid options, ``--out``, more
    than ``MAX_CLIPS`` clips or not enough free space (nothing written), 1 when the disk fails or fills
    up while writing (the old folder, or none, is left)."""
    cfg = config_from_args(args)
    subtype = "FLOAT" if args.float_wav else "PCM_16"
    try:
        validate_config(cfg)
        check_output_dir(args.out, "--out")
        check_room(args.out, cfg, subtype, what="--clips")
    except ValueError as exc:
        raise UsageError(str(exc)) from None
    total = cfg.num_clips
    try:
        with tqdm(total=total, desc="synth_dance", unit="clip", disable=args.no_progress) as bar:
            out = write_dataset(
                args.out,
                cfg,
                subtype=subtype,
                progress=bar.update,
                overwrite=args.overwrite,
            )
    except (FileExistsError, NotADirectoryError, FolderBusyError) as exc:
        raise UsageError(f"--out {exc}") from None
    except OSError as exc:  # a disk that fills up or goes away while writing
        return fail("momu data synth", f"cannot write {args.out}: {exc.strerror or exc}", EXIT_PROBLEMS)
    sys.stdout.write(f"wrote {total} clips ({cfg.skeleton}, {cfg.sample_rate} Hz) to {out}\n")
    return 0
