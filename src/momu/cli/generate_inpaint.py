"""``momu generate forecast | inbetween | edit``: MoFusion's inpainting tasks from the command line.

    momu generate forecast --model M --motion seed.bvh --music song.wav --out out/          # 2 s seed
    momu generate forecast --model T --motion seed.npz --caption "a person jumps" --seconds 6 --out out/
    momu generate inbetween --model M --motion dance.bvh --keyframes 0,2,4,end --music song.wav --out out/
    momu generate edit --model T --motion walk.npz --caption "a person waves" --time 1:3 \\
        --joints r_shoulder+ --out out/

All three run :class:`~momu.methods.mofusion.MoFusionModel`'s inpainting sampler (MoFusion §4.4: known
frames are replaced by their forward-diffused values before every denoising step) over the given
motion, converted to the model's skeleton and frame rate (its record says them: 20 fps, §4.4):

* **forecast** (§4.4, supp. Table 2): the first ``--seed-seconds`` (default 2 s = S = 40 frames) are
  the given motion; the rest, up to ``--seconds``, is generated for the song or the caption;
* **inbetween** (§4.4): the ``--keyframes`` are kept; the frames between them are generated;
* **edit** (text-based editing, named in the MoFusion abstract only — *not evaluated by the paper*):
  the ``--time`` × ``--joints`` region is regenerated with a new caption; everything else is kept
  (a MoFusion text model only).

What is kept is the converted input itself, bit for bit (:func:`~momu.cli.generate_motion.keep_given`).
The model sees the motion moved onto the floor and centred (:func:`momu.features.convert.floor_offset`),
like ``generate music``; the result is moved back to the input's place. Every check — the files, the
model folder's record and task, the condition (``--music`` for a music model, ``--caption`` for a text
model), the keyframe / time / joint specs and the lengths — comes before the model is loaded, and a
failure is one line and exit status 2 (:mod:`momu.cli.generate_cmd`).
"""

from __future__ import annotations

import argparse
import logging
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from momu.cli.generate_args import add_common, add_motion, formats, need_3d, provenance, record_for
from momu.cli.generate_io import (
    GenerateInputError,
    ModelRecord,
    Song,
    file_sha256,
    read_song,
    resolve_outputs,
    song_warnings,
)
from momu.cli.generate_methods import check_length, describe, load_method_model, text_seconds
from momu.cli.generate_motion import keep_given, model_rate_motion, read_motion
from momu.cli.generate_specs import edit_region, parse_keyframes
from momu.cli.generate_write import DANCE_FORMATS, check_space, write_dance_outputs

__all__ = ["add_parsers", "forecast", "inbetween", "edit", "SEED_SECONDS"]

log = logging.getLogger(__name__)

SEED_SECONDS = 2.0
"""Forecasting's seed (MoFusion §4.4: S = 40 frames = 2 s at 20 fps)."""


_MODEL_HELP = "a MoFusion model folder (mofusion.json; MoFusion table runs save them under models/); required"


def _condition_args(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--music",
        type=Path,
        metavar="SONG",
        help="the song (a MoFusion music model), as for `generate dance`",
    )
    p.add_argument(
        "--caption",
        metavar="TEXT",
        help='what the person does (a MoFusion text model), e.g. "a person jumps"',
    )


def add_parsers(what: Any, run: Callable[[argparse.Namespace], int]) -> None:
    """``forecast``, ``inbetween`` and ``edit`` under ``momu generate``; ``run`` dispatches them."""
    f = what.add_parser(
        "forecast", help="continue a motion from its first seconds (MoFusion §4.4): mp4, BVH, npz"
    )
    add_motion(f, "the seed motion (its first --seed-seconds are kept)")
    _condition_args(f)
    f.add_argument(
        "--seed-seconds",
        type=float,
        default=SEED_SECONDS,
        help=f"seconds of the motion kept as the seed (default {SEED_SECONDS:g}: MoFusion §4.4's 40 frames)",
    )
    add_common(
        f,
        DANCE_FORMATS,
        "length of the result, seed included (default: the song's; with a caption 4 s, or the model's "
        "training window if shorter)",
        guidance=False,
        model_help=_MODEL_HELP,
    )
    f.set_defaults(func=run, direction="forecast")
    b = what.add_parser("inbetween", help="fill in a motion between keyframes (MoFusion §4.4): mp4, BVH, npz")
    add_motion(b, "the motion whose keyframes are kept")
    b.add_argument(
        "--keyframes",
        required=True,
        metavar="SPEC",
        help="times in seconds, 'end', or 'every:STEP' (comma-separated), e.g. 0,1.5,3,end or every:1",
    )
    _condition_args(b)
    add_common(
        b, DANCE_FORMATS, "use only the first SECONDS of the motion", guidance=False, model_help=_MODEL_HELP
    )
    b.set_defaults(func=run, direction="inbetween")
    e = what.add_parser(
        "edit",
        help="regenerate part of a motion for a new caption (text model; not evaluated by the paper)",
    )
    add_motion(e, "the motion to edit (kept outside --time × --joints)")
    e.add_argument(
        "--caption", metavar="TEXT", help='the new caption of the edited part, e.g. "a person waves"'
    )
    e.add_argument(
        "--time", metavar="A:B", help="START:END seconds to regenerate (comma-separated; default: all of it)"
    )
    e.add_argument(
        "--joints",
        metavar="NAMES",
        help="joints to regenerate, e.g. l_elbow,l_wrist or r_shoulder+ (and below it; default: all)",
    )
    add_common(
        e, DANCE_FORMATS, "use only the first SECONDS of the motion", guidance=False, model_help=_MODEL_HELP
    )
    e.set_defaults(func=run, direction="edit", music=None)


# ---------------------------------------------------------------- checks (before any model loads)


def _caption(args: argparse.Namespace, record: ModelRecord) -> str | None:
    """The caption (whitespace-normalised) when the model is a text model; refuses the wrong condition."""
    caption = None if args.caption is None else " ".join(str(args.caption).split())
    if caption == "":
        raise GenerateInputError('--caption is empty; describe the motion, e.g. "a person walks forward"')
    where = f"--model {record.folder} is {describe(record)}"
    if record.task == "music":
        if caption is not None:
            raise GenerateInputError(f"--caption: {where}, conditioned on music; give --music SONG instead")
        if args.music is None:
            raise GenerateInputError(f"--music SONG is needed: {where}")
        return None
    if args.music is not None:
        raise GenerateInputError(f"--music: {where}, conditioned on text; give --caption TEXT instead")
    if caption is None:
        raise GenerateInputError(f"--caption TEXT is needed: {where}")
    return caption


def _covered(song: Song, frames: int, fps: float) -> Song:
    """``song`` if it is long enough for ``frames`` frames of motion (warnings logged)."""
    from momu.methods.mofusion.model import frames_seconds

    if song.duration < frames_seconds(frames, fps) - 1e-9:
        raise GenerateInputError(
            f"--music {song.path}: {song.duration:.2f} s of music for {frames / fps:.2f} s of motion; "
            "give a song at least as long as the motion"
        )
    song_warnings(song)
    return song


def _forecast_frames(args: argparse.Namespace, record: ModelRecord, fps: float) -> tuple[int, Song | None]:
    """The result's length in frames (seed included) and, for a music model, the song."""
    if record.task != "music":
        return int(round(text_seconds(record, args.seconds) * fps)), None
    song = read_song(args.music, args.seconds)
    if args.seconds is not None:
        frames = int(round(args.seconds * fps))
    else:
        frames = int(np.floor(song.duration * fps + 1e-6))
    check_length(record, frames / fps)
    return frames, _covered(song, frames, fps)


# ---------------------------------------------------------------- the three tasks


def _prepare(
    args: argparse.Namespace, seconds: float | None
) -> tuple[dict[str, Path], ModelRecord, str | None, np.ndarray, float]:
    """The checks every task makes: the outputs, the motion file (its first ``seconds``), the model
    folder's record and task, the condition; returns those and the motion at the model's skeleton and
    rate with that rate."""
    outputs = resolve_outputs(args.out, formats(args.format), DANCE_FORMATS, args.direction)
    given = read_motion(args.motion, args.skeleton, args.fps, seconds)
    record = record_for(args, args.direction)
    need_3d(outputs, record)
    caption = _caption(args, record)
    return outputs, record, caption, model_rate_motion(given, args.motion, record), float(record.fps or 0)


def forecast(args: argparse.Namespace) -> list[Path]:
    """``momu generate forecast``: keep the first ``--seed-seconds``, generate the rest (§4.4)."""
    from momu.methods.mofusion.model import MIN_FRAMES, frames_seconds

    if not np.isfinite(args.seed_seconds) or args.seed_seconds <= 0:
        raise GenerateInputError(f"--seed-seconds must be > 0, got {args.seed_seconds}")
    outputs, record, caption, motion, fps = _prepare(args, None)
    frames, song = _forecast_frames(args, record, fps)
    seed = int(round(args.seed_seconds * fps))
    if seed < 1:
        raise GenerateInputError(f"--seed-seconds {args.seed_seconds:g} is under one frame at {fps:g} fps")
    if motion.shape[0] < seed:
        raise GenerateInputError(
            f"--motion {args.motion}: {motion.shape[0] / fps:.2f} s of motion ({motion.shape[0]} frames at "
            f"{fps:g} fps) is shorter than the --seed-seconds {args.seed_seconds:g} seed ({seed} frames)"
        )
    if frames <= seed or frames < MIN_FRAMES:
        raise GenerateInputError(
            f"--seconds: {frames / fps:.2f} s leaves nothing to forecast after the --seed-seconds "
            f"{args.seed_seconds:g} seed (the result must be longer than the seed, and at least "
            f"{MIN_FRAMES} frames)"
        )
    if motion.shape[0] > seed:
        log.info(
            "%s: the first %d frames are the seed; the other %d are not used",
            args.motion,
            seed,
            len(motion) - seed,
        )
    keep = np.zeros((frames, motion.shape[1]), dtype=bool)
    keep[:seed] = True
    cond = caption if song is None else (song.audio, song.sample_rate)
    seconds, seed_seconds = frames_seconds(frames, fps), args.seed_seconds

    def generate(model: Any, x: np.ndarray) -> list[np.ndarray]:
        return model.forecast([x], [cond], [seconds], [args.seed], seed_seconds=seed_seconds)

    extra = {"seed_seconds": args.seed_seconds, "kept": {"seed_frames": seed}}
    return _inpaint(args, record, outputs, motion[:seed], keep, generate, song, caption, extra)


def inbetween(args: argparse.Namespace) -> list[Path]:
    """``momu generate inbetween``: keep the ``--keyframes``, generate the frames between (§4.4)."""
    outputs, record, caption, motion, fps = _prepare(args, args.seconds)
    frames = motion.shape[0]
    keys = parse_keyframes(args.keyframes, frames, fps)
    song = None if caption is not None else _covered(read_song(args.music, frames / fps), frames, fps)
    check_length(record, frames / fps)
    keep = np.zeros((frames, motion.shape[1]), dtype=bool)
    keep[keys] = True
    cond = caption if song is None else (song.audio, song.sample_rate)

    def generate(model: Any, x: np.ndarray) -> list[np.ndarray]:
        return model.inbetween([x], [keys], [cond], [args.seed])

    extra = {"keyframes": args.keyframes, "kept": {"keyframes": keys}}
    return _inpaint(args, record, outputs, motion, keep, generate, song, caption, extra)


def edit(args: argparse.Namespace) -> list[Path]:
    """``momu generate edit``: regenerate ``--time`` × ``--joints`` for a new caption (abstract only;
    not evaluated by the paper), keep the rest."""
    from momu.features.skeletons import get_skeleton

    outputs, record, caption, motion, fps = _prepare(args, args.seconds)
    region = edit_region(args.time, args.joints, motion.shape[0], fps, record.skeleton)
    check_length(record, motion.shape[0] / fps)
    names = get_skeleton(record.skeleton).joint_names
    rows = np.flatnonzero(region.any(axis=1))
    spans = [[int(s[0]), int(s[-1]) + 1] for s in np.split(rows, np.flatnonzero(np.diff(rows) > 1) + 1)]

    def generate(model: Any, x: np.ndarray) -> list[np.ndarray]:
        return model.edit([x], [region], [caption], [args.seed])

    extra = {
        "time": args.time,
        "joints": args.joints,
        "regenerated": {"frames": spans, "joints": [names[j] for j in np.flatnonzero(region.any(axis=0))]},
        "kept": {"everything_but": "regenerated"},
        "not_evaluated_by_the_paper": True,
    }
    return _inpaint(args, record, outputs, motion, ~region, generate, None, caption, extra)


# ---------------------------------------------------------------- generate, keep, write


def _inpaint(
    args: argparse.Namespace,
    record: ModelRecord,
    outputs: dict[str, Path],
    given: np.ndarray,
    keep: np.ndarray,
    generate: Callable[[Any, np.ndarray], list[np.ndarray]],
    song: Song | None,
    caption: str | None,
    extra: dict[str, Any],
) -> list[Path]:
    """Load the model, run ``generate(model, given on the floor)``, move the result back to ``given``'s
    place, write the kept part of ``given`` into it exactly, and write the outputs."""
    from momu.features.convert import floor_offset
    from momu.features.skeletons import get_skeleton

    root = get_skeleton(record.skeleton).root
    offset = floor_offset(given, root)
    check_space(outputs, keep.shape[0] / float(record.fps or 20.0))
    model = load_method_model(record)
    log.info("momu generate %s: %s, %d frames", args.direction, describe(record), keep.shape[0])
    try:
        (out,) = generate(model, given + offset)
    except ValueError as exc:
        raise GenerateInputError(f"--model {record.folder}: cannot generate: {exc}") from None
    full = np.zeros((keep.shape[0], *given.shape[1:]))
    full[: len(given)] = given
    motion = keep_given(np.asarray(out, dtype=np.float64) - offset, full, keep, root)
    prov = {**provenance(args, record, args.motion), **extra, "fps": float(model.fps), "frames": len(motion)}
    prov["kept"] = {
        **extra["kept"],
        "from": f"the input motion on {record.skeleton} at {float(model.fps):g} fps, copied exactly",
    }
    if caption is not None:
        prov["caption"] = caption
    if song is not None:
        prov["music"] = {"path": str(song.path), "sha256": file_sha256(song.path)}
    return write_dance_outputs(
        outputs,
        motion,
        float(model.fps),
        record.skeleton,
        None if song is None else song.track,
        None if song is None else song.sample_rate,
        prov,
        video_fps=args.video_fps,
        title=f"momu {args.direction}",
        rigid=False,  # the kept frames stay the input's, bit for bit
        quiet=args.quiet,
    )
