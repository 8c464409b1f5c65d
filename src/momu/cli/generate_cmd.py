"""``momu generate``: dance for your song, music for your dance, motion for a caption.

    momu generate dance --music song.mp3 --out out/            # out/dance.mp4, dance.bvh, dance.npz
    momu generate dance --music song.wav --out dance.bvh       # one file; its suffix picks the format
    momu generate music --motion dance.bvh --out out/          # out/music.wav, music.mp4
    momu generate joint --seconds 12 --out out/                # both at once (cross guidance)
    momu generate text --caption "a person jumps" --model M --out out/   # out/motion.mp4, .bvh, .npz
    momu generate forecast --motion seed.bvh --music song.wav --model M --out out/  # MoFusion §4.4
    momu generate inbetween --motion d.bvh --keyframes 0,2,end --music song.wav --model M --out out/
    momu generate edit --motion m.npz --caption "a person waves" --time 1:3 --model T --out out/

``--model DIR`` is a folder written by ``momu train`` (or a recipe: ``<out>/<table>/models/momu-*``);
without it the MoMu model shipped with momu is used. The folder's record says its method: MoMu
(``momu.json``: dance, music, joint), MoFusion (``mofusion.json``: ``dance`` for a music model,
``text`` for a text model, ``forecast`` / ``inbetween`` for either, ``edit`` for a text model) or
HarmoGAN (``harmogan.json``: ``dance``); the other methods run through :mod:`momu.cli.generate_methods`,
MoFusion's inpainting tasks through :mod:`momu.cli.generate_inpaint`. MoMu generates songs and dances
of any length (up to 10 minutes) in overlapping windows stitched by inpainting (:mod:`momu.generation`).
Everything that can be checked without the model — the input file, the output path (writable, names
not too long, space for the outputs), the model folder's record, what its method can generate, whether
the motion's skeleton converts to the model's — is checked first; a problem prints one line
``momu generate: error: ...`` and exits with status 2. The outputs are written together at the end
(:mod:`momu.cli.generate_write`); a failure there (a full disk) prints one line and exits with status 1,
SIGTERM exits with 143, and neither leaves anything behind. The command ends with one line on stdout
naming the files it wrote.
"""

from __future__ import annotations

import argparse
import logging
import sys
from pathlib import Path
from typing import Any

import numpy as np

from momu.cli import generate_inpaint
from momu.cli.generate_args import add_common, add_motion, formats, need_3d, provenance, record_for
from momu.cli.generate_errors import GenerateOutputError
from momu.cli.generate_io import (
    GenerateInputError,
    ModelRecord,
    check_seconds,
    read_song,
    resolve_outputs,
    song_warnings,
)
from momu.cli.generate_methods import generate_method_dance, generate_text, text_seconds
from momu.cli.generate_motion import motion_warnings, read_motion, to_skeleton
from momu.cli.generate_progress import info_logging, progress
from momu.cli.generate_write import (
    DANCE_FORMATS,
    MUSIC_FORMATS,
    check_space,
    write_dance_outputs,
    write_joint_outputs,
    write_music_outputs,
)
from momu.cli.interrupts import Terminated, exit_on_sigterm
from momu.data.common import AUDIO_SUFFIXES
from momu.errors import EXIT_PREEMPTED, EXIT_PROBLEMS, EXIT_USAGE

log = logging.getLogger(__name__)

JOINT_FORMATS = ("wav", "npz", "bvh", "mp4")


def add_parser(sub: Any) -> None:
    p = sub.add_parser("generate", help="dance for your music, music for your dance, motion for a caption")
    what = p.add_subparsers(dest="what", metavar="WHAT")
    what.required = True
    d = what.add_parser("dance", help="dance for a song: mp4 (with the song), BVH, npz")
    d.add_argument(
        "--music",
        type=Path,
        required=True,
        help=f"the song: {', '.join(s.lstrip('.') for s in AUDIO_SUFFIXES)}, or anything ffmpeg decodes",
    )
    add_common(d, DANCE_FORMATS, "use only the first SECONDS of the song")
    d.set_defaults(func=run, direction="dance")
    m = what.add_parser("music", help="music for a dance: wav (+ mp4 of the dance with it)")
    add_motion(m, "the dance")
    add_common(m, MUSIC_FORMATS, "use only the first SECONDS of the motion")
    m.add_argument(
        "--beats-per-movement",
        default="auto",
        metavar="N|ballroom|auto",
        help="music beats per movement of the dance (1: the music's beat is the dance's period; 3 for a "
        "waltz danced once per bar, 2 for a Latin dance that moves once per half bar; ballroom: 3 or 2 "
        "read from how often the feet move per body movement; default auto: 3 for a dance that moves "
        "once per waltz bar, else 1)",
    )
    m.set_defaults(func=run, direction="music")
    j = what.add_parser("joint", help="music and dance together (cross guidance, MoMu Alg. 2)")
    add_common(j, JOINT_FORMATS, "length in seconds (default 10)")
    j.set_defaults(func=run, direction="joint")
    t = what.add_parser("text", help="motion for a caption (a MoFusion text model): mp4 (silent), BVH, npz")
    t.add_argument("--caption", required=True, help='what the person does, e.g. "a person walks forward"')
    add_common(
        t,
        DANCE_FORMATS,
        "length in seconds (default: 4, or the model's training window if shorter)",
        model_help="a MoFusion text model folder (mofusion.json, task text); required",
    )
    t.set_defaults(func=run, direction="text")
    generate_inpaint.add_parsers(what, run)


def run(args: argparse.Namespace) -> int:
    """Run ``momu generate WHAT``; bad inputs print one line and return 2, a failed write 1, SIGTERM 143."""
    try:
        with exit_on_sigterm(), info_logging(args.quiet):
            if args.guidance is not None and not np.isfinite(args.guidance):
                raise GenerateInputError(f"--guidance must be a finite number, got {args.guidance}")
            if not np.isfinite(args.video_fps) or args.video_fps <= 0:
                raise GenerateInputError(f"--video-fps must be > 0, got {args.video_fps}")
            written = {
                "dance": _dance,
                "music": _music,
                "joint": _joint,
                "text": _text,
                "forecast": generate_inpaint.forecast,
                "inbetween": generate_inpaint.inbetween,
                "edit": generate_inpaint.edit,
            }[args.direction](args)
    except (GenerateInputError, FileNotFoundError) as exc:
        sys.stderr.write(f"momu generate: error: {exc}\n")
        return EXIT_USAGE
    except GenerateOutputError as exc:
        sys.stderr.write(f"momu generate: error: {exc}\n")
        return EXIT_PROBLEMS
    except Terminated as exc:
        sys.stderr.write(f"momu generate: stopped by {exc.signal_name}; nothing was written\n")
        return EXIT_PREEMPTED
    sys.stdout.write(f"momu generate {args.direction}: wrote {', '.join(map(str, written))}\n")
    return 0


def _load(record: ModelRecord) -> Any:
    from momu.methods.momu import MoMuModel

    try:
        return MoMuModel.load(record.folder)
    except (OSError, ValueError, KeyError) as exc:
        raise GenerateInputError(f"--model {record.folder}: cannot load: {exc}") from None


def _dance(args: argparse.Namespace) -> list[Path]:
    outputs = resolve_outputs(args.out, formats(args.format), DANCE_FORMATS, "dance")
    song = read_song(args.music, args.seconds)
    song_warnings(song)
    record = record_for(args, "dance")
    need_3d(outputs, record)
    check_space(outputs, song.duration)
    log.info(
        "dance for %s: %.1f s, %d Hz, %d channel(s)",
        song.path,
        song.duration,
        song.sample_rate,
        song.channels,
    )
    if record.method != "momu":
        motion, fps = generate_method_dance(record, song, args.seed)
        skeleton = record.skeleton
    else:
        from momu.generation.momu_long import music_to_motion_long, plan_for_seconds  # after the checks

        model = _load(record)
        plan = plan_for_seconds(model, song.duration, "motion")
        with progress(len(plan.starts), "generating the dance", "window", args.quiet) as update:
            (motion,) = music_to_motion_long(
                model,
                [song.audio],
                song.sample_rate,
                [args.seed],
                guidance_scale=args.guidance,
                progress=update,
            )
        fps, skeleton = model.rates.motion_fps, model.skeleton
    return write_dance_outputs(
        outputs,
        motion,
        fps,
        skeleton,
        song.track,
        song.sample_rate,
        provenance(args, record, args.music),
        video_fps=args.video_fps,
        quiet=args.quiet,
    )


def _music(args: argparse.Namespace) -> list[Path]:
    from momu.features.convert import stand_on_floor
    from momu.features.skeletons import get_skeleton

    outputs = resolve_outputs(args.out, formats(args.format), MUSIC_FORMATS, "music")
    from momu.features.ballroom_metre import parse_beats_per_movement

    try:
        beats = parse_beats_per_movement(args.beats_per_movement)
    except ValueError as exc:
        raise GenerateInputError(str(exc)) from None
    given = read_motion(args.motion, args.skeleton, args.fps, args.seconds)
    motion, trajectory = given.motion, given.trajectory
    motion_warnings(given, args.motion)
    record = record_for(args, "music")
    # the whole path in space (root-centred files carry it apart), on the floor and centred like the
    # training data; 3D -> 2D conversion projects it with the synthetic data's camera
    model_input = to_skeleton(given, args.motion, record)
    if get_skeleton(record.skeleton).dims == 3:
        model_input = stand_on_floor(model_input, get_skeleton(record.skeleton).root).astype(np.float32)
    check_space(outputs, motion.shape[0] / given.fps)
    log.info("music for %s: %.1f s at %g fps", args.motion, motion.shape[0] / given.fps, given.fps)
    from momu.generation.momu_long import motion_to_music_long, plan_for_seconds  # after the checks

    model = _load(record)
    if beats == "auto" and not model.conditions.reads_dance_beats:
        beats = 1  # a music conditioned on the dance's latent alone: nothing to split
    if beats in ("ballroom", "auto"):
        from momu.features.ballroom_metre import read_beats

        beats, said = read_beats(beats, model_input, given.fps, record.skeleton)
        log.info("%s", said)
    if beats != 1:
        try:
            model.use_beats_per_movement(beats)
        except ValueError as exc:
            raise GenerateInputError(f"--beats-per-movement: --model {record.folder}: {exc}") from None
    plan = plan_for_seconds(model, motion.shape[0] / given.fps, "music")
    with progress(len(plan.starts), "generating the music", "window", args.quiet) as update:
        (audio,) = motion_to_music_long(
            model, [model_input], given.fps, [args.seed], guidance_scale=args.guidance, progress=update
        )
    shown = motion if trajectory is None else motion + trajectory[:, None, :]
    return write_music_outputs(
        outputs,
        audio,
        model.rates.sample_rate,
        shown,
        given.fps,
        given.skeleton,
        video_fps=args.video_fps,
        quiet=args.quiet,
    )


def _joint(args: argparse.Namespace) -> list[Path]:
    outputs = resolve_outputs(args.out, formats(args.format), JOINT_FORMATS, "joint")
    seconds = 10.0 if args.seconds is None else float(check_seconds(args.seconds) or 0.0)
    record = record_for(args, "dance")
    need_3d(outputs, record)
    check_space(outputs, seconds)
    log.info("music and dance together: %.1f s", seconds)
    model = _load(record)
    try:
        ((audio, motion),) = model.joint([seconds], [args.seed])
    except ValueError as exc:  # e.g. longer than the denoiser's max_length
        raise GenerateInputError(f"--seconds {seconds}: {exc}") from None
    return write_joint_outputs(
        outputs,
        audio,
        model.rates.sample_rate,
        motion,
        model.rates.motion_fps,
        model.skeleton,
        provenance(args, record, None),
        video_fps=args.video_fps,
        quiet=args.quiet,
    )


def _text(args: argparse.Namespace) -> list[Path]:
    caption = " ".join(str(args.caption).split())
    if not caption:
        raise GenerateInputError('--caption is empty; describe the motion, e.g. "a person walks forward"')
    outputs = resolve_outputs(args.out, formats(args.format), DANCE_FORMATS, "motion")
    record = record_for(args, "text")
    need_3d(outputs, record)
    seconds = text_seconds(record, args.seconds)
    check_space(outputs, seconds)
    motion, fps = generate_text(record, caption, seconds, args.seed)
    prov = {**provenance(args, record, None), "caption": caption, "seconds": seconds}
    return write_dance_outputs(
        outputs,
        motion,
        fps,
        record.skeleton,
        None,
        None,
        prov,
        video_fps=args.video_fps,
        title="momu text",
        quiet=args.quiet,
    )
