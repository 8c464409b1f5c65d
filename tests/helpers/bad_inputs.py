"""Bad and hostile inputs for the fault matrix (issue 34), each built under a test's folder.

Songs (``generate dance --music``), motions (``generate music --motion``) and argv builders used by
``tests/integration/test_fault_matrix_inputs.py``: each builder takes the test's folder and returns
the file it wrote, or the ``momu`` argv (without ``--model``).
"""

from __future__ import annotations

import io
import zipfile
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import soundfile as sf

from momu.export import write_bvh, write_motion_npz
from tests.integration.test_bad_input_matrix import _pairs, _swing, _wav
from tests.unit.test_metrics_beats_audio import SR, clicks

Setup = Callable[[Path], list[str]]


def song(seconds: float = 2.0, channels: int = 2, scale: float = 1.0, sr: int = SR) -> np.ndarray:
    x = clicks([0.25 + 0.5 * i for i in range(int(seconds * 2))], seconds, sr)
    x = x + 0.05 * np.sin(2 * np.pi * 220 * np.arange(x.size) / sr).astype(np.float32)
    return np.stack([x * (1.0 - 0.3 * c) for c in range(channels)], axis=1) * scale


def float_wav(scale: float) -> Setup:
    def setup(root: Path) -> list[str]:
        sf.write(root / "loud.wav", song(scale=scale), SR, subtype="FLOAT")
        return ["generate", "dance", "--music", str(root / "loud.wav"), "--out", str(root / "o")]

    return setup


def mp3(root: Path, damage: str) -> Path:
    path = root / f"{damage}.mp3"
    sf.write(path, song(6.0, sr=44100), 44100, format="MP3")
    data = bytearray(path.read_bytes())
    if damage == "truncated":  # a partial download: the header still says 6 s
        data = data[: len(data) // 2]
    else:  # a zeroed stretch in the middle
        data[len(data) // 3 : 2 * len(data) // 3] = bytes(len(data) // 3)
    path.write_bytes(bytes(data))
    return path


def dance(music: Callable[[Path], Path], *extra: str) -> Setup:
    def setup(root: Path) -> list[str]:
        return ["generate", "dance", "--music", str(music(root)), "--out", str(root / "o"), *extra]

    return setup


def text_as_mp3(root: Path) -> Path:
    (root / "notes.mp3").write_text("not audio, only text\n" * 50)
    return root / "notes.mp3"


def short_wav(root: Path) -> Path:
    sf.write(root / "blip.wav", song(0.2), SR)
    return root / "blip.wav"


def bvh(root: Path, frames: int | None = None, frame_time: float | None = None, rows: int = 20) -> Path:
    """A dwm21 BVH of ``rows`` frames (momu's writer) whose header is then made to say otherwise."""
    from momu.data.synth.dataset import SynthConfig, generate_clip

    clip = generate_clip(SynthConfig(num_clips=1, min_seconds=2.0, max_seconds=2.0, skeleton="dwm21"), 0)
    assert clip.motion is not None
    motion = np.concatenate([clip.motion] * (rows // len(clip.motion) + 1))[:rows]
    path = write_bvh(root / "dance.bvh", motion, clip.fps, "dwm21")
    text = path.read_text()
    if frames is not None:
        text = text.replace(f"Frames: {rows}\n", f"Frames: {frames}\n")
    if frame_time is not None:
        head, _, rest = text.partition("Frame Time:")
        text = head + f"Frame Time: {frame_time:.9f}\n" + rest.split("\n", 1)[1]
    path.write_text(text)
    return path


def music(motion: Callable[[Path], Path], *extra: str) -> Setup:
    def setup(root: Path) -> list[str]:
        return ["generate", "music", "--motion", str(motion(root)), "--out", str(root / "o"), *extra]

    return setup


def npz(root: Path, **arrays: Any) -> Path:
    np.savez_compressed(root / "motion.npz", **arrays)
    return root / "motion.npz"


def zip_bomb(root: Path) -> Path:
    """300 kB of zip holding a 316 MB ``joints`` array of zeros (and a tiny ``fps``)."""
    header = io.BytesIO()
    shape = (1_100_000, 24, 3)
    np.lib.format.write_array_header_1_0(header, {"descr": "<f4", "fortran_order": False, "shape": shape})
    path = root / "bomb.npz"
    with zipfile.ZipFile(path, "w", compression=zipfile.ZIP_DEFLATED, compresslevel=1) as zf:
        with zf.open("joints.npy", "w", force_zip64=True) as fh:
            fh.write(header.getvalue())
            block, left = bytes(1 << 22), int(np.prod(shape)) * 4
            while left > 0:
                fh.write(block[: min(left, len(block))])
                left -= len(block)
        fps = io.BytesIO()
        np.save(fps, np.float64(20.0))
        zf.writestr("fps.npy", fps.getvalue())
    return path


def npy_long_header(root: Path) -> Path:
    path = root / "huge.npy"
    header = io.BytesIO()
    np.lib.format.write_array_header_1_0(
        header, {"descr": "<f4", "fortran_order": False, "shape": (10**9, 24, 3)}
    )
    path.write_bytes(b"\x93NUMPY\x01\x00" + header.getvalue()[8:] + _swing(5, 24).tobytes())
    return path


def complex_npy(root: Path) -> Path:
    np.save(root / "c.npy", _swing(40, 24).astype(np.complex64) * (1 + 0.5j))
    return root / "c.npy"


def long_npy(root: Path) -> Path:  # 601 s at 20 fps
    np.save(root / "long.npy", np.broadcast_to(_swing(1, 24), (12_020, 24, 3)))
    return root / "long.npy"


def short_npz(root: Path) -> Path:  # 0.2 s
    return write_motion_npz(root / "blip.npz", _swing(4, 24), 20.0, "smpl24")


def motion_npz(root: Path) -> Path:
    return write_motion_npz(root / "motion.npz", _swing(40, 24), 20.0, "smpl24")


def generate(*argv: str) -> Setup:
    """``momu generate ARGV`` with a 2-second song ``ROOT/song.wav`` and a motion ``ROOT/motion.npz``."""

    def setup(root: Path) -> list[str]:
        _wav(root / "song.wav", 2.0)
        motion_npz(root)
        return ["generate", *[a.replace("ROOT", str(root)) for a in argv]]

    return setup


def eval_complex(root: Path) -> list[str]:
    _pairs(root)
    np.save(root / "gen" / "c0.npy", np.load(root / "gen" / "c0.npy").astype(np.complex64) * (1 + 1j))
    return ["eval", "--gen", str(root / "gen"), "--gt", str(root / "gt"), "--metrics", "bas", "--fps", "30"]
