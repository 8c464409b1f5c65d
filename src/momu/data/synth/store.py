"""Writing ``synth_dance`` to disk and reading a written copy back.

Layout of a written dataset (``write_dataset(out_dir, cfg)``)::

    out_dir/manifest.json           format, version, config, skeleton, fps, sample_rate, clips[]
    out_dir/audio/<id>.wav          mono, cfg.sample_rate, PCM_16 by default
    out_dir/motion/<id>.npy         (T, J, D) float32 (metres for 3D, pixels for 2D)
    out_dir/trajectory/<id>.npy     (T, 3) float32 root path, only when cfg.root_centred

Each manifest clip entry holds ``id``, ``index``, ``style``, ``split``, the relative ``audio`` /
``motion`` (/ ``trajectory``) paths, ``num_frames``, ``num_samples``, ``duration`` (s), ``bpm``,
``beats_per_bar``, ``beat_times``, ``downbeat_times``, ``onset_times``, ``break_times`` and
``motion_beat_times`` (s). The dataset is written into a staging folder beside ``out_dir`` and
renamed into place when complete (:func:`momu.io.staged_dir`), so an interrupted write leaves the
old folder (or none), never a mix; a concurrent writer of the same folder fails at once, and a
non-empty folder is replaced only with ``overwrite``. The same configuration always gives
byte-identical files.

Before anything is written, :func:`check_room` refuses more than :data:`MAX_CLIPS` clips (the manifest
is built in memory and written as one JSON file) and a dataset whose estimated size
(:func:`estimated_bytes`, an upper bound) exceeds the free space where it goes. Every file is encoded
in memory and written by one call (the wavs too), so a disk that fills up while writing raises
``OSError`` (``ENOSPC``) and leaves the old folder, or none.
"""

from __future__ import annotations

import dataclasses
import io
import logging
import shutil
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import soundfile as sf

from momu.data.common import load_npy
from momu.data.synth.dataset import (
    SPLITS,
    SynthConfig,
    SynthDance,
    generate_clip,
    resolved_fps,
    validate_config,
)
from momu.data.types import Clip
from momu.features.skeletons import get_skeleton
from momu.io import atomic_write_bytes, read_json, staged_dir, write_json

__all__ = [
    "write_dataset",
    "load_written",
    "check_room",
    "estimated_bytes",
    "WrittenSynthDance",
    "MANIFEST",
    "FORMAT",
    "MAX_CLIPS",
    "SUBTYPES",
]

log = logging.getLogger(__name__)

MANIFEST = "manifest.json"
FORMAT = "momu.synth_dance"
VERSION = 1
MAX_CLIPS = 100_000
"""Most clips one written dataset may hold (its manifest, about 2 KB per 10 s clip, is built in memory)."""
SUBTYPES = {"PCM_16": 2, "PCM_24": 3, "FLOAT": 4}
"""Wav subtypes :func:`write_dataset` writes, with their bytes per sample."""
_FILE_OVERHEAD = 4096 + 256  # a file's headers and its last, partly filled, disk block
_MANIFEST_BYTES_PER_SECOND = 400  # beat, onset and motion-beat times: measured ~180 B/s of clip
_MANIFEST_BYTES_PER_CLIP = 1024
_META_KEYS = (
    "bpm",
    "beats_per_bar",
    "beat_times",
    "downbeat_times",
    "onset_times",
    "break_times",
    "motion_beat_times",
)


def _npy_bytes(array: np.ndarray) -> bytes:
    buf = io.BytesIO()
    np.save(buf, np.ascontiguousarray(array), allow_pickle=False)
    return buf.getvalue()


def _wav_bytes(audio: np.ndarray, sample_rate: int, subtype: str) -> bytes:
    """The wav file's bytes. libsndfile stamps a float wav's ``PEAK`` chunk with the time of writing;
    that stamp is zeroed so the same clip always gives the same bytes."""
    buf = io.BytesIO()
    sf.write(buf, audio, sample_rate, subtype=subtype, format="WAV")
    data = bytearray(buf.getvalue())
    at = data.find(b"PEAK", 12, max(data.find(b"data", 12), 12))  # a header chunk, before the samples
    if at >= 0 and len(data) >= at + 16:  # "PEAK", chunk size, version, timestamp (uint32s)
        data[at + 12 : at + 16] = bytes(4)
    return bytes(data)


def estimated_bytes(cfg: SynthConfig, subtype: str = "PCM_16") -> int:
    """An upper bound of the bytes :func:`write_dataset` writes for ``cfg`` (every clip at
    ``max_seconds``, every file rounded up to a disk block, the manifest)."""
    skeleton = get_skeleton(cfg.skeleton)
    seconds = float(cfg.max_seconds)
    frames = int(np.ceil(seconds * resolved_fps(cfg))) + 1
    samples = int(np.ceil(seconds * cfg.sample_rate)) + 1
    per_clip = samples * SUBTYPES.get(subtype, 4) + frames * skeleton.num_joints * skeleton.dims * 4
    files = 2
    if cfg.root_centred:
        per_clip += frames * 3 * 4
        files += 1
    per_clip += files * _FILE_OVERHEAD + _MANIFEST_BYTES_PER_CLIP + int(_MANIFEST_BYTES_PER_SECOND * seconds)
    return int(cfg.num_clips) * per_clip + _FILE_OVERHEAD


def _free_bytes(path: Path) -> int:
    probe = path
    while not probe.exists() and probe != probe.parent:
        probe = probe.parent
    return int(shutil.disk_usage(probe).free)


def check_room(
    out_dir: str | Path, cfg: SynthConfig, subtype: str = "PCM_16", what: str = "num_clips"
) -> None:
    """Refuse (``ValueError`` naming ``what``) more than :data:`MAX_CLIPS` clips, or a dataset larger
    (:func:`estimated_bytes`) than the free space of the disk ``out_dir`` goes to. Writes nothing.

    With ``overwrite`` the old copy stays until the new one is complete, so the new one needs all
    of its room."""
    if cfg.num_clips > MAX_CLIPS:
        raise ValueError(
            f"{what} {cfg.num_clips}: at most {MAX_CLIPS:,} clips in one dataset (write several "
            "folders, each with its own --seed, for more)"
        )
    need = estimated_bytes(cfg, subtype)
    free = _free_bytes(Path(out_dir).absolute())
    if need > free:
        raise ValueError(
            f"{what} {cfg.num_clips}: the dataset needs up to {need / 1e9:.2f} GB and {out_dir} has "
            f"{free / 1e9:.2f} GB free; write fewer or shorter clips, or free some space"
        )


def write_dataset(
    out_dir: str | Path,
    cfg: SynthConfig | None = None,
    *,
    subtype: str = "PCM_16",
    progress: Callable[[int], Any] | None = None,
    overwrite: bool = False,
) -> Path:
    """Generate every clip of ``cfg`` and write it as folder ``out_dir``; returns ``out_dir``.

    Args:
        out_dir: destination folder (created; must be empty or absent unless ``overwrite``).
        cfg: the configuration (default :class:`SynthConfig`).
        subtype: libsndfile subtype of the wavs (``"PCM_16"`` or ``"FLOAT"``).
        progress: called with 1 after each clip (e.g. a tqdm bar's ``update``).
        overwrite: replace a non-empty ``out_dir`` (as one rename, once the new copy is complete).

    Raises:
        ValueError: an invalid ``cfg`` or ``subtype``, more than :data:`MAX_CLIPS` clips, or not
            enough free space (:func:`check_room`). NotADirectoryError: ``out_dir`` is a file.
        FileExistsError: it is a non-empty folder and ``overwrite`` is false.
        momu.io.FolderBusyError: another process is writing it. OSError: the disk filled up (or
            failed) while writing; the old folder (or none) is left.
    """
    cfg = cfg if cfg is not None else SynthConfig()
    if subtype not in SUBTYPES:
        raise ValueError(f"subtype must be PCM_16, PCM_24 or FLOAT, got {subtype!r}")
    validate_config(cfg)
    check_room(out_dir, cfg, subtype)
    dataset = SynthDance(cfg)
    final = Path(out_dir)
    with staged_dir(final, overwrite=overwrite) as out:
        _write_clips(out, cfg, dataset, subtype, progress)
    log.info("wrote %d synth_dance clips to %s", len(dataset), final)
    return final


def _write_clips(
    out: Path, cfg: SynthConfig, dataset: SynthDance, subtype: str, progress: Callable[[int], Any] | None
) -> None:
    entries: list[dict[str, Any]] = []
    for index in dataset.indices:
        clip = generate_clip(cfg, index)
        assert clip.motion is not None and clip.audio is not None
        entry: dict[str, Any] = {
            "id": clip.id,
            "index": index,
            "style": clip.style,
            "split": clip.meta["split"],
            "audio": f"audio/{clip.id}.wav",
            "motion": f"motion/{clip.id}.npy",
            "num_frames": clip.num_frames,
            "num_samples": int(clip.audio.shape[0]),
            "duration": clip.duration,
        }
        atomic_write_bytes(out / entry["audio"], _wav_bytes(clip.audio, cfg.sample_rate, subtype))
        atomic_write_bytes(out / entry["motion"], _npy_bytes(clip.motion))
        if clip.trajectory is not None:
            entry["trajectory"] = f"trajectory/{clip.id}.npy"
            atomic_write_bytes(out / entry["trajectory"], _npy_bytes(clip.trajectory))
        entry.update({k: clip.meta[k] for k in _META_KEYS})
        entries.append(entry)
        if progress is not None:
            progress(1)
    skeleton = get_skeleton(cfg.skeleton)
    manifest = {
        "format": FORMAT,
        "version": VERSION,
        "config": dataclasses.asdict(cfg),
        "skeleton": skeleton.name,
        "dims": skeleton.dims,
        "fps": resolved_fps(cfg),
        "sample_rate": cfg.sample_rate,
        "audio_subtype": subtype,
        "splits": {s: sum(e["split"] == s for e in entries) for s in SPLITS},
        "clips": entries,
    }
    write_json(out / MANIFEST, manifest)


class WrittenSynthDance:
    """A ``synth_dance`` copy written by :func:`write_dataset`, loaded lazily clip by clip."""

    def __init__(self, root: str | Path, split: str | None = None) -> None:
        self.root = Path(root)
        path = self.root / MANIFEST
        if not path.is_file():
            raise FileNotFoundError(
                f"{path}: no synth_dance manifest (write one with `momu data synth --out DIR`)"
            )
        manifest = read_json(path)
        if not isinstance(manifest, dict) or manifest.get("format") != FORMAT:
            raise ValueError(f"{path}: not a synth_dance manifest (format {manifest.get('format')!r})")
        if manifest.get("version") != VERSION:
            raise ValueError(f"{path}: unsupported manifest version {manifest.get('version')!r}")
        if split == "all":
            split = None
        if split is not None and split not in SPLITS:
            raise ValueError(f"synth_dance: split must be one of {', '.join(SPLITS)}, all; got {split!r}")
        self.manifest = manifest
        self.split = split
        self.skeleton: str = manifest["skeleton"]
        self.fps = float(manifest["fps"])
        self.sample_rate = int(manifest["sample_rate"])
        self.entries: list[dict[str, Any]] = [
            e for e in manifest["clips"] if split is None or e["split"] == split
        ]

    def __len__(self) -> int:
        return len(self.entries)

    def _file(self, entry: dict[str, Any], key: str) -> Path:
        path = self.root / entry[key]
        if not path.is_file():
            raise FileNotFoundError(f"{path}: listed in {self.root / MANIFEST} but missing")
        return path

    def __getitem__(self, index: int) -> Clip:
        if not -len(self) <= index < len(self):
            raise IndexError(f"synth_dance index {index} out of range for {len(self)} clips")
        entry = self.entries[index]
        motion_path = self._file(entry, "motion")
        motion = load_npy(motion_path)
        sk = get_skeleton(self.skeleton)
        if motion.shape != (entry["num_frames"], sk.num_joints, self.manifest["dims"]):
            raise ValueError(
                f"{motion_path}: motion shape {motion.shape}, manifest says "
                f"({entry['num_frames']}, {sk.num_joints}, {self.manifest['dims']})"
            )
        audio_path = self._file(entry, "audio")
        try:
            audio, sr = sf.read(audio_path, dtype="float32", always_2d=False)
        except (RuntimeError, sf.LibsndfileError) as exc:
            raise ValueError(f"{audio_path}: unreadable audio: {exc}") from None
        if sr != self.sample_rate or audio.ndim != 1 or audio.shape[0] != entry["num_samples"]:
            raise ValueError(
                f"{audio_path}: {audio.shape} samples at {sr} Hz, manifest says "
                f"({entry['num_samples']},) at {self.sample_rate} Hz"
            )
        trajectory = None
        if "trajectory" in entry:
            trajectory = load_npy(self._file(entry, "trajectory"))
        meta = {k: entry[k] for k in _META_KEYS}
        meta.update(index=entry["index"], split=entry["split"], source="synth_dance", root=str(self.root))
        return Clip(
            id=entry["id"],
            motion=motion.astype(np.float32, copy=False),
            fps=self.fps,
            audio=audio,
            sample_rate=sr,
            skeleton=self.skeleton,
            style=entry["style"],
            trajectory=trajectory,
            meta=meta,
        )

    def __repr__(self) -> str:
        return f"WrittenSynthDance(root={str(self.root)!r}, clips={len(self)}, split={self.split!r})"


def load_written(out_dir: str | Path, split: str | None = None) -> WrittenSynthDance:
    """Open a dataset written by :func:`write_dataset` (optionally one split) as a ClipDataset."""
    return WrittenSynthDance(out_dir, split)
