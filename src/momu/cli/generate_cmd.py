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
import sys
from pathlib import Path
from typing import Any

import numpy as np

from momu.io import atomic_path, write_json

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
    import soundfile as sf

    if not path.is_file():
        raise FileNotFoundError(f"--input {path}: audio file not found")
    try:
        audio, sr = sf.read(str(path), dtype="float32", always_2d=True)
    except RuntimeError as exc:
        raise ValueError(f"--input {path}: cannot read audio: {exc}") from None
    return audio.mean(axis=1), int(sr)


def _read_motion(path: Path, joints: int, dims: int) -> np.ndarray:
    if not path.is_file():
        raise FileNotFoundError(f"--input {path}: motion file not found")
    try:
        motion = np.load(path, allow_pickle=False)
    except ValueError as exc:
        raise ValueError(f"--input {path}: not a plain .npy array: {exc}") from None
    if motion.ndim != 3 or motion.shape[1:] != (joints, dims):
        raise ValueError(f"--input {path}: motion must be (T, {joints}, {dims}), got {motion.shape}")
    if not np.all(np.isfinite(motion)):
        raise ValueError(f"--input {path}: motion contains NaN or infinite values")
    return motion.astype(np.float32)


def run(args: argparse.Namespace) -> int:
    """Run the subcommand; bad inputs print one line ``momu generate: error: ...`` and return 2."""
    try:
        return _run(args)
    except (ValueError, FileNotFoundError) as exc:
        sys.stderr.write(f"momu generate: error: {exc}\n")
        return 2


def _run(args: argparse.Namespace) -> int:
    from momu.methods.momu import MoMuModel

    model = MoMuModel.load(args.model)
    if args.bone_correction:
        model.cfg.bone_correction = True
    rates = model.rates
    if args.task == "music2motion":
        if args.input is None:
            raise ValueError("--input: music2motion needs an audio file")
        audio, sr = _read_audio(args.input)
        (motion,) = model.music_to_motion([audio], sr, [args.seed], guidance_scale=args.guidance_scale)
        _write_motion(args.out, motion, rates.motion_fps, model.skeleton)
    elif args.task == "motion2music":
        if args.input is None:
            raise ValueError("--input: motion2music needs a .npy motion file")
        motion_vae = model.vae.motion_vae
        joints, dims = getattr(motion_vae, "num_joints", 0), getattr(motion_vae, "joint_dims", 0)
        motion = _read_motion(args.input, int(joints), int(dims))
        (audio,) = model.motion_to_music(
            [motion], args.fps or 60.0, [args.seed], guidance_scale=args.guidance_scale
        )
        _write_wav(args.out, audio, rates.sample_rate)
    else:
        if args.seconds <= 0:
            raise ValueError(f"--seconds must be > 0, got {args.seconds}")
        ((audio, motion),) = model.joint([args.seconds], [args.seed])
        _write_wav(args.out.with_suffix(".wav"), audio, rates.sample_rate)
        _write_motion(args.out.with_suffix(".npy"), motion, rates.motion_fps, model.skeleton)
    log.info("momu generate: wrote %s", args.out)
    return 0
