"""``momu generate``: a user's motion file as a model's input — read, cut, converted to the model's
skeleton (and, for MoFusion, resampled to its frame rate) — checked before any model is loaded.

* :func:`read_motion` reads the file (:func:`momu.data.motion_files.read_motion_file`: BVH, npy, npz, a
  Dance with Melody folder) and keeps its first ``--seconds``;
* :func:`to_skeleton` maps it to the model's skeleton as global positions (root-centred files get their
  trajectory back), refusing what cannot be converted (2D keypoints to a 3D model);
* :func:`model_rate_motion` does both and resamples to the model's rate (MoFusion: 20 fps, §4.4), the
  frames the MoFusion tasks keep (:mod:`momu.cli.generate_inpaint`);
* :func:`keep_given` writes the kept part of that motion into a generated one, bit for bit.

Errors are :class:`~momu.cli.generate_io.GenerateInputError` lines naming ``--motion``.
"""

from __future__ import annotations

import logging
from pathlib import Path

import numpy as np

from momu.cli.generate_io import GenerateInputError, ModelRecord
from momu.cli.generate_song import MAX_SONG_SECONDS, MIN_SECONDS, check_seconds
from momu.data.motion_files import MotionInput

__all__ = ["read_motion", "motion_warnings", "to_skeleton", "model_rate_motion", "keep_given"]

log = logging.getLogger(__name__)

SHORT_MOTION_SECONDS = 2.0
"""Motions shorter than this get a warning (the music will be very short)."""
STATIC_MOTION_FRACTION = 0.01
"""A motion whose joints all stay within this fraction of the figure's size is called static."""


def read_motion(path: Path, skeleton: str | None, fps: float | None, seconds: float | None) -> MotionInput:
    """The motion file, cut to its first ``seconds`` (checked like a song's ``--seconds``).

    A motion longer than :data:`~momu.cli.generate_song.MAX_SONG_SECONDS` needs ``seconds``; one
    shorter than :data:`~momu.cli.generate_song.MIN_SECONDS` is refused.
    """
    from momu.data.motion_files import read_motion_file

    seconds = check_seconds(seconds)
    try:
        given = read_motion_file(
            path, skeleton=skeleton, fps=fps, max_seconds=None if seconds is not None else MAX_SONG_SECONDS
        )
    except (ValueError, FileNotFoundError) as exc:
        raise GenerateInputError(f"--motion {exc}") from None
    if given.motion.shape[0] / given.fps < MIN_SECONDS:
        raise GenerateInputError(
            f"--motion {path}: too short: only {given.motion.shape[0] / given.fps:.2f} s of motion "
            f"({given.motion.shape[0]} frames at {given.fps:g} fps); momu needs at least {MIN_SECONDS:g} s"
        )
    if seconds is None:
        return given
    keep = max(2, int(round(seconds * given.fps)))
    trajectory = None if given.trajectory is None else given.trajectory[:keep]
    return MotionInput(given.motion[:keep], given.fps, given.skeleton, trajectory, given.source)


def motion_warnings(given: MotionInput, path: Path) -> list[str]:
    """Warnings (also logged) for a motion that is very short, or static (its joints barely move)."""
    out = []
    seconds = given.motion.shape[0] / given.fps
    if seconds < SHORT_MOTION_SECONDS:
        out.append(f"{path}: only {seconds:.2f} s of motion; the music will be very short")
    x = given.motion.astype(np.float64)
    if given.trajectory is not None:
        x = x + given.trajectory[:, None, :].astype(np.float64)
    size = float(np.max(np.ptp(x[0], axis=0)))  # the figure's extent in its first frame
    moved = float(np.max(np.ptp(x, axis=0)))  # the farthest any joint goes along any axis
    if moved <= STATIC_MOTION_FRACTION * max(size, 1e-9):
        out.append(
            f"{path}: the motion is static (no joint moves more than {moved:.2g}, "
            f"{100 * moved / max(size, 1e-9):.2g} % of the figure's size); "
            "the music will not follow any movement"
        )
    for line in out:
        log.warning("%s", line)
    return out


def to_skeleton(given: MotionInput, path: Path, record: ModelRecord) -> np.ndarray:
    """``given`` as ``(T, J, D)`` float64 global positions of the model's skeleton (same frame rate)."""
    from momu.features.convert import can_convert, convert_motion

    if not can_convert(given.skeleton, record.skeleton):
        raise GenerateInputError(
            f"--motion {path}: cannot convert skeleton {given.skeleton!r} to the model's "
            f"{record.skeleton!r} (2D keypoints have no depth for a 3D model)"
        )
    return convert_motion(given.motion, given.skeleton, record.skeleton, trajectory=given.trajectory)


def model_rate_motion(given: MotionInput, path: Path, record: ModelRecord) -> np.ndarray:
    """``given`` on the model's skeleton at its frame rate (``record.fps``): ``(T', J, 3)`` float64.

    Raises:
        GenerateInputError: the skeleton does not convert, or it is shorter than the model's
            :data:`~momu.methods.mofusion.model.MIN_FRAMES`.
    """
    from momu.methods.mofusion.data import resample_motion
    from momu.methods.mofusion.model import MIN_FRAMES

    assert record.fps is not None  # a MoFusion record always says its rate
    motion = resample_motion(to_skeleton(given, path, record), given.fps, record.fps)
    if motion.shape[0] < MIN_FRAMES:
        raise GenerateInputError(
            f"--motion {path}: {motion.shape[0]} frames at the model's {record.fps:g} fps "
            f"({given.motion.shape[0] / given.fps:.2f} s) is too short; it takes at least {MIN_FRAMES} "
            f"frames ({MIN_FRAMES / record.fps:.2f} s)"
        )
    return motion


def keep_given(generated: np.ndarray, given: np.ndarray, keep: np.ndarray, root: int) -> np.ndarray:
    """``generated`` with the kept part of ``given`` (both ``(T, J, 3)``) written back exactly.

    ``keep`` is ``(T, J)`` (True = keep). MoFusion's pose vector (§3) holds the root's position and the
    other joints relative to it, and the inpainting sampler keeps those values; decoding them back
    to positions rounds in float32. So a kept joint is ``given``'s value itself where the root is kept
    too, and ``given``'s offset from the root added to the new root where the root was regenerated.
    """
    out = np.array(generated, dtype=np.float64, copy=True)
    keep = np.asarray(keep, dtype=bool)
    root_kept = keep[:, root]
    rel = keep & ~root_kept[:, None]
    if rel.any():
        moved = out[:, root : root + 1] + (given - given[:, root : root + 1])
        out[rel] = moved[rel]
    exact = keep & root_kept[:, None]
    out[exact] = given[exact]
    return out
