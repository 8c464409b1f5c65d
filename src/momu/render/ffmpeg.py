"""Running ffmpeg (the ``imageio-ffmpeg`` binary) so that it never outlives its work or momu.

Every ffmpeg momu starts

* gets a **CPU-time limit** proportional to its work (ffmpeg's own ``-timelimit``: the kernel kills it
  once it has used that much CPU, so a process whose parent was killed with SIGKILL stops too — an
  encoder spinning on bad input cannot run forever);
* gets a **wall-clock limit** (a watchdog thread kills it), also proportional to the work;
* runs in its **own session**, and the whole group is killed when the Python side leaves the block with
  an exception (an error, Ctrl-C, or SIGTERM turned into ``SystemExit`` by
  :func:`momu.cli.interrupts.exit_on_sigterm`);
* writes its messages to an anonymous temporary file (no name on disk, nothing left behind).

:func:`run_ffmpeg` decodes (its output is returned); :func:`ffmpeg_process` is a running process
that is fed frames through its stdin (:func:`write_mp4`).
"""

from __future__ import annotations

import contextlib
import logging
import math
import os
import signal
import subprocess
import tempfile
import threading
from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import IO

import numpy as np

__all__ = [
    "FfmpegError",
    "ffmpeg_exe",
    "ffmpeg_process",
    "run_ffmpeg",
    "write_mp4",
    "mp4_limits",
    "AAC_BITRATE",
    "AAC_RATES",
]

logger = logging.getLogger(__name__)

CPU_BASE_S = 60.0
"""CPU seconds every ffmpeg run may use, whatever its size (start-up, probing)."""
CPU_PER_FRAME_S = 0.1
"""Extra CPU seconds per video frame written (H.264 ``veryfast`` at 320x416 takes ~2 ms)."""
CPU_PER_AUDIO_S = 0.1
"""Extra CPU seconds per second of audio decoded or encoded (AAC takes ~2 ms)."""
WALL_BASE_S = 300.0
"""Wall-clock seconds every ffmpeg run may take, whatever its size."""
WALL_PER_FRAME_S = 1.0
"""Extra wall-clock seconds per video frame (momu draws the frames while ffmpeg waits for them)."""
AAC_BITRATE = "192k"
"""Bit rate of the mp4's AAC sound track (the song keeps its channels: stereo stays stereo)."""
AAC_RATES = (32000, 44100, 48000, 64000, 88200, 96000)
"""Sound-track rates kept as they are; any other (a 16 kHz song, generated music) is resampled to 48 kHz:
AAC at 192 kb/s on a 16 kHz stereo track takes 3x the CPU time of the same track at 48 kHz."""
AAC_CODER = "twoloop"
"""ffmpeg's AAC coding algorithm (its default): ``fast`` takes half the CPU time (1.2 s against 2.4 s for
3 minutes of 44.1 kHz stereo) but spends as little as 140 kb/s on simple music; ``twoloop`` keeps 192."""


class FfmpegError(RuntimeError):
    """ffmpeg failed, or was stopped at its time limit; the message says which and why."""


def ffmpeg_exe() -> str:
    """The ffmpeg binary of ``imageio-ffmpeg`` (``RuntimeError`` saying what to install without it)."""
    try:
        import imageio_ffmpeg
    except ImportError:
        raise RuntimeError(
            "writing .mp4 needs an ffmpeg binary: `pip install imageio-ffmpeg` "
            "(or write a .gif, which needs only matplotlib and Pillow)"
        ) from None
    return str(imageio_ffmpeg.get_ffmpeg_exe())


def mp4_limits(frames: int, audio_seconds: float) -> tuple[float, float]:
    """``(cpu_seconds, wall_seconds)`` for encoding ``frames`` video frames and ``audio_seconds`` of sound."""
    cpu = CPU_BASE_S + CPU_PER_FRAME_S * frames + CPU_PER_AUDIO_S * audio_seconds
    wall = WALL_BASE_S + WALL_PER_FRAME_S * frames + CPU_PER_AUDIO_S * audio_seconds
    return cpu, wall


def _kill_group(proc: subprocess.Popen[bytes]) -> None:
    """SIGKILL ``proc``'s process group (its own session: ffmpeg and anything it started)."""
    if proc.poll() is not None:
        return
    try:
        os.killpg(proc.pid, signal.SIGKILL)
    except (ProcessLookupError, PermissionError):
        with contextlib.suppress(ProcessLookupError):
            proc.kill()


def _last_lines(log: IO[bytes], limit: int = 500) -> str:
    log.seek(0)
    return log.read().decode(errors="replace").strip()[-limit:]


class _Watchdog:
    """Kills a process group after ``seconds`` of wall-clock time (unless cancelled first)."""

    def __init__(self, proc: subprocess.Popen[bytes], seconds: float) -> None:
        self.fired = False
        self._proc = proc
        self._timer = threading.Timer(seconds, self._fire)
        self._timer.daemon = True
        self._timer.start()

    def _fire(self) -> None:
        self.fired = True
        _kill_group(self._proc)

    def cancel(self) -> None:
        self._timer.cancel()


def _command(args: Sequence[str], cpu_seconds: float) -> list[str]:
    limit = str(max(1, int(math.ceil(cpu_seconds))))
    return [ffmpeg_exe(), "-hide_banner", "-nostats", "-timelimit", limit, *args]


def _failure(what: str, code: int, watchdog: _Watchdog, wall: float, cpu: float, log: IO[bytes]) -> str:
    if watchdog.fired:
        return f"ffmpeg took longer than {wall:.0f} s {what}; it was stopped"
    messages = _last_lines(log)
    # the kernel's SIGXCPU at the limit (ffmpeg stops on it, "received signal 24"), SIGKILL past it
    if code in (-signal.SIGKILL, -signal.SIGXCPU) or f"received signal {int(signal.SIGXCPU)}" in messages:
        return f"ffmpeg used more than its {cpu:.0f} s of CPU time {what}; it was stopped"
    return f"ffmpeg failed {what}: {messages or f'exit status {code}'}"


@contextlib.contextmanager
def ffmpeg_process(
    args: Sequence[str],
    *,
    what: str,
    cpu_seconds: float,
    wall_seconds: float,
    pass_fds: Sequence[int] = (),
) -> Iterator[subprocess.Popen[bytes]]:
    """A running ``ffmpeg ARGS`` fed through its stdin, within the limits (module docstring).

    The block writes to ``proc.stdin``; leaving it normally closes stdin and waits for ffmpeg (raising
    :class:`FfmpegError` naming ``what`` when it failed or hit a limit); leaving it with an exception
    kills ffmpeg's process group first.
    """
    with tempfile.TemporaryFile() as log:
        proc = subprocess.Popen(
            _command(args, cpu_seconds),
            stdin=subprocess.PIPE,
            stdout=subprocess.DEVNULL,
            stderr=log,
            start_new_session=True,
            pass_fds=tuple(pass_fds),
        )
        watchdog = _Watchdog(proc, wall_seconds)
        try:
            try:
                yield proc
            except BaseException:
                _kill_group(proc)
                raise
            finally:
                assert proc.stdin is not None
                with contextlib.suppress(BrokenPipeError, OSError):
                    proc.stdin.close()
            code = proc.wait()
        finally:
            watchdog.cancel()
            _kill_group(proc)
            proc.wait()
        if code != 0:
            raise FfmpegError(_failure(what, code, watchdog, wall_seconds, cpu_seconds, log))


def run_ffmpeg(
    args: Sequence[str], *, what: str, cpu_seconds: float, wall_seconds: float
) -> tuple[bytes, str]:
    """Run ``ffmpeg ARGS`` to completion within the limits; returns ``(stdout, its messages)``.

    Raises:
        FfmpegError: non-zero exit status, or a limit was reached (ffmpeg is killed).
    """
    with tempfile.TemporaryFile() as log:
        proc = subprocess.Popen(
            _command(args, cpu_seconds),
            stdin=subprocess.DEVNULL,
            stdout=subprocess.PIPE,
            stderr=log,
            start_new_session=True,
        )
        watchdog = _Watchdog(proc, wall_seconds)
        try:
            out, _ = proc.communicate()
        finally:
            watchdog.cancel()
            _kill_group(proc)
            proc.wait()
        if proc.returncode != 0:
            raise FfmpegError(_failure(what, proc.returncode, watchdog, wall_seconds, cpu_seconds, log))
        return out, _last_lines(log)


def _sound_args(fd: int, rate: int, channels: int) -> list[str]:
    """Input and encoder options of the AAC track read from ``fd`` (float32 WAV)."""
    args = ["-f", "wav", "-i", f"pipe:{fd}"]
    out = ["-c:a", "aac", "-b:a", AAC_BITRATE, "-aac_coder", AAC_CODER]
    if channels > 2:
        out += ["-ac", "2"]
    if rate not in AAC_RATES:
        out += ["-ar", "48000"]
    return args + out


def write_mp4(
    path: Path,
    images: Iterator[np.ndarray],
    out_fps: float,
    sound: np.ndarray | None,
    sample_rate: int | None,
    num_frames: int,
) -> int:
    """Pipe RGBA frames to ffmpeg (H.264 ``veryfast``, yuv420p, even frame size), with ``sound``
    (``(S, C)`` float in [-1, 1]: its channels are kept, stereo stays stereo) as an AAC track at
    :data:`AAC_BITRATE`.

    The sound is padded with silence or cut to the video's ``num_frames / out_fps`` seconds and reaches
    ffmpeg through an anonymous temporary file (nothing named on disk, nothing left if momu is killed).
    Returns the number of frames.
    """
    first = next(images, None)
    if first is None:
        raise ValueError("motion: no frames to animate")
    h, w = first.shape[:2]
    video = ["-y", "-loglevel", "error", "-f", "rawvideo", "-pix_fmt", "rgba"]
    video += ["-s", f"{w}x{h}", "-r", f"{out_fps:g}", "-i", "pipe:0"]
    encode = ["-vf", "pad=ceil(iw/2)*2:ceil(ih/2)*2", "-c:v", "libx264", "-preset", "veryfast"]
    encode += ["-pix_fmt", "yuv420p"]
    seconds = num_frames / out_fps
    cpu, wall = mp4_limits(num_frames, seconds)
    with contextlib.ExitStack() as stack:
        fds: tuple[int, ...] = ()
        sound_args: list[str] = []
        if sound is not None and sample_rate:
            import soundfile as sf

            track = np.zeros((int(round(seconds * sample_rate)), sound.shape[1]), dtype=np.float32)
            keep = min(track.shape[0], sound.shape[0])
            np.clip(sound[:keep], -1.0, 1.0, out=track[:keep])
            fh = stack.enter_context(tempfile.TemporaryFile())
            sf.write(fh, track, int(sample_rate), format="WAV", subtype="FLOAT")
            del track
            fh.flush()
            fh.seek(0)
            fds = (fh.fileno(),)
            sound_args = _sound_args(fh.fileno(), int(sample_rate), sound.shape[1])
            encode += ["-shortest"]
        cmd = video + sound_args[:4] + encode + sound_args[4:] + ["-f", "mp4", str(path)]
        count = 0
        proc = stack.enter_context(
            ffmpeg_process(cmd, what=f"writing {path}", cpu_seconds=cpu, wall_seconds=wall, pass_fds=fds)
        )
        assert proc.stdin is not None
        with contextlib.suppress(BrokenPipeError):  # ffmpeg exited early: the error says why
            for image in _chain(first, images):
                proc.stdin.write(np.ascontiguousarray(image).data)
                count += 1
    return count


def _chain(first: np.ndarray, rest: Iterator[np.ndarray]) -> Iterator[np.ndarray]:
    yield first
    yield from rest
