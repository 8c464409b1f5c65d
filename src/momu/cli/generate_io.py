"""``momu generate``: everything checked before a model is loaded — the song
(:mod:`momu.cli.generate_song`), the outputs, the model folder's record — and the default (shipped) model.

Each check raises :class:`GenerateInputError` with one line naming the file or option and what is wrong
(the command prints it and exits with status 2); soft problems (a very short or silent song, an unusual
sample rate) are logged as warnings and generation goes on.
"""

from __future__ import annotations

import hashlib
import logging
import os
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import Any

from momu.cli.generate_errors import GenerateInputError
from momu.cli.generate_song import (
    MAX_SONG_SECONDS,
    MIN_SECONDS,
    Song,
    check_seconds,
    read_song,
    song_warnings,
)
from momu.cli.output_paths import OutputPathError, check_writable_output
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
    "MIN_SECONDS",
    "check_seconds",
]

log = logging.getLogger(__name__)


def resolve_outputs(
    out: str | Path, formats: list[str] | None, allowed: tuple[str, ...], stem: str
) -> dict[str, Path]:
    """Output file per format, each checked writable now (before any work).

    ``out`` with a suffix in ``allowed`` is that one file (``--format`` must agree); any other suffix is
    an error, unless the text ends in a path separator (``take_1.5/``, ``song.wav/``: a folder, whatever
    its name's dots); otherwise ``out`` is a folder (created when the outputs are written) holding
    ``<stem>.<format>`` for each of ``formats`` (default: all ``allowed``). A folder path that is an
    existing file is an error; so is a folder that cannot be written or a name too long for the file
    system (:func:`momu.cli.output_paths.check_writable_output`).
    """
    folder = isinstance(out, str) and out.endswith(("/", os.sep))
    out = Path(out)
    try:
        outputs = _output_files(out, formats, allowed, stem, folder)
        for path in outputs.values():
            check_writable_output(path, "--out", is_file=True)
    except OutputPathError as exc:
        raise GenerateInputError(str(exc)) from None
    except OSError as exc:  # ENAMETOOLONG, ELOOP while looking at the path
        raise GenerateInputError(f"--out {out}: {exc.strerror or exc}") from None
    return outputs


def _output_files(
    out: Path, formats: list[str] | None, allowed: tuple[str, ...], stem: str, folder: bool
) -> dict[str, Path]:
    suffix = out.suffix.lower().lstrip(".")
    if formats is not None:
        bad = [f for f in formats if f not in allowed]
        if bad or not formats:
            raise GenerateInputError(f"--format: unknown {bad or formats}; choose from {', '.join(allowed)}")
    if suffix and not folder and not out.is_dir():
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
