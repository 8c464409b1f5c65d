"""``momu generate``: dance for your song, music for your dance, motion for a caption.

    momu generate dance --music song.mp3 --out out/            # out/dance.mp4, dance.bvh, dance.npz
    momu generate dance --music song.wav --out dance.bvh       # one file; its suffix picks the format
    momu generate music --motion dance.bvh --out out/          # out/music.wav, music.mp4
    momu generate joint --seconds 12 --out out/                # both at once (cross guidance)
    momu generate text --caption "a person jumps" --model M --out out/   # out/motion.mp4, .bvh, .npz

``--model DIR`` is a folder written by ``momu train`` (or a recipe: ``<out>/<table>/models/momu-*``);
without it the MoMu model shipped with momu is used. The folder's record says its method: MoMu
(``momu.json``: dance, music, joint), MoFusion (``mofusion.json``: ``dance`` for a music model,
``text`` for a text model) or HarmoGAN (``harmogan.json``: ``dance``); the other methods run through
:mod:`momu.cli.generate_methods`. MoMu generates songs and dances of any length (up to 10 minutes) in
overlapping windows stitched by inpainting (:mod:`momu.generation`). Everything that can be checked
without the model — the input file, the output path, the model folder's record, what its method can
generate, whether the motion's skeleton converts to the model's — is checked first; a problem prints
one line ``momu generate: error: ...`` and exits with status 2.
"""

from __future__ import annotations

import argparse
import logging
import sys
from pathlib import Path
from typing import Any

import numpy as np

from momu.cli.generate_io import (
    GenerateInputError,
    ModelRecord,
    default_model_dir,
    file_sha256,
    model_record,
    read_song,
    resolve_outputs,
    song_warnings,
)
from momu.cli.generate_methods import (
    check_model,
    generate_method_dance,
    generate_text,
    text_seconds,
)
from momu.cli.generate_write import DANCE_FORMATS, MUSIC_FORMATS, write_dance_outputs, write_music_outputs
from momu.data.common import AUDIO_SUFFIXES

log = logging.getLogger(__name__)

JOINT_FORMATS = ("wav", "npz", "bvh", "mp4")


def _formats(text: str | None) -> list[str] | None:
    return None if text is None else [f.strip().lower().lstrip(".") for f in text.split(",") if f.strip()]


def _common(p: argparse.ArgumentParser, formats: tuple[str, ...], seconds_help: str) -> None:
    p.add_argument(
        "--out",
        type=Path,
        required=True,
        help=f"output folder, or one file ending in {', '.join('.' + f for f in formats)}",
    )
    p.add_argument("--format", help=f"comma-separated subset of {','.join(formats)} (default: all)")
    p.add_argument(
        "--model",
        type=Path,
        help="a model folder from `momu train`: MoMu, MoFusion or HarmoGAN (default: the shipped MoMu model)",
    )
    p.add_argument("--seed", type=int, default=0, help="noise seed (same seed, same result)")
    p.add_argument("--guidance", type=float, help="classifier-free guidance scale s (MoMu Eq. 7; MoMu only)")
    p.add_argument("--seconds", type=float, help=seconds_help)
    p.add_argument("--video-fps", type=float, default=25.0, help="frame rate of the mp4 (default 25)")
    p.add_argument("--quiet", action="store_true", help="no progress bar")


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
    _common(d, DANCE_FORMATS, "use only the first SECONDS of the song")
    d.set_defaults(func=run, direction="dance")
    m = what.add_parser("music", help="music for a dance: wav (+ mp4 of the dance with it)")
    m.add_argument("--motion", type=Path, required=True, help="BVH, npy, npz, or a Dance with Melody folder")
    m.add_argument("--skeleton", help="the motion's skeleton when the file does not say (e.g. smpl24)")
    m.add_argument("--fps", type=float, help="the motion's frame rate when the file does not say")
    _common(m, MUSIC_FORMATS, "use only the first SECONDS of the motion")
    m.set_defaults(func=run, direction="music")
    j = what.add_parser("joint", help="music and dance together (cross guidance, MoMu Alg. 2)")
    _common(j, JOINT_FORMATS, "length in seconds (default 10)")
    j.set_defaults(func=run, direction="joint")
    t = what.add_parser("text", help="motion for a caption (a MoFusion text model): mp4 (silent), BVH, npz")
    t.add_argument("--caption", required=True, help='what the person does, e.g. "a person walks forward"')
    _common(t, DANCE_FORMATS, "length in seconds (default: 4, or the model's training window if shorter)")
    t.set_defaults(func=run, direction="text")


def run(args: argparse.Namespace) -> int:
    """Run ``momu generate WHAT``; bad inputs print one line and return 2."""
    try:
        if args.guidance is not None and not np.isfinite(args.guidance):
            raise GenerateInputError(f"--guidance must be a finite number, got {args.guidance}")
        if not np.isfinite(args.video_fps) or args.video_fps <= 0:
            raise GenerateInputError(f"--video-fps must be > 0, got {args.video_fps}")
        return {"dance": _dance, "music": _music, "joint": _joint, "text": _text}[args.direction](args)
    except (GenerateInputError, FileNotFoundError) as exc:
        sys.stderr.write(f"momu generate: error: {exc}\n")
        return 2


def _record(args: argparse.Namespace, direction: str) -> ModelRecord:
    from momu.training import find_model

    if args.model is None and direction == "text":
        raise GenerateInputError(
            "--model DIR is needed: momu ships no text model (train a MoFusion text model)"
        )
    try:
        folder = find_model(args.model) if args.model is not None else default_model_dir(direction)
    except ValueError as exc:  # ConfigError: several models in a training output
        raise GenerateInputError(f"--model {exc}") from None
    record = model_record(folder)
    check_model(record, args.direction, args)
    return record


def _need_3d(outputs: dict[str, Path], record: ModelRecord) -> None:
    if "bvh" in outputs and record.dims != 3:
        raise GenerateInputError(
            f"--model {record.folder}: generates 2D keypoints ({record.skeleton}); BVH needs a 3D model "
            "(use --format mp4,npz, or a model trained on a 3D skeleton)"
        )


def _load(record: ModelRecord) -> Any:
    from momu.methods.momu import MoMuModel

    try:
        return MoMuModel.load(record.folder)
    except (OSError, ValueError, KeyError) as exc:
        raise GenerateInputError(f"--model {record.folder}: cannot load: {exc}") from None


def _progress(total: int, desc: str, quiet: bool) -> Any:
    from tqdm.auto import tqdm

    return tqdm(total=total, desc=desc, unit="window", disable=quiet or None, dynamic_ncols=True)


def _provenance(args: argparse.Namespace, record: ModelRecord, source: Path | None) -> dict[str, Any]:
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


def _dance(args: argparse.Namespace) -> int:
    from momu.generation.momu_long import music_to_motion_long, plan_for_seconds

    outputs = resolve_outputs(args.out, _formats(args.format), DANCE_FORMATS, "dance")
    song = read_song(args.music, args.seconds)
    song_warnings(song)
    record = _record(args, "dance")
    _need_3d(outputs, record)
    if record.method != "momu":
        motion, fps = generate_method_dance(record, song, args.seed)
        skeleton = record.skeleton
    else:
        model = _load(record)
        plan = plan_for_seconds(model, song.duration, "motion")
        with _progress(len(plan.starts), "dance", args.quiet) as bar:
            (motion,) = music_to_motion_long(
                model,
                [song.audio],
                song.sample_rate,
                [args.seed],
                guidance_scale=args.guidance,
                progress=bar.update,
            )
        fps, skeleton = model.rates.motion_fps, model.skeleton
    written = write_dance_outputs(
        outputs,
        motion,
        fps,
        skeleton,
        song.audio,
        song.sample_rate,
        _provenance(args, record, args.music),
        video_fps=args.video_fps,
    )
    log.info("momu generate dance: wrote %s", ", ".join(map(str, written)))
    return 0


def _music(args: argparse.Namespace) -> int:
    from momu.data.motion_files import read_motion_file
    from momu.features.convert import can_convert, convert_motion, stand_on_floor
    from momu.generation.momu_long import motion_to_music_long, plan_for_seconds

    outputs = resolve_outputs(args.out, _formats(args.format), MUSIC_FORMATS, "music")
    if args.seconds is not None and (not np.isfinite(args.seconds) or args.seconds <= 0):
        raise GenerateInputError(f"--seconds must be > 0, got {args.seconds}")
    try:
        given = read_motion_file(args.motion, skeleton=args.skeleton, fps=args.fps)
    except ValueError as exc:
        raise GenerateInputError(f"--motion {exc}") from None
    motion, trajectory = given.motion, given.trajectory
    if args.seconds is not None:
        keep = max(2, int(round(args.seconds * given.fps)))
        motion = motion[:keep]
        trajectory = None if trajectory is None else trajectory[:keep]
    record = _record(args, "music")
    if not can_convert(given.skeleton, record.skeleton):
        raise GenerateInputError(
            f"--motion {args.motion}: cannot convert skeleton {given.skeleton!r} to the model's "
            f"{record.skeleton!r} (2D keypoints have no depth for a 3D model)"
        )
    from momu.features.skeletons import get_skeleton

    # the whole path in space (root-centred files carry it apart), on the floor and centred like the
    # training data; 3D -> 2D conversion projects it with the synthetic data's camera
    model_input = convert_motion(motion, given.skeleton, record.skeleton, trajectory=trajectory)
    if get_skeleton(record.skeleton).dims == 3:
        model_input = stand_on_floor(model_input, get_skeleton(record.skeleton).root).astype(np.float32)
    if motion.shape[0] / given.fps < 2.0:
        log.warning(
            "%s: only %.2f s of motion; the music will be very short",
            args.motion,
            motion.shape[0] / given.fps,
        )
    model = _load(record)
    plan = plan_for_seconds(model, motion.shape[0] / given.fps, "music")
    with _progress(len(plan.starts), "music", args.quiet) as bar:
        (audio,) = motion_to_music_long(
            model, [model_input], given.fps, [args.seed], guidance_scale=args.guidance, progress=bar.update
        )
    shown = motion if trajectory is None else motion + trajectory[:, None, :]
    written = write_music_outputs(
        outputs, audio, model.rates.sample_rate, shown, given.fps, given.skeleton, video_fps=args.video_fps
    )
    log.info("momu generate music: wrote %s", ", ".join(map(str, written)))
    return 0


def _joint(args: argparse.Namespace) -> int:
    outputs = resolve_outputs(args.out, _formats(args.format), JOINT_FORMATS, "joint")
    seconds = 10.0 if args.seconds is None else float(args.seconds)
    if not np.isfinite(seconds) or seconds <= 0:
        raise GenerateInputError(f"--seconds must be > 0, got {args.seconds}")
    record = _record(args, "dance")
    _need_3d(outputs, record)
    model = _load(record)
    try:
        ((audio, motion),) = model.joint([seconds], [args.seed])
    except ValueError as exc:  # e.g. longer than the denoiser's max_length
        raise GenerateInputError(f"--seconds {seconds}: {exc}") from None
    sr, fps = model.rates.sample_rate, model.rates.motion_fps
    dance = {k: v for k, v in outputs.items() if k in ("npz", "bvh", "mp4")}
    written = write_dance_outputs(
        dance,
        motion,
        fps,
        model.skeleton,
        audio,
        sr,
        _provenance(args, record, None),
        video_fps=args.video_fps,
    )
    if "wav" in outputs:
        written += write_music_outputs({"wav": outputs["wav"]}, audio, sr, motion, fps, model.skeleton)
    log.info("momu generate joint: wrote %s", ", ".join(map(str, written)))
    return 0


def _text(args: argparse.Namespace) -> int:
    caption = " ".join(str(args.caption).split())
    if not caption:
        raise GenerateInputError('--caption is empty; describe the motion, e.g. "a person walks forward"')
    outputs = resolve_outputs(args.out, _formats(args.format), DANCE_FORMATS, "motion")
    record = _record(args, "text")
    _need_3d(outputs, record)
    seconds = text_seconds(record, args.seconds)
    motion, fps = generate_text(record, caption, seconds, args.seed)
    prov = {**_provenance(args, record, None), "caption": caption, "seconds": seconds}
    written = write_dance_outputs(
        outputs, motion, fps, record.skeleton, None, None, prov, video_fps=args.video_fps, title="momu text"
    )
    log.info("momu generate text: wrote %s", ", ".join(map(str, written)))
    return 0
