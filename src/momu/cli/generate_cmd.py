"""``momu generate``: music for your motion, dance for your music, or both, with a trained MoMu model.

    momu generate --task music2motion --model DIR --input song.wav --out dance.npy
    momu generate --task motion2music --model DIR --input dance.npy --fps 60 --out song.wav
    momu generate --task joint --model DIR --seconds 12 --out pair   # pair.wav + pair.npy

``DIR`` is a model folder written by :meth:`momu.methods.momu.MoMuModel.save` — every MoMu recipe
writes one per trained configuration under ``<out>/<table>/models/momu-<hash>/``. Motion files are
``.npy`` arrays ``(T, J, D)`` of keypoints in the model's skeleton and units (``openpose14``: 2D
pixels); the output motion's frame rate is written next to it as ``<out>.json``.
"""

from __future__ import annotations

import argparse
import logging
from pathlib import Path
from typing import Any

import numpy as np

from momu.data.common import AUDIO_SUFFIXES, DataFileError, absent_reason, load_npy
from momu.errors import UsageError
from momu.io import atomic_path, check_output_file, write_json
from momu.metrics._audio import read_audio

log = logging.getLogger(__name__)

TASKS = ("music2motion", "motion2music", "joint")


def add_parser(sub: Any) -> None:
    p = sub.add_parser(
        "generate", help="generate motion from music, music from motion, or both (MoMu-Diffusion)"
    )
    p.add_argument("--task", choices=TASKS, required=True, help="what to generate")
    p.add_argument("--model", type=Path, required=True, help="a saved MoMu model folder (momu.json ...)")
    p.add_argument("--input", type=Path, help="music2motion: an audio file; motion2music: a (T, J, D) .npy")
    p.add_argument(
        "--out", type=Path, required=True, help="output file (.npy motion, .wav music; joint: a stem)"
    )
    p.add_argument(
        "--fps", type=float, default=None, help="motion2music: frame rate of --input (default: 60)"
    )
    p.add_argument("--seconds", type=float, default=10.0, help="joint: length in seconds (default 10)")
    p.add_argument("--seed", type=int, default=0, help="noise seed (generation is deterministic per seed)")
    p.add_argument(
        "--guidance-scale", type=float, default=None, help="classifier-free guidance scale s (Eq. 7)"
    )
    p.add_argument("--bone-correction", action="store_true", help="apply MoMu App. E bone-length correction")
    p.set_defaults(func=run)


def _write_wav(path: Path, audio: np.ndarray, sample_rate: int) -> None:
    import soundfile as sf

    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_path(path) as tmp:
        sf.write(str(tmp), np.asarray(audio, dtype=np.float32), sample_rate, format="WAV")


def _write_motion(path: Path, motion: np.ndarray, fps: float, skeleton: str) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    with atomic_path(path) as tmp:
        with open(tmp, "wb") as fh:
            np.save(fh, np.asarray(motion, dtype=np.float32), allow_pickle=False)
    write_json(path.with_suffix(".json"), {"fps": fps, "skeleton": skeleton, "shape": list(motion.shape)})


def _read_audio(path: Path) -> tuple[np.ndarray, int]:
    try:
        return read_audio(path)
    except (FileNotFoundError, ValueError) as exc:
        raise UsageError(f"--input {exc}") from None


def _read_motion(path: Path, joints: int, dims: int) -> np.ndarray:
    try:
        motion = load_npy(path)
    except DataFileError as exc:
        raise UsageError(f"--input {exc}") from None
    if motion.ndim != 3 or motion.shape[1:] != (joints, dims):
        raise UsageError(f"--input {path}: motion must be (T, {joints}, {dims}), got {motion.shape}")
    if not np.all(np.isfinite(motion)):
        raise UsageError(f"--input {path}: motion contains NaN or infinite values")
    return motion.astype(np.float32)


def _outputs(args: argparse.Namespace) -> list[Path]:
    """Every file the task writes (checked before the model is loaded)."""
    out: Path = args.out
    if args.task == "joint":
        return [out.with_suffix(".wav"), out.with_suffix(".npy"), out.with_suffix(".json")]
    suffix = ".npy" if args.task == "music2motion" else ".wav"
    if out.suffix.lower() != suffix:
        raise UsageError(f"--out {out}: {args.task} writes a {suffix} file; give a name ending in {suffix}")
    return [out, out.with_suffix(".json")] if args.task == "music2motion" else [out]


def _check_arguments(args: argparse.Namespace) -> None:
    """Inputs, options and every output path, before any work."""
    if args.task in ("music2motion", "motion2music"):
        if args.input is None:
            need = "an audio file" if args.task == "music2motion" else "a .npy motion file"
            raise UsageError(f"--input: {args.task} needs {need}")
        if not args.input.is_file():
            raise UsageError(f"--input {args.input}: {absent_reason(args.input)}")
        if args.task == "music2motion" and args.input.suffix.lower() not in AUDIO_SUFFIXES:
            raise UsageError(
                f"--input {args.input}: not an audio file (expected {', '.join(AUDIO_SUFFIXES)})"
            )
    if args.fps is not None and not args.fps > 0:
        raise UsageError(f"--fps must be > 0, got {args.fps}")
    if args.task == "joint" and not args.seconds > 0:
        raise UsageError(f"--seconds must be > 0, got {args.seconds}")
    model = Path(args.model)
    if not model.is_dir():
        raise UsageError(f"--model {model}: {absent_reason(model, 'model folder')}")
    for path in _outputs(args):
        try:
            check_output_file(path, "--out")
        except ValueError as exc:
            raise UsageError(str(exc)) from None


def run(args: argparse.Namespace) -> int:
    """Run the subcommand; bad inputs print one line ``momu generate: error: ...`` and return 2."""
    _check_arguments(args)
    from momu.methods.momu import MoMuModel

    try:
        model = MoMuModel.load(args.model)
    except (ValueError, FileNotFoundError, OSError) as exc:
        raise UsageError(f"--model {exc}") from None
    if args.bone_correction:
        model.cfg.bone_correction = True
    rates = model.rates
    if args.task == "music2motion":
        audio, sr = _read_audio(args.input)
        (motion,) = model.music_to_motion([audio], sr, [args.seed], guidance_scale=args.guidance_scale)
        _write_motion(args.out, motion, rates.motion_fps, model.skeleton)
    elif args.task == "motion2music":
        motion_vae = model.vae.motion_vae
        joints, dims = getattr(motion_vae, "num_joints", 0), getattr(motion_vae, "joint_dims", 0)
        motion = _read_motion(args.input, int(joints), int(dims))
        (audio,) = model.motion_to_music(
            [motion], args.fps or 60.0, [args.seed], guidance_scale=args.guidance_scale
        )
        _write_wav(args.out, audio, rates.sample_rate)
    else:
        ((audio, motion),) = model.joint([args.seconds], [args.seed])
        _write_wav(args.out.with_suffix(".wav"), audio, rates.sample_rate)
        _write_motion(args.out.with_suffix(".npy"), motion, rates.motion_fps, model.skeleton)
    log.info("momu generate: wrote %s", args.out)
    return 0
