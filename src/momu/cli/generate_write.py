"""``momu generate``: writing what was generated — mp4 (skeleton video with sound), BVH, npz, wav.

The outputs of one command are written as one (:class:`momu.cli.output_paths.StagedOutputs`): each to
a temporary beside its final name, all moved into place together when every one is complete. A
failure (a full disk, ffmpeg failing or running past its time limit, Ctrl-C, SIGTERM) leaves nothing:
no half-written file, no npz without its mp4, no empty folder. Writing failures raise
:class:`~momu.cli.generate_errors.GenerateOutputError` (one line, exit status 1).

The mp4 keeps the song's channels (stereo stays stereo) as 192 kb/s AAC (:mod:`momu.render.ffmpeg`);
its frames show a progress bar on a terminal and a few INFO lines otherwise
(:mod:`momu.cli.generate_progress`).
"""

from __future__ import annotations

import logging
from pathlib import Path
from typing import Any

import numpy as np

from momu.cli.generate_errors import GenerateInputError, GenerateOutputError
from momu.cli.generate_progress import progress
from momu.cli.output_paths import OutputPathError, StagedOutputs, check_writable_output
from momu.io import atomic_path

__all__ = [
    "DANCE_FORMATS",
    "MUSIC_FORMATS",
    "BYTES_PER_SECOND",
    "check_space",
    "write_dance_outputs",
    "write_music_outputs",
    "write_joint_outputs",
    "video_frames",
]

log = logging.getLogger(__name__)

DANCE_FORMATS = ("mp4", "bvh", "npz")
"""What ``momu generate dance`` and ``momu generate text`` write (folder output: ``dance.<format>`` /
``motion.<format>``)."""
MUSIC_FORMATS = ("wav", "mp4")
"""What ``momu generate music`` writes (folder output: ``music.<format>``)."""
BYTES_PER_SECOND = {"bvh": 45_000, "npz": 20_000, "mp4": 40_000, "wav": 64_000}
"""Roughly what each output takes per second of dance or music (a 3-minute dance: 7.4 MB of BVH)."""


def check_space(outputs: dict[str, Path], seconds: float) -> None:
    """Refuse (one line) when the output folder's file system lacks the space ``seconds`` of output take."""
    need = int(1.5 * seconds * sum(BYTES_PER_SECOND.get(f, 0) for f in outputs)) + 1_000_000
    for folder in sorted({p.parent for p in outputs.values()}):
        try:
            check_writable_output(folder, "--out", need_bytes=need)
        except OutputPathError as exc:
            raise GenerateInputError(str(exc)) from None


def video_frames(motion: np.ndarray, fps: float, seconds: float) -> np.ndarray:
    """``motion`` held on its last frame (or cut) to cover ``seconds``: a video as long as its sound."""
    need = max(1, int(np.ceil(seconds * fps - 1e-6)))
    if motion.shape[0] >= need:
        return motion[:need]
    pad = np.repeat(motion[-1:], need - motion.shape[0], axis=0)
    return np.concatenate([motion, pad])


def _video(
    path: Path,
    shown_as: Path,
    motion: np.ndarray,
    fps: float,
    skeleton: str,
    audio: np.ndarray | None,
    sample_rate: int | None,
    video_fps: float,
    title: str,
    quiet: bool,
) -> None:
    from momu.render.skeleton import output_frames, skeleton_animation

    seconds = motion.shape[0] / fps if audio is None or not sample_rate else len(audio) / sample_rate
    frames = video_frames(motion, fps, seconds)
    out_fps = min(float(video_fps), float(fps))
    total = len(output_frames(frames.shape[0], fps, out_fps))
    with progress(total, f"writing {shown_as.name}", "frame", quiet) as update:
        skeleton_animation(
            path,
            frames,
            fps,
            skeleton,
            audio=audio,
            sample_rate=sample_rate if audio is not None else None,
            out_fps=out_fps,
            title=title,
            progress=update,
        )


class _Writing:
    """Names the output being written in an error (a full disk, ffmpeg failing)."""

    def __init__(self, staged: StagedOutputs, quiet: bool) -> None:
        self.staged = staged
        self.quiet = quiet

    def begin(self, key: str) -> Path:
        if not self.quiet:
            log.info("writing %s", self.staged.finals[key])
        return self.staged.path(key)


def _staged(paths: dict[str, Path], quiet: bool, write: Any) -> list[Path]:
    """Run ``write(_Writing)`` inside :class:`StagedOutputs` and commit; failures: GenerateOutputError."""
    from momu.render.ffmpeg import FfmpegError

    try:
        with StagedOutputs(paths) as staged:
            write(_Writing(staged, quiet))
            return staged.commit()
    except (OSError, FfmpegError) as exc:
        folder = sorted({p.parent for p in paths.values()})[0]
        reason = exc.strerror if isinstance(exc, OSError) and exc.strerror else str(exc)
        raise GenerateOutputError(
            f"--out {folder}: cannot write the outputs: {reason}; nothing was written"
        ) from None


def _dance(
    w: _Writing,
    paths: dict[str, Path],
    motion: np.ndarray,
    fps: float,
    skeleton: str,
    sound: np.ndarray | None,
    sample_rate: int | None,
    provenance: dict[str, Any],
    video_fps: float,
    title: str,
) -> None:
    from momu.export import write_bvh, write_motion_npz

    if "npz" in paths:
        write_motion_npz(w.begin("npz"), motion, fps, skeleton, provenance=provenance)
    if "bvh" in paths:
        write_bvh(w.begin("bvh"), motion, fps, skeleton)
    if "mp4" in paths:
        tmp = w.begin("mp4")
        _video(tmp, paths["mp4"], motion, fps, skeleton, sound, sample_rate, video_fps, title, w.quiet)


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
    quiet: bool = True,
) -> list[Path]:
    """Write the generated motion in each requested format, all together; returns the files written.

    ``motion`` is ``(T, J, D)`` at ``fps`` on ``skeleton`` (any method's); the mp4 carries ``audio``
    (``(S,)`` mono or ``(S, C)`` channels) as its sound, or is silent (and as long as the motion) when
    ``audio`` is ``None`` (text→motion). ``quiet``: no progress bar or INFO lines.
    With ``rigid`` (3D skeletons) every file holds :func:`momu.export.rigid_motion` of ``motion``, the
    BVH's motion: one length per bone, so the npz and the BVH agree joint for joint. ``rigid=False``
    writes ``motion`` as it is to the npz and the mp4 (inpainting keeps the given frames bit for bit);
    the BVH then holds its rigid version.

    Raises:
        GenerateOutputError: writing failed (nothing is left half-written).
    """
    from momu.export import rigid_motion

    if rigid:
        motion = rigid_motion(motion, skeleton)

    def write(w: _Writing) -> None:
        _dance(w, paths, motion, fps, skeleton, audio, sample_rate, provenance, video_fps, title)

    return _staged(paths, quiet, write)


def _music(
    w: _Writing,
    paths: dict[str, Path],
    audio: np.ndarray,
    sample_rate: int,
    motion: np.ndarray,
    fps: float,
    skeleton: str,
    video_fps: float,
) -> None:
    import soundfile as sf

    if "wav" in paths:
        with atomic_path(w.begin("wav")) as tmp:
            sf.write(str(tmp), np.asarray(audio, dtype=np.float32), int(sample_rate), format="WAV")
    if "mp4" in paths:
        tmp = w.begin("mp4")
        _video(tmp, paths["mp4"], motion, fps, skeleton, audio, sample_rate, video_fps, "momu music", w.quiet)


def write_music_outputs(
    paths: dict[str, Path],
    audio: np.ndarray,
    sample_rate: int,
    motion: np.ndarray,
    fps: float,
    skeleton: str,
    *,
    video_fps: float = 25.0,
    quiet: bool = True,
) -> list[Path]:
    """Write the generated music (wav) and, for mp4, the input motion with the music as its sound."""

    def write(w: _Writing) -> None:
        _music(w, paths, audio, sample_rate, motion, fps, skeleton, video_fps)

    return _staged(paths, quiet, write)


def write_joint_outputs(
    paths: dict[str, Path],
    audio: np.ndarray,
    sample_rate: int,
    motion: np.ndarray,
    fps: float,
    skeleton: str,
    provenance: dict[str, Any],
    *,
    video_fps: float = 25.0,
    quiet: bool = True,
) -> list[Path]:
    """``generate joint``: the dance formats (the rigid motion, as :func:`write_dance_outputs`) and the
    music's wav, all together."""
    from momu.export import rigid_motion

    dance = {k: v for k, v in paths.items() if k in DANCE_FORMATS}
    motion = rigid_motion(motion, skeleton)

    def write(w: _Writing) -> None:
        _dance(w, dance, motion, fps, skeleton, audio, sample_rate, provenance, video_fps, "momu dance")
        if "wav" in paths:
            _music(w, {"wav": paths["wav"]}, audio, sample_rate, motion, fps, skeleton, video_fps)

    return _staged(paths, quiet, write)
