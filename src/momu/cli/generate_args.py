"""``momu generate``: what every ``WHAT`` shares — the common options, the model folder's record (checked
against what was asked before anything is loaded), and the provenance written into the npz.

:mod:`momu.cli.generate_cmd` (dance, music, joint, text) and :mod:`momu.cli.generate_inpaint`
(MoFusion's forecast, inbetween, edit) both build on these.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from momu.cli.generate_io import (
    GenerateInputError,
    ModelRecord,
    default_model_dir,
    file_sha256,
    model_record,
)
from momu.cli.generate_methods import check_model

__all__ = ["formats", "add_common", "add_motion", "record_for", "need_3d", "provenance", "NO_DEFAULT_MODEL"]

NO_DEFAULT_MODEL = {
    "text": "momu ships no text model (train a MoFusion text model)",
    "forecast": "momu ships no MoFusion model (train one: the MoFusion tables save them under models/)",
    "inbetween": "momu ships no MoFusion model (train one: the MoFusion tables save them under models/)",
    "edit": "momu ships no MoFusion text model (train one: the MoFusion Table 2 saves it under models/)",
}
"""Why ``--model`` is needed for the ``WHAT`` s that have no shipped model."""


MODEL_HELP = "a model folder from `momu train`: MoMu, MoFusion or HarmoGAN (default: the shipped MoMu model)"


def formats(text: str | None) -> list[str] | None:
    """``--format mp4,BVH`` -> ``["mp4", "bvh"]`` (``None``: all)."""
    return None if text is None else [f.strip().lower().lstrip(".") for f in text.split(",") if f.strip()]


def add_common(
    p: argparse.ArgumentParser,
    allowed: tuple[str, ...],
    seconds_help: str,
    *,
    guidance: bool = True,
    model_help: str = MODEL_HELP,
) -> None:
    """``--out --format --model --seed [--guidance] --seconds --video-fps --quiet``."""
    p.add_argument(
        "--out",
        required=True,
        help=f"output folder (a trailing / always means one), or one file ending in "
        f"{', '.join('.' + f for f in allowed)}",
    )
    p.add_argument("--format", help=f"comma-separated subset of {','.join(allowed)} (default: all)")
    p.add_argument("--model", type=Path, metavar="DIR", help=model_help)
    p.add_argument("--seed", type=int, default=0, help="noise seed (same seed, same result)")
    if guidance:
        p.add_argument(
            "--guidance", type=float, help="classifier-free guidance scale s (MoMu Eq. 7; MoMu only)"
        )
    else:
        p.set_defaults(guidance=None)
    p.add_argument("--seconds", type=float, help=seconds_help)
    p.add_argument("--video-fps", type=float, default=25.0, help="frame rate of the mp4 (default 25)")
    p.add_argument("--quiet", action="store_true", help="no progress bar and no INFO lines")


def add_motion(p: argparse.ArgumentParser, what: str) -> None:
    """``--motion FILE --skeleton NAME --fps F`` (read by :func:`momu.cli.generate_motion.read_motion`)."""
    p.add_argument(
        "--motion",
        type=Path,
        required=True,
        metavar="FILE",
        help=f"{what}: BVH, npy, npz, or a Dance with Melody folder",
    )
    p.add_argument("--skeleton", help="the motion's skeleton when the file does not say (e.g. smpl24)")
    p.add_argument("--fps", type=float, help="the motion's frame rate when the file does not say")


def record_for(args: argparse.Namespace, direction: str) -> ModelRecord:
    """The ``--model`` folder's record (or the shipped model's); refused if it cannot do ``direction``."""
    from momu.training import find_model

    if args.model is None and direction in NO_DEFAULT_MODEL:
        raise GenerateInputError(f"--model DIR is needed: {NO_DEFAULT_MODEL[direction]}")
    try:
        folder = find_model(args.model) if args.model is not None else default_model_dir(direction)
    except ValueError as exc:  # ConfigError: several models in a training output
        raise GenerateInputError(f"--model {exc}") from None
    record = model_record(folder)
    check_model(record, args.direction, args)
    return record


def need_3d(outputs: dict[str, Path], record: ModelRecord) -> None:
    """A BVH needs a 3D model."""
    if "bvh" in outputs and record.dims != 3:
        raise GenerateInputError(
            f"--model {record.folder}: generates 2D keypoints ({record.skeleton}); BVH needs a 3D model "
            "(use --format mp4,npz, or a model trained on a 3D skeleton)"
        )


def provenance(args: argparse.Namespace, record: ModelRecord, source: Path | None) -> dict[str, Any]:
    """What the npz records: momu version, command, model and its provenance, seed, the input file."""
    from momu import __version__

    prov: dict[str, Any] = {
        "momu_version": __version__,
        "command": ["momu", *sys.argv[1:]] if sys.argv and "momu" in Path(sys.argv[0]).name else None,
        "direction": args.direction,
        "method": record.method,
        "model": str(record.folder),
        "model_provenance": record.provenance,
        "seed": args.seed,
        "guidance": args.guidance,
        "seconds": args.seconds,
    }
    if source is not None and source.is_file():
        prov["input"] = {"path": str(source), "sha256": file_sha256(source)}
    return prov
