"""ffmpeg within limits: it cannot spin forever, outlive an error, or lose the song's channels."""

from __future__ import annotations

import subprocess
import time
from pathlib import Path

import numpy as np
import pytest

imageio_ffmpeg = pytest.importorskip("imageio_ffmpeg")

from momu.render.ffmpeg import FfmpegError, ffmpeg_process, run_ffmpeg  # noqa: E402
from momu.render.skeleton import skeleton_animation  # noqa: E402

_HEAVY = [
    "-f",
    "lavfi",
    "-i",
    "testsrc2=size=1280x720:rate=50",
    "-t",
    "600",
    "-c:v",
    "libx264",
    "-f",
    "null",
    "-",
]


def test_cpu_time_limit_stops_a_busy_ffmpeg() -> None:
    start = time.monotonic()
    with pytest.raises(FfmpegError, match="more than its 1 s of CPU time encoding"):
        run_ffmpeg(_HEAVY, what="encoding", cpu_seconds=1.0, wall_seconds=60.0)
    assert time.monotonic() - start < 30


def test_wall_clock_limit_stops_it_too() -> None:
    with pytest.raises(FfmpegError, match="took longer than 1 s decoding"):
        run_ffmpeg(["-re", *_HEAVY], what="decoding", cpu_seconds=60.0, wall_seconds=1.0)


def _running(pid: int) -> bool:
    try:
        state = Path(f"/proc/{pid}/stat").read_text().split(")")[-1].split()[0]
    except OSError:
        return False
    return state != "Z"


@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="needs /proc")
def test_an_error_while_feeding_it_kills_it() -> None:
    with pytest.raises(KeyboardInterrupt):
        with ffmpeg_process(
            ["-f", "rawvideo", "-pix_fmt", "gray", "-s", "8x8", "-i", "pipe:0", "-f", "null", "-"],
            what="encoding",
            cpu_seconds=60.0,
            wall_seconds=60.0,
        ) as proc:
            pid = proc.pid
            raise KeyboardInterrupt
    assert not _running(pid)


def _audio_info(path: Path) -> str:
    info = subprocess.run(
        [imageio_ffmpeg.get_ffmpeg_exe(), "-hide_banner", "-i", str(path)], capture_output=True, text=True
    ).stderr
    return next(line for line in info.splitlines() if "Audio:" in line)


def test_sound_beyond_full_scale_is_clipped_not_an_endless_encode(tmp_path: Path) -> None:
    """Samples around ±1e6 made ffmpeg's AAC encoder spin forever (issue 34)."""
    motion = np.random.default_rng(0).normal(size=(20, 24, 3)).astype(np.float32)
    loud = np.random.default_rng(1).uniform(-1e6, 1e6, size=(16000, 2)).astype(np.float32)
    start = time.monotonic()
    skeleton_animation(tmp_path / "a.mp4", motion, 20.0, "smpl24", audio=loud, sample_rate=16000)
    assert time.monotonic() - start < 60
    line = _audio_info(tmp_path / "a.mp4")
    assert "48000 Hz, stereo" in line, line  # the channels are kept (16 kHz is resampled)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.mp4"]
