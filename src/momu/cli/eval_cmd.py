"""``momu eval --gen DIR --gt DIR --metrics m1,m2 [--fps F] [--out FILE.json]``.

Evaluates a folder of generated motions (``.npy``, ``(T, J, D)``) and/or music (``.wav``/``.flac``/
``.ogg``/``.mp3``) against a folder of references, pairing files by stem (``a.npy`` ↔ ``a.npy``,
``a.wav`` ↔ ``a.wav``). A generated item that lacks a modality takes it from its reference — the
conditioning input: generated dances (``.npy`` only) are scored against the reference music, generated
music (``.wav`` only) against the reference motion. Any registered metric runs by name, plugins
included; ``--set NAME.KEY=VALUE`` sets a metric parameter. Prints a table; ``--out`` writes JSON with
the scores and each metric's provenance (source, config, specification).
"""

from __future__ import annotations

import argparse
import datetime as dt
import logging
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from momu.config import ConfigError, apply_overrides, to_container
from momu.data.types import Clip
from momu.io import write_json
from momu.metrics._audio import read_audio
from momu.registry import METRICS

__all__ = ["add_parser", "run", "collect_folder", "load_pairs", "build_metrics", "evaluate"]

logger = logging.getLogger(__name__)

MOTION_SUFFIXES = (".npy",)
AUDIO_SUFFIXES = (".wav", ".flac", ".ogg", ".mp3")
# Joint layouts inferred from (J, D) when --skeleton is not given.
_SKELETONS = {
    (24, 3): "smpl24",
    (14, 2): "openpose14",
    (21, 3): "dwm21",
    (23, 3): "dwm23",
    (22, 3): "humanml22",
}


class EvalInputError(ValueError):
    """Missing folders, unpaired or unreadable files."""


def add_parser(sub: Any) -> None:
    p = sub.add_parser(
        "eval",
        help="score generated motion/music folders against references with registered metrics",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("--gen", required=True, type=Path, help="folder of generated .npy motions and/or audio")
    p.add_argument("--gt", required=True, type=Path, help="folder of reference .npy motions and/or audio")
    p.add_argument(
        "--metrics", required=True, help="comma-separated registered metric names (momu list metrics)"
    )
    p.add_argument("--fps", type=float, default=60.0, help="motion frame rate in fps (default 60, AIST++)")
    p.add_argument("--skeleton", default=None, help="joint layout name (default: inferred from (J, D))")
    p.add_argument("--out", type=Path, default=None, help="write scores + provenance to this JSON file")
    p.add_argument(
        "--set",
        dest="params",
        action="append",
        default=[],
        metavar="METRIC.KEY=VALUE",
        help="metric parameter, e.g. bas.variant=mint (repeatable)",
    )
    p.set_defaults(func=run)


def collect_folder(folder: Path) -> dict[str, dict[str, Path]]:
    """``stem -> {"motion": path, "audio": path}`` for the motion and audio files of ``folder``."""
    if not folder.exists():
        raise EvalInputError(f"{folder}: folder not found")
    if not folder.is_dir():
        raise EvalInputError(f"{folder}: not a folder")
    items: dict[str, dict[str, Path]] = {}
    for path in sorted(folder.iterdir()):
        suffix = path.suffix.lower()
        kind = "motion" if suffix in MOTION_SUFFIXES else "audio" if suffix in AUDIO_SUFFIXES else None
        if kind is None or not path.is_file():
            continue
        entry = items.setdefault(path.stem, {})
        if kind in entry:
            raise EvalInputError(
                f"{folder}: two {kind} files for '{path.stem}': {entry[kind].name}, {path.name}"
            )
        entry[kind] = path
    if not items:
        raise EvalInputError(
            f"{folder}: no motion ({', '.join(MOTION_SUFFIXES)}) or audio ({', '.join(AUDIO_SUFFIXES)}) files"
        )
    return items


def _load_motion(path: Path) -> np.ndarray:
    try:
        arr = np.load(path, allow_pickle=False)
    except Exception as exc:
        raise EvalInputError(f"{path}: cannot read as a .npy array: {exc}") from None
    if arr.ndim != 3 or arr.shape[2] not in (2, 3):
        raise EvalInputError(
            f"{path}: expected joint positions (T, J, D) with D = 2 or 3, got shape {arr.shape}"
        )
    if not np.issubdtype(arr.dtype, np.number) or not np.all(np.isfinite(arr)):
        raise EvalInputError(f"{path}: motion must hold finite numbers")
    return np.asarray(arr, dtype=np.float32)


def _clip(
    stem: str, files: dict[str, Path], fallback: dict[str, Path], fps: float, skeleton: str | None
) -> Clip:
    motion_path = files.get("motion") or fallback.get("motion")
    audio_path = files.get("audio") or fallback.get("audio")
    motion = _load_motion(motion_path) if motion_path else None
    audio, sr = (None, None)
    if audio_path:
        try:
            audio, sr = read_audio(audio_path)
        except (FileNotFoundError, ValueError) as exc:
            raise EvalInputError(str(exc)) from None
    name = skeleton or (_SKELETONS.get((motion.shape[1], motion.shape[2]), "") if motion is not None else "")
    meta = {
        "motion_file": str(motion_path) if motion_path else None,
        "audio_file": str(audio_path) if audio_path else None,
    }
    return Clip(id=stem, motion=motion, fps=fps, audio=audio, sample_rate=sr, skeleton=name, meta=meta)


def load_pairs(
    gen_dir: Path, gt_dir: Path, fps: float, skeleton: str | None = None
) -> tuple[list[Clip], list[Clip]]:
    """Generated and reference clips paired by stem (sorted); missing generated modalities from the reference.

    Raises:
        EvalInputError: a folder is missing or empty, a stem is unpaired, or a file is unreadable.
    """
    if not fps > 0:
        raise EvalInputError(f"--fps: must be > 0, got {fps}")
    gen, gt = collect_folder(gen_dir), collect_folder(gt_dir)
    only_gen, only_gt = sorted(set(gen) - set(gt)), sorted(set(gt) - set(gen))
    if only_gen or only_gt:
        parts = []
        if only_gen:
            parts.append(
                f"{len(only_gen)} generated without a reference in {gt_dir}: {', '.join(only_gen[:10])}"
            )
        if only_gt:
            parts.append(
                f"{len(only_gt)} references without a generated item in {gen_dir}: {', '.join(only_gt[:10])}"
            )
        raise EvalInputError("unpaired files (pairs are matched by file stem): " + "; ".join(parts))
    stems = sorted(gen)
    generated = [_clip(s, gen[s], gt[s], fps, skeleton) for s in stems]
    reference = [_clip(s, gt[s], {}, fps, skeleton) for s in stems]
    return generated, reference


def _metric_params(names: Sequence[str], overrides: Sequence[str]) -> dict[str, dict[str, Any]]:
    params: dict[str, dict[str, Any]] = {n: {} for n in names}
    tree = to_container(apply_overrides({}, overrides)) or {}
    for key, value in tree.items():
        if key not in params:
            raise ConfigError(f"--set {key}.…: '{key}' is not among --metrics ({', '.join(names)})")
        if not isinstance(value, dict):
            raise ConfigError(f"--set {key}={value!r}: expected METRIC.KEY=VALUE")
        params[key] = value
    return params


def build_metrics(names: Sequence[str], params: dict[str, dict[str, Any]]) -> dict[str, Any]:
    """Build each named metric with its parameters (validated); usage errors raise ``ConfigError``."""
    built: dict[str, Any] = {}
    for name in names:
        try:
            built[name] = METRICS.build(name, params.get(name) or None)
        except (ValueError, TypeError) as exc:
            if isinstance(exc, ConfigError):
                raise
            raise ConfigError(f"metric '{name}': {exc}") from exc
    return built


def evaluate(
    generated: Sequence[Clip], reference: Sequence[Clip], metrics: dict[str, Any]
) -> tuple[dict[str, float], dict[str, Any], dict[str, str]]:
    """Run built metrics (``name -> metric``): ``(scores, provenance per metric, errors per metric)``."""
    scores: dict[str, float] = {}
    provenance: dict[str, Any] = {}
    errors: dict[str, str] = {}
    for name, metric in metrics.items():
        entry = METRICS.get(name)
        info: dict[str, Any] = {"source": entry.source, "origin": entry.origin}
        try:
            info["provenance"] = metric.provenance()
        except Exception as exc:  # a plugin's provenance must not lose the scores
            info["provenance"] = {"error": f"{type(exc).__name__}: {exc}"}
        provenance[name] = info
        try:
            result = metric(list(generated), list(reference))
        except (ValueError, ZeroDivisionError, KeyError, RuntimeError) as exc:
            errors[name] = f"{type(exc).__name__}: {exc}"
            logger.error("metric %s failed: %s", name, errors[name])
            continue
        for key, value in result.items():
            scores[key] = float(value)
    return scores, provenance, errors


def _table(scores: dict[str, float], errors: dict[str, str], n: int) -> str:
    width = max([len(k) for k in scores] + [len(k) for k in errors] + [6])
    lines = [f"{'metric':<{width}}  value   ({n} pairs)", f"{'-' * width}  {'-' * 12}"]
    lines += [f"{k:<{width}}  {v:.6g}" for k, v in scores.items()]
    lines += [f"{k:<{width}}  FAILED: {msg}" for k, msg in errors.items()]
    return "\n".join(lines) + "\n"


def run(args: argparse.Namespace) -> int:
    names = [n.strip() for n in args.metrics.split(",") if n.strip()]
    if not names:
        raise ConfigError("--metrics: give at least one metric name (see `momu list metrics`)")
    for name in names:
        METRICS.get(name)  # unknown names fail before any file is read
    metrics = build_metrics(names, _metric_params(names, args.params))
    try:
        generated, reference = load_pairs(args.gen, args.gt, args.fps, args.skeleton)
    except EvalInputError as exc:
        sys.stderr.write(f"momu eval: error: {exc}\n")
        return 2
    scores, provenance, errors = evaluate(generated, reference, metrics)
    sys.stdout.write(_table(scores, errors, len(generated)))
    if args.out is not None:
        from momu import __version__

        write_json(
            args.out,
            {
                "scores": scores,
                "errors": errors,
                "metrics": provenance,
                "inputs": {
                    "gen": str(args.gen),
                    "gt": str(args.gt),
                    "pairs": [c.id for c in generated],
                    "fps": args.fps,
                    "generated_modalities": {
                        c.id: {"motion": c.meta["motion_file"], "audio": c.meta["audio_file"]}
                        for c in generated
                    },
                },
                "momu_version": __version__,
                "created": dt.datetime.now(dt.timezone.utc).isoformat(timespec="seconds"),
            },
        )
    return 1 if errors else 0
