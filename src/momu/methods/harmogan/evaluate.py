"""Evaluation of HarmoGAN rows: training (shared by every HarmoGAN table), generation and per-clip measures.

Every HarmoGAN recipe evaluates on the held-out tail of every dance (the temporal split), cut into
consecutive 6-s windows (the paper's clip length, §V-A). For a trained row and clip *i*:

* the row itself: motion generated from clip *i*'s music, starting from clip *i*'s first
  ground-truth pose (§IV-A: "a single initial pose input"), scored against clip *i*'s music;
* *other condition*: the same model, the same noise seed and initial pose, given clip π(i)'s
  music, scored against clip *i*'s music (a model that follows its music scores lower);
* *shuffled*: clip π(i)'s ground-truth motion against clip *i*'s music;
* *ground truth*: clip *i*'s own motion.

Calibration rows (``calibration_row`` in the config) score perturbed ground truth on the same clips
with the same metric code (:mod:`momu.methods.harmogan.perturb`). Models and data are shared by all
HarmoGAN tables of one output folder: ``<out>/harmogan_shared/`` (stages, saved models, data cache).
"""

from __future__ import annotations

import logging
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from omegaconf import DictConfig, OmegaConf

from momu.config import build_component
from momu.data.types import Clip
from momu.engine.context import RunContext
from momu.engine.scores import ROW
from momu.features.bones import bone_lengths
from momu.features.cache import FeatureCache
from momu.features.skeletons import get_skeleton
from momu.methods.harmogan.data import (
    Dance,
    MeterUnitDataset,
    Window,
    eval_windows,
    replace_motion,
    window_clip,
)
from momu.methods.harmogan.method import HarmoGAN
from momu.methods.harmogan.model import HarmoGANModel
from momu.methods.harmogan.perturb import beat_period, shifted_audio, static_pose, time_warped
from momu.methods.harmogan.prepare import load_dances, load_units
from momu.methods.momu.scoring import derangement
from momu.metrics._clips import clip_motion
from momu.metrics.harmony import HarmonyConfig, clip_harmony

__all__ = [
    "SHARED_DIR",
    "CALIBRATION_ROWS",
    "FEET",
    "RunData",
    "shared_context",
    "run_data",
    "fit_model",
    "test_set",
    "generate",
    "harmony_values",
    "motion_values",
    "row_clips",
    "with_row",
    "training_bones",
]

log = logging.getLogger(__name__)

SHARED_DIR = "harmogan_shared"
FEET = (10, 11, 19, 20)
"""dwm21 heels and toes (the lowest points of the body)."""

CALIBRATION_ROWS: Mapping[str, str] = {
    "shuffled": "ground truth, motion of another clip (shuffled)",
    "half_beat": "ground truth, audio shifted by half a beat",
    "static": "static mean pose + 0.1 mm noise",
    "fast": "ground truth sped up ×1.25",
}
"""The calibration rows every HarmoGAN table prints (``calibration_row`` → row name)."""


def shared_context(ctx: RunContext) -> RunContext:
    """A context whose stages live in ``<out>/harmogan_shared`` (provenance, timings and remembered
    values shared)."""
    return RunContext(
        accelerator=ctx.accelerator,
        out_dir=ctx.out_dir.parent / SHARED_DIR,
        resume=ctx.resume,
        trained=ctx.trained,
        timings=ctx.timings,
        derived=ctx.derived,
    )


@dataclass
class RunData:
    """A row's method, its dances and their data key, and the shared context and data cache."""

    method: HarmoGAN
    dances: list[Dance]
    key: dict[str, Any]
    shared: RunContext
    cache: FeatureCache


def run_data(ctx: RunContext, cfg: DictConfig) -> RunData:
    """Build the row's method and load (or read from the cache) its dances."""
    method = build_component(cfg.method, "methods")
    if not isinstance(method, HarmoGAN):
        raise ValueError(f"method: expected 'harmogan', got {type(method).__name__}")
    shared = shared_context(ctx)
    cache = FeatureCache(shared.out_dir / "cache")
    with ctx.timed("data"):
        dances, key = load_dances(cfg, method.cfg, cache)
    return RunData(method, dances, key, shared, cache)


def model_folder(data: RunData, key_hash: str) -> Path:
    return data.shared.out_dir / "models" / f"harmogan-{key_hash}"


def fit_model(ctx: RunContext, data: RunData, seed: int) -> tuple[HarmoGANModel, str]:
    """Train (or reuse) the row's model, save it once; returns it and its folder (relative to ``<out>``)."""
    with ctx.timed("data"):
        arrays, stats = load_units(data.dances, data.key, data.method.cfg, data.cache)
    model, key_hash = data.method.fit(
        data.shared, data.dances, MeterUnitDataset(arrays), stats, data.key, seed
    )
    folder = model_folder(data, key_hash)
    if ctx.accelerator.is_main_process and not (folder / "harmogan.json").is_file():
        model.save(folder)
    return model, str(folder.relative_to(ctx.out_dir.parent))


def test_set(data: RunData, split: str = "test") -> tuple[list[Window], list[Clip]]:
    """The windows of ``split`` (the held-out parts by default) and their ground-truth clips.

    Raises:
        ValueError: fewer than two windows (the comparisons pair clip i with clip π(i)).
    """
    ev = data.method.cfg.evaluation
    windows = eval_windows(data.dances, split, ev.clip_seconds, ev.hop_seconds)
    if len(windows) < 2:
        raise ValueError(
            f"the held-out parts hold {len(windows)} window(s) of {ev.clip_seconds} s; the tables need 2 or "
            "more (lower method.evaluation.clip_seconds or raise method.test_fraction)"
        )
    return windows, [window_clip(data.dances[w.dance], w) for w in windows]


def generate(
    ctx: RunContext,
    model: HarmoGANModel,
    music: Sequence[Clip],
    initial: Sequence[np.ndarray | None],
    seed: int,
) -> list[np.ndarray]:
    """One generated dance per music clip (clip k's noise seed: ``seed · 10007 + k``)."""
    out = []
    with ctx.timed("sample harmogan"):
        for k, (clip, pose) in enumerate(zip(music, initial)):
            assert clip.audio is not None and clip.sample_rate is not None
            out.append(model.generate(clip.audio, clip.sample_rate, pose, seed=int(seed) * 10007 + k))
    return out


def harmony_values(clips: Sequence[Clip], clip_seconds: float) -> dict[str, np.ndarray]:
    """Per-clip ``h`` and hit rate (the registered metric's code, audio cut to the motion, 6-s windows)."""
    cfg = HarmonyConfig(window_seconds=clip_seconds)
    h, hr = [], []
    for clip in clips:
        results = clip_harmony(clip, cfg)
        h.append(np.mean([r.h for r in results]))
        hr.append(np.mean([r.hit_rate for r in results]))
    return {"h": np.asarray(h), "hit_rate": np.asarray(hr)}


def motion_values(
    motions: Sequence[np.ndarray], truth: Sequence[np.ndarray], reference_bones: np.ndarray
) -> dict[str, np.ndarray]:
    """Per-clip motion measures against the ground-truth clips (Fig. 9 and the realism checks).

    * ``mse`` — mean squared error of the root-centred 3D positions (m²; Eq. 14's quantity);
    * ``cosine`` — mean over frames of ``1 − cos`` between the flattened generated and true poses;
    * ``bone_error`` — mean over bones of ``|mean length / the training data's mean length − 1|`` (%);
    * ``foot_height`` — median over frames of the lowest foot point's height relative to the root (cm);
    * ``foot_error`` — its absolute difference from the ground-truth clip's (cm).
    """
    bones = get_skeleton("dwm21").bones
    out: dict[str, list[float]] = {
        "mse": [],
        "cosine": [],
        "bone_error": [],
        "foot_height": [],
        "foot_error": [],
    }
    for gen, ref in zip(motions, truth):
        g, r = np.asarray(gen, np.float64), np.asarray(ref, np.float64)
        n = min(len(g), len(r))
        g, r = g[:n], r[:n]
        out["mse"].append(float(np.mean((g - r) ** 2)))
        gf, rf = g.reshape(n, -1), r.reshape(n, -1)
        cos = (gf * rf).sum(-1) / np.maximum(np.linalg.norm(gf, axis=-1) * np.linalg.norm(rf, axis=-1), 1e-12)
        out["cosine"].append(float(np.mean(1.0 - cos)))
        lengths = np.asarray(bone_lengths(g, bones)).mean(axis=0)
        out["bone_error"].append(100.0 * float(np.mean(np.abs(lengths / reference_bones - 1.0))))
        foot = 100.0 * float(np.median(g[:, list(FEET), 1].min(axis=1)))
        out["foot_height"].append(foot)
        out["foot_error"].append(abs(foot - 100.0 * float(np.median(r[:, list(FEET), 1].min(axis=1)))))
    return {k: np.asarray(v) for k, v in out.items()}


def training_bones(dances: Sequence[Dance]) -> np.ndarray:
    """Mean bone lengths of the training parts (the reference of ``bone_error``)."""
    bones = get_skeleton("dwm21").bones
    return np.concatenate([np.asarray(bone_lengths(d.motion[: d.split_frame], bones)) for d in dances]).mean(
        0
    )


def with_row(cfg: DictConfig, kind: str) -> DictConfig:
    """``cfg`` as the calibration row ``kind`` (``truth`` or a :data:`CALIBRATION_ROWS` key)."""
    plain = OmegaConf.to_container(cfg, resolve=True)
    assert isinstance(plain, dict)
    return OmegaConf.create({**plain, "calibration_row": kind})


def row_clips(
    ctx: RunContext, cfg: DictConfig, data: RunData, seed: int, split: str = "test"
) -> tuple[dict[str, list[Clip]], list[Clip], dict[str, str]]:
    """The clips a row is scored on, per comparison variant, and the ground truth.

    Returns ``({variant: clips}, truth, artifacts)``: variant :data:`ROW` is the row itself (a trained
    model's samples, ``calibration_row: truth`` the ground truth itself, or a :data:`CALIBRATION_ROWS`
    perturbation); the others are ``shuffled``, ``ground truth`` and (model rows) ``other condition``,
    all on the same clips.
    """
    windows, truth = test_set(data, split)
    perm = derangement(len(truth))
    shuffled = [
        replace_motion(truth[i], clip_motion(truth[perm[i]], "harmony"), "/shuf") for i in range(len(truth))
    ]
    variants: dict[str, list[Clip]] = {"ground truth": truth, "shuffled": shuffled}
    kind = cfg.get("calibration_row")
    artifacts: dict[str, str] = {}
    ev = data.method.cfg.evaluation
    if kind is None:
        model, folder = fit_model(ctx, data, seed)
        artifacts["model"] = folder
        firsts: list[np.ndarray | None] = [clip_motion(c, "harmony")[0] for c in truth]
        own = generate(ctx, model, truth, firsts, seed)
        other = generate(ctx, model, [truth[perm[i]] for i in range(len(truth))], firsts, seed)
        variants[ROW] = [replace_motion(c, m, "/gen") for c, m in zip(truth, own)]
        variants["other condition"] = [replace_motion(c, m, "/other") for c, m in zip(truth, other)]
    elif kind == "truth":
        variants[ROW] = truth
    elif kind == "shuffled":
        variants[ROW] = shuffled
        del variants["shuffled"]
    elif kind == "half_beat":
        rows = []
        for w, clip in zip(windows, truth):
            dance = data.dances[w.dance]
            audio = shifted_audio(dance, w, 0.5 * beat_period(dance))
            rows.append(Clip(**{**clip.__dict__, "id": clip.id + "/half_beat", "audio": audio}))
        variants[ROW] = rows
    elif kind == "static":
        rng = np.random.default_rng([int(seed), 15])
        variants[ROW] = [
            replace_motion(c, static_pose(clip_motion(c, "harmony"), ev.static_noise_m, rng), "/static")
            for c in truth
        ]
    elif kind == "fast":
        variants[ROW] = [
            replace_motion(c, time_warped(data.dances[w.dance], w, ev.speed_factor), "/fast")
            for w, c in zip(windows, truth)
        ]
    else:
        raise ValueError(f"calibration_row: {kind!r} is not one of {', '.join(CALIBRATION_ROWS)} (or null)")
    return variants, truth, artifacts
