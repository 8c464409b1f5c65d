"""What ``momu eval`` runs (its command line: :mod:`momu.cli.eval_cmd`).

Kept apart from the parser so that building ``momu``'s parser does not import the metrics (6 s).
"""

from __future__ import annotations

import argparse
import datetime as dt
import logging
import math
import sys
from collections.abc import Iterator, Mapping, Sequence
from contextlib import contextmanager
from typing import Any

from momu.cli.eval_inputs import EvalInputError, collect_folder, generated_modalities, load_pairs
from momu.config import ConfigError, apply_overrides, to_container
from momu.data.types import Clip
from momu.errors import EXIT_OK, EXIT_PROBLEMS, UsageError
from momu.io import check_output_file, write_json
from momu.metrics.inputs import needs_of, within_roundoff
from momu.registry import METRICS

__all__ = ["run", "collect_folder", "load_pairs", "build_metrics", "evaluate", "check_inputs"]

logger = logging.getLogger(__name__)


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


_MODALITY = {"motion": "motion (.npy/.npz)", "audio": "music (audio files)"}


def check_inputs(
    metrics: Mapping[str, Any], generated: Sequence[Clip], reference: Sequence[Clip]
) -> dict[str, str]:
    """Refuse a metric whose scored modality is not generated; warn about clips too short for it.

    Returns ``metric -> warning`` for the metrics whose bins or windows some clips are too short
    for (the score is reported, flagged).

    Raises:
        EvalInputError: a metric would score a modality the generated folder does not hold.
    """
    have = generated_modalities(generated)
    warnings: dict[str, str] = {}
    for name, metric in metrics.items():
        needs = needs_of(name, metric)
        if needs is None:
            continue
        if needs.scores and not have & set(needs.scores):
            wanted = " or ".join(_MODALITY[m] for m in needs.scores)
            raise EvalInputError(
                f"metric '{name}' scores generated {wanted}, but the generated folder holds "
                f"{' and '.join(sorted(have)) or 'neither'} for every pair (a missing modality is taken from "
                "the reference as the condition, never scored)"
            )
        shortest = needs.shortest(metric)
        short = [c for c in generated if c.duration < shortest]
        if short:
            warnings[name] = (
                f"{len(short)} of {len(generated)} clips are shorter than {shortest:g} s (e.g. "
                f"{short[0].id}: {short[0].duration:.2f} s): too few bins or beats, the score saturates"
            )
            logger.warning("metric %s: %s", name, warnings[name])
    return warnings


def evaluate(
    generated: Sequence[Clip], reference: Sequence[Clip], metrics: dict[str, Any]
) -> tuple[dict[str, float], dict[str, Any], dict[str, str]]:
    """Run built metrics (``name -> metric``): ``(scores, provenance per metric, errors per metric)``.

    A metric that raises or returns something other than a mapping of numbers is reported in the
    errors; the other metrics' scores are kept.
    """
    from tqdm import tqdm

    scores: dict[str, float] = {}
    provenance: dict[str, Any] = {}
    errors: dict[str, str] = {}
    for name, metric in tqdm(metrics.items(), desc="metrics", unit="metric", disable=None):
        entry = METRICS.get(name)
        info: dict[str, Any] = {"source": entry.source, "origin": entry.origin}
        try:
            info["provenance"] = metric.provenance()
        except Exception as exc:  # a plugin's provenance must not lose the scores
            info["provenance"] = {"error": f"{type(exc).__name__}: {exc}"}
        provenance[name] = info
        try:
            result = _scores(name, metric(list(generated), list(reference)))
        except Exception as exc:  # one failing metric must not lose the others' scores
            errors[name] = f"{type(exc).__name__}: {str(exc) or 'no message'}"
            logger.error("metric %s failed: %s", name, errors[name])
            continue
        scores.update(result)
    return scores, provenance, errors


def _scores(name: str, result: Any) -> dict[str, float]:
    if not isinstance(result, Mapping):
        raise TypeError(f"returned {type(result).__name__}, expected a mapping of score names to numbers")
    out: dict[str, float] = {}
    for key, value in result.items():
        try:
            out[str(key)] = float(value)
        except (TypeError, ValueError):
            raise TypeError(f"score {key!r} is {type(value).__name__}, not a number") from None
    return out


def _flags(metrics: Mapping[str, Any], scores: Mapping[str, float]) -> dict[str, str]:
    """``score key -> note`` for Fréchet distances within round-off of 0."""
    flags: dict[str, str] = {}
    for name, metric in metrics.items():
        needs = needs_of(name, metric)
        if needs is None or not needs.frechet:
            continue
        for key, value in scores.items():
            if (
                (key == name or key.startswith(name + "."))
                and math.isfinite(value)
                and within_roundoff(value)
            ):
                flags[key] = "≈ 0 within round-off: the two sets are indistinguishable"
    return flags


def _table(
    scores: dict[str, float], errors: dict[str, str], n: int, flags: dict[str, str], warnings: dict[str, str]
) -> str:
    width = max([len(k) for k in scores] + [len(k) for k in errors] + [6])
    lines = [f"{'metric':<{width}}  value   ({n} pairs)", f"{'-' * width}  {'-' * 12}"]
    for key, value in scores.items():
        note = f"  ({flags[key]})" if key in flags else ""
        lines.append(f"{key:<{width}}  {value:.6g}{note}")
    lines += [f"{k:<{width}}  FAILED: {msg}" for k, msg in errors.items()]
    lines += [f"warning: {k}: {msg}" for k, msg in warnings.items()]
    return "\n".join(lines) + "\n"


class _OncePerMessage(logging.Filter):
    """Let each distinct log message through once (a per-clip warning is printed once, not 500 times)."""

    def __init__(self) -> None:
        super().__init__()
        self.first: dict[tuple[str, int, str], logging.LogRecord] = {}

    def filter(self, record: logging.LogRecord) -> bool:
        key = (record.name, record.levelno, record.getMessage())
        first = self.first.setdefault(key, record)
        return first is record  # the first record passes every handler; later copies none


@contextmanager
def _each_warning_once() -> Iterator[None]:
    import warnings

    once = _OncePerMessage()
    handlers = logging.getLogger().handlers
    for handler in handlers:
        handler.addFilter(once)
    with warnings.catch_warnings():
        warnings.simplefilter("once")
        try:
            yield
        finally:
            for handler in handlers:
                handler.removeFilter(once)


def run(args: argparse.Namespace) -> int:
    names = [n.strip() for n in args.metrics.split(",") if n.strip()]
    if not names:
        raise ConfigError("--metrics: give at least one metric name (see `momu list metrics`)")
    for name in names:
        METRICS.get(name)  # unknown names fail before any file is read
    metrics = build_metrics(names, _metric_params(names, args.params))
    if args.out is not None:
        try:
            check_output_file(args.out, "--out")
        except ValueError as exc:
            raise UsageError(str(exc)) from None
    with _each_warning_once():
        try:
            generated, reference = load_pairs(args.gen, args.gt, args.fps, args.skeleton, progress=True)
            warnings = check_inputs(metrics, generated, reference)
        except EvalInputError as exc:
            raise UsageError(str(exc)) from None
        scores, provenance, errors = evaluate(generated, reference, metrics)
    flags = _flags(metrics, scores)
    sys.stdout.write(_table(scores, errors, len(generated), flags, warnings))
    if args.out is not None:
        from momu import __version__

        write_json(
            args.out,
            {
                "scores": scores,
                "errors": errors,
                "warnings": warnings,
                "flags": flags,
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
    return EXIT_PROBLEMS if errors else EXIT_OK
