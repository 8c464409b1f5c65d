"""``momu generate``: writing what was generated — mp4 (skeleton video with sound), BVH, npz, wav.

Every file is written atomically (a temporary beside it, renamed when complete), so an interrupted run
leaves no half-written output.
"""

from __future__ import annotations

import logging
from pathlib import Path
from typing import Any

import numpy as np

from momu.io import atomic_path

__all__ = ["DANCE_FORMATS", "MUSIC_FORMATS", "write_dance_outputs", "write_music_outputs", "video_frames"]

log = logging.getLogger(__name__)

DANCE_FORMATS = ("mp4", "bvh", "npz")
"""What ``momu generate dance`` and ``momu generate text`` write (folder output: ``dance.<format>`` /
``motion.<format>``)."""
MUSIC_FORMATS = ("wav", "mp4")
"""What ``momu generate music`` writes (folder output: ``music.<format>``)."""


def video_frames(motion: np.ndarray, fps: float, seconds: float) -> np.ndarray:
    """``motion`` held on its last frame (or cut) to cover ``seconds``: a video as long as its sound."""
    need = max(1, int(np.ceil(seconds * fps - 1e-6)))
    if motion.shape[0] >= need:
        return motion[:need]
    pad = np.repeat(motion[-1:], need - motion.shape[0], axis=0)
    return np.concatenate([motion, pad])


def _video(
    path: Path,
    motion: np.ndarray,
    fps: float,
    skeleton: str,
    audio: np.ndarray | None,
    sample_rate: int | None,
    video_fps: float,
    title: str,
) -> None:
    from momu.render.skeleton import skeleton_animation

    seconds = motion.shape[0] / fps if audio is None or not sample_rate else len(audio) / sample_rate
    frames = video_frames(motion, fps, seconds)
    skeleton_animation(
        path,
        frames,
        fps,
        skeleton,
        audio=audio,
        sample_rate=sample_rate if audio is not None else None,
        out_fps=min(float(video_fps), float(fps)),
        title=title,
    )


def write_dance_outputs(
    paths: dict[str, Path],
    motion: np.ndarray,
    fps: float,
    skeleton: str,
    audio: np.ndarray | None,
    sample_rate: int | None,
    provenance: dict[str, Any],
    *,
    video_fps: float = 25.0,
    title: str = "momu dance",
    rigid: bool = True,
) -> list[Path]:
    """Write the generated motion in each requested format; returns the files written.

    ``motion`` is ``(T, J, D)`` at ``fps`` on ``skeleton`` (any method's); the mp4 carries ``audio``
    as its sound, or is silent (and as long as the motion) when ``audio`` is ``None`` (text→motion).
    With ``rigid`` (3D skeletons) every file holds :func:`momu.export.rigid_motion` of ``motion``, the
    BVH's motion: one length per bone, so the npz and the BVH agree joint for joint. ``rigid=False``
    writes ``motion`` as it is to the npz and the mp4 (inpainting keeps the given frames bit for bit);
    the BVH then holds its rigid version.
    """
    from momu.export import rigid_motion, write_bvh, write_motion_npz

    if rigid:
        motion = rigid_motion(motion, skeleton)
    written = []
    if "npz" in paths:
        written.append(write_motion_npz(paths["npz"], motion, fps, skeleton, provenance=provenance))
    if "bvh" in paths:
        written.append(write_bvh(paths["bvh"], motion, fps, skeleton))
    if "mp4" in paths:
        _video(paths["mp4"], motion, fps, skeleton, audio, sample_rate, video_fps, title)
        written.append(paths["mp4"])
    return written


def write_music_outputs(
    paths: dict[str, Path],
    audio: np.ndarray,
    sample_rate: int,
    motion: np.ndarray,
    fps: float,
    skeleton: str,
    *,
    video_fps: float = 25.0,
) -> list[Path]:
    """Write the generated music (wav) and, for mp4, the input motion with the music as its sound."""
    import soundfile as sf

    written = []
    if "wav" in paths:
        with atomic_path(paths["wav"]) as tmp:
            sf.write(str(tmp), np.asarray(audio, dtype=np.float32), int(sample_rate), format="WAV")
        written.append(paths["wav"])
    if "mp4" in paths:
        _video(paths["mp4"], motion, fps, skeleton, audio, sample_rate, video_fps, "momu music")
        written.append(paths["mp4"])
    return written
