"""``momu generate``: everything checked before a model is loaded — the song, the motion, the outputs,
the model folder's record — and the default (shipped) model.

Each check raises :class:`GenerateInputError` with one line naming the file or option and what is wrong
(the command prints it and exits with status 2); soft problems (a very short or silent song, an unusual
sample rate) are logged as warnings and generation goes on.
"""

from __future__ import annotations

import hashlib
import io
import logging
import subprocess
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import Any

import numpy as np

from momu.io import read_json

__all__ = [
    "GenerateInputError",
    "Song",
    "read_song",
    "song_warnings",
    "resolve_outputs",
    "ModelRecord",
    "model_record",
    "MODEL_FILES",
    "default_model_dir",
    "file_sha256",
    "MAX_SONG_SECONDS",
]

log = logging.getLogger(__name__)

MAX_SONG_SECONDS = 600.0
"""Longest input (10 minutes); ``--seconds`` cuts a longer one."""
SHORT_SONG_SECONDS = 2.0
"""Songs shorter than this get a warning (the model's beats need a few bars)."""
SILENCE_RMS = 1e-4
"""A song whose RMS is below this (full scale 1) is called silent."""
USUAL_RATES = (8000, 96000)
"""Sample rates outside this range (Hz) get a warning: far from the 16 kHz music the models train on."""


class GenerateInputError(ValueError):
    """A bad input, output path or model folder of ``momu generate`` (one line, exit status 2)."""


@dataclass(frozen=True)
class Song:
    """A decoded song: mono waveform in [-1, 1] at its own rate.

    Attributes:
        audio: ``(S,)`` float32 mono mixdown.
        sample_rate: the file's rate (Hz).
        channels: channels in the file.
        duration: seconds of ``audio`` (after any ``--seconds`` cut).
        file_duration: seconds in the file.
        path: the file.
    """

    audio: np.ndarray
    sample_rate: int
    channels: int
    duration: float
    file_duration: float
    path: Path


def _decode_soundfile(path: Path) -> tuple[np.ndarray, int]:
    import soundfile as sf

    audio, sr = sf.read(str(path), dtype="float32", always_2d=True)
    return audio, int(sr)


def _decode_ffmpeg(path: Path) -> tuple[np.ndarray, int]:
    """Decode any format ffmpeg knows (m4a, aac ...) through imageio-ffmpeg's binary, to float WAV."""
    import imageio_ffmpeg
    import soundfile as sf

    cmd = [
        imageio_ffmpeg.get_ffmpeg_exe(),
        "-v",
        "error",
        "-i",
        str(path),
        "-f",
        "wav",
        "-c:a",
        "pcm_f32le",
        "-",
    ]
    proc = subprocess.run(cmd, capture_output=True, check=False)
    if proc.returncode != 0 or not proc.stdout:
        raise RuntimeError(proc.stderr.decode(errors="replace").strip().splitlines()[-1:] or "no output")
    audio, sr = sf.read(io.BytesIO(proc.stdout), dtype="float32", always_2d=True)
    return audio, int(sr)


def read_song(path: Path, seconds: float | None = None) -> Song:
    """Decode a song (wav, mp3, flac, ogg, opus with libsndfile; other formats through ffmpeg).

    Raises:
        GenerateInputError: missing or unreadable file, no samples, NaN samples, longer than
            :data:`MAX_SONG_SECONDS` (without ``seconds``), or a bad ``seconds``.
    """
    if seconds is not None and (not np.isfinite(seconds) or seconds <= 0):
        raise GenerateInputError(f"--seconds must be > 0, got {seconds}")
    if not path.exists():
        raise GenerateInputError(f"--music {path}: file not found")
    if not path.is_file():
        raise GenerateInputError(f"--music {path}: not a file")
    try:
        audio, sr = _decode_soundfile(path)
    except Exception as first:  # libsndfile raises LibsndfileError / RuntimeError / TypeError
        try:
            audio, sr = _decode_ffmpeg(path)
        except Exception:
            raise GenerateInputError(f"--music {path}: cannot read audio ({first})") from None
    if audio.size == 0 or sr <= 0:
        raise GenerateInputError(f"--music {path}: the file holds no audio samples")
    if not np.all(np.isfinite(audio)):
        raise GenerateInputError(f"--music {path}: audio contains NaN or infinite samples")
    file_duration = audio.shape[0] / sr
    if seconds is None and file_duration > MAX_SONG_SECONDS:
        raise GenerateInputError(
            f"--music {path}: {file_duration:.0f} s is longer than {MAX_SONG_SECONDS:.0f} s; "
            "pass --seconds to use its beginning"
        )
    mono = audio.mean(axis=1).astype(np.float32)
    if seconds is not None:
        mono = mono[: int(round(min(seconds, MAX_SONG_SECONDS) * sr))]
    return Song(mono, sr, int(audio.shape[1]), mono.shape[0] / sr, file_duration, path)


def song_warnings(song: Song) -> list[str]:
    """Warnings (also logged) for a song that is very short, silent, or at an unusual sample rate."""
    out = []
    if song.duration < SHORT_SONG_SECONDS:
        out.append(
            f"{song.path}: only {song.duration:.2f} s long; dances under {SHORT_SONG_SECONDS:g} s show little"
        )
    rms = float(np.sqrt(np.mean(np.square(song.audio.astype(np.float64))))) if song.audio.size else 0.0
    if rms < SILENCE_RMS:
        out.append(f"{song.path}: the audio is silent (RMS {rms:.1e}); the dance will not follow any beat")
    if not USUAL_RATES[0] <= song.sample_rate <= USUAL_RATES[1]:
        out.append(
            f"{song.path}: sample rate {song.sample_rate} Hz is far outside the models' 16 kHz training "
            f"music (usual range {USUAL_RATES[0]}-{USUAL_RATES[1]} Hz); it is resampled"
        )
    for line in out:
        log.warning("%s", line)
    return out


def resolve_outputs(
    out: Path, formats: list[str] | None, allowed: tuple[str, ...], stem: str
) -> dict[str, Path]:
    """Output file per format.

    ``out`` with a suffix in ``allowed`` is that one file (``--format`` must agree); any other suffix is
    an error; otherwise ``out`` is a folder (created later) holding ``<stem>.<format>`` for each of
    ``formats`` (default: all ``allowed``). A folder path that is an existing file is an error.
    """
    suffix = out.suffix.lower().lstrip(".")
    if formats is not None:
        bad = [f for f in formats if f not in allowed]
        if bad or not formats:
            raise GenerateInputError(f"--format: unknown {bad or formats}; choose from {', '.join(allowed)}")
    if suffix and not out.is_dir():
        if suffix not in allowed:
            raise GenerateInputError(
                f"--out {out}: unknown output type '.{suffix}' (use a folder, or a file ending in "
                f"{', '.join('.' + a for a in allowed)})"
            )
        if formats is not None and formats != [suffix]:
            raise GenerateInputError(f"--out {out} is a .{suffix} file but --format asks for {formats}")
        if out.parent.exists() and not out.parent.is_dir():
            raise GenerateInputError(f"--out {out}: {out.parent} is a file, not a folder")
        return {suffix: out}
    if out.exists() and not out.is_dir():
        raise GenerateInputError(
            f"--out {out}: is a file; give a folder or a file ending in one of {allowed}"
        )
    for parent in out.parents:
        if parent.exists() and not parent.is_dir():
            raise GenerateInputError(f"--out {out}: {parent} is a file, not a folder")
    return {f: out / f"{stem}.{f}" for f in (formats or list(allowed))}


MODEL_FILES = {"momu": "momu.json", "mofusion": "mofusion.json", "harmogan": "harmogan.json"}
"""The record file of each method's saved model folder (which one a folder holds says its method)."""
DEFAULT_FPS = {"mofusion": 20.0, "harmogan": 15.0}
"""Motion rates of the methods whose record may leave ``config.fps`` out (their config defaults)."""


@dataclass(frozen=True)
class ModelRecord:
    """What a model folder's record says, read without loading any weights.

    Attributes:
        folder: the model folder.
        method: ``momu``, ``mofusion`` or ``harmogan`` (which of :data:`MODEL_FILES` it holds).
        skeleton: the motion's skeleton name. dims: 2 or 3 (the skeleton's).
        task: what it is conditioned on: ``music`` (music→dance; MoMu also dance→music and joint) or
            ``text`` (a MoFusion text→motion model).
        fps: motion frame rate (``None`` for MoMu: derived from its rates when loaded).
        window_seconds: MoFusion's training window (text models train on clips up to this long).
        max_frames: the longest motion the backbone takes (``None``: any length).
        provenance: ``provenance.json`` when present.
    """

    folder: Path
    skeleton: str
    dims: int
    provenance: dict[str, Any]
    method: str = "momu"
    task: str = "music"
    fps: float | None = None
    window_seconds: float | None = None
    max_frames: int | None = None

    @property
    def file(self) -> str:
        return MODEL_FILES[self.method]


def _read_record(folder: Path) -> tuple[str, dict[str, Any]]:
    held = [m for m, name in MODEL_FILES.items() if (folder / name).is_file()]
    if not held:
        names = ", ".join(MODEL_FILES.values())
        raise GenerateInputError(f"--model {folder}: not a saved momu model (no {names})")
    if len(held) > 1:
        raise GenerateInputError(f"--model {folder}: holds several model records ({', '.join(held)})")
    method = held[0]
    try:
        meta = read_json(folder / MODEL_FILES[method])
    except (OSError, ValueError) as exc:
        raise GenerateInputError(f"--model {folder}: {exc}") from None
    if not isinstance(meta, dict) or meta.get("method") != method:
        raise GenerateInputError(f"--model {folder}: {MODEL_FILES[method]} is not a {method} model record")
    return method, meta


def _max_frames(folder: Path) -> int | None:
    """A backbone's positional-table bound (``dit``'s ``max_length``) from its saved part config."""
    from momu.parts_io import read_part_config

    try:
        rec = read_part_config(folder / "backbone")
    except (OSError, ValueError):
        return None  # a missing part is reported when the model loads
    value = (rec.get("config") or {}).get("max_length")
    return int(value) if isinstance(value, (int, float)) else None


def model_record(folder: Path) -> ModelRecord:
    """Read a model folder's record (``momu.json``, ``mofusion.json`` or ``harmogan.json``, and
    ``provenance.json`` when present)."""
    from momu.features.skeletons import get_skeleton

    method, meta = _read_record(folder)
    name = str(meta.get("skeleton", ""))
    try:
        dims = get_skeleton(name).dims
    except KeyError:
        raise GenerateInputError(
            f"--model {folder}: unknown skeleton {name!r} in {MODEL_FILES[method]}"
        ) from None
    prov_path = folder / "provenance.json"
    provenance = dict(read_json(prov_path)) if prov_path.is_file() else {}
    if method == "momu":
        return ModelRecord(folder, name, dims, provenance)
    given = meta.get("config")
    cfg: dict[str, Any] = given if isinstance(given, dict) else {}
    fps = float(cfg.get("fps", DEFAULT_FPS[method]))
    if method == "harmogan":
        return ModelRecord(folder, name, dims, provenance, method, "music", fps)
    task = str(cfg.get("task", "music"))
    if task not in ("music", "text"):
        raise GenerateInputError(f"--model {folder}: unknown MoFusion task {task!r} in mofusion.json")
    window = float(cfg.get("window_seconds", 10.0))
    return ModelRecord(folder, name, dims, provenance, method, task, fps, window, _max_frames(folder))


def default_model_dir(direction: str) -> Path:
    """The shipped model for ``direction`` (``"dance"`` / ``"music"``): ``momu/pretrained/index.json``."""
    root = Path(str(resources.files("momu") / "pretrained"))
    index = root / "index.json"
    if not index.is_file():
        raise GenerateInputError(
            "no shipped model in this installation (momu/pretrained/index.json missing): pass --model DIR "
            "(a folder written by `momu train`) or run `nox -s pretrain`"
        )
    entry = read_json(index).get(direction)
    if not entry:
        raise GenerateInputError(f"{index}: no shipped model for '{direction}'; pass --model DIR")
    return root / str(entry)


def file_sha256(path: Path) -> str:
    """SHA-256 of a file (provenance of inputs)."""
    digest = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()
