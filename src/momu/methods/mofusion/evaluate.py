"""Evaluation of MoFusion's music rows (Table 1, supp. Tables 1–2) and their calibration rows.

Per evaluation clip *i* (the first ``num_clips`` test clips cut to ``seconds``) the model generates
from clip *i*'s music (``row``) and — same sampling seed — from clip π(i)'s music (*other
condition*, π(i) = (i + 1) mod N); ``mode: forecast`` keeps the first ``seed_seconds`` of clip
*i*'s ground truth (supp. Table 2). Every motion — generated at 20 fps, ground truth after the same
60 → 20 fps step — is resampled to ``metric_fps`` = 60 before the Bailando-scale metrics (A2).

Columns (``Scores.metrics``; per-clip evidence for the paired comparisons where a clip has a value):

* ``bas`` — MoFusion Eq. 10 (``bas``, Bailando variant, σ = 3 frames at 60 fps, librosa music beats)
  per clip; *shuffled* = clip π(i)'s ground-truth motion against clip i's music, *ground truth* =
  clip i's own; ``bas_after_seed`` drops the seed frames from both beat sets (A15).
* ``fid_k`` (↓) and ``div_k`` (↑) — Bailando's kinetic FID / Div against the evaluation clips' ground
  truth (distributional; this seed's real-vs-real floor — ``reference_split`` crops — and the
  ground truth's Div as *ground truth*).
* ``multimodality`` (↑) — MoFusion §4.1: kinetic-feature distance between K generations per music.
* ``bone_std_cm`` / ``asym_cm`` (↓, supp. Table 1's kinematic columns) — per clip, the temporal std
  of every bone length (mean over bones) and the mean left/right bone-length difference, in cm, at
  the model's rate; *ground truth* is the data's own floor.
* ``seed_error_cm`` and ``boundary_jump`` (supp. Table 2) — max deviation from the seed over the
  seed frames (0 by construction) and the speed change across the seed boundary (m/s, mean over
  joints), against ground truth's.
"""

from __future__ import annotations

import dataclasses
import logging
from pathlib import Path
from typing import Any

import numpy as np
from omegaconf import DictConfig

from momu.config import build_component, to_container
from momu.data.types import Clip
from momu.engine.context import RunContext
from momu.engine.evaluate import map_gathered
from momu.engine.scores import ROW, Scores
from momu.features.bones import bone_lengths
from momu.features.mofusion_pose import mirror_bone_pairs
from momu.features.skeletons import get_skeleton
from momu.methods.mofusion.data import crop, global_positions, resample_motion, split_indices
from momu.methods.mofusion.method import MoFusion
from momu.methods.mofusion.model import MoFusionModel
from momu.methods.momu.generation import eval_seeds
from momu.methods.momu.scoring import derangement, excerpt_ids
from momu.metrics.beat_align import bas
from momu.metrics.beats import music_beats
from momu.registry import METRICS

__all__ = [
    "fit_mofusion",
    "eval_clips",
    "metric_motion",
    "evaluate_music",
    "calibrate_music",
    "kinematic_columns",
    "repeated_samples",
]

log = logging.getLogger(__name__)
OTHER = "other condition"


SHARED_PARTS = "mofusion_shared"
"""Folder beside the tables' folders whose ``parts/`` holds every MoFusion stage, so Table 1 and
supp. Tables 1–2 run with the same ``--out`` train each model once (supp. A: no retraining)."""


def shared_context(ctx: RunContext) -> RunContext:
    """``ctx`` with its stage cache in ``<out>/mofusion_shared/parts`` (the records stay ``ctx``'s)."""
    return dataclasses.replace(ctx, out_dir=ctx.out_dir.parent / SHARED_PARTS)


def fit_mofusion(ctx: RunContext, cfg: DictConfig, seed: int) -> tuple[MoFusion, MoFusionModel, Any, str]:
    """Train (or reuse) ``cfg.method`` on ``cfg.dataset`` for ``seed``; the model is saved once under
    ``<out>/models/<stage folder>``. Returns ``(method, model, dataset, model folder relative to out)``.

    The stage is cached in the tables' shared folder (:func:`shared_context`)."""
    method = build_component(cfg.method, "methods")
    if not isinstance(method, MoFusion):
        raise ValueError(f"method: expected 'mofusion', got {type(method).__name__}")
    dataset = build_component(cfg.dataset, "datasets")
    model, stage = method.fit(shared_context(ctx), dataset, to_container(cfg.dataset), seed)
    folder = ctx.out_dir / "models" / stage
    if ctx.accelerator.is_main_process and not (folder / "mofusion.json").is_file():
        model.save(folder)
    return method, model, dataset, str(Path("models") / stage)


def eval_clips(
    dataset: Any, split: str, count: int, seconds: float, task: str, *, keep_shorter: bool = False
) -> list[Clip]:
    """The first ``count`` clips of ``split``, cut to ``[0, seconds)``.

    A clip shorter than ``seconds`` is skipped, or kept whole with ``keep_shorter`` (text→motion:
    each caption is generated at its clip's own length, T2M's protocol). Per-clip values are
    recorded under :func:`~momu.methods.momu.scoring.excerpt_ids` (clip and length), so rows scored
    on other lengths of the same clips are never paired clip by clip.
    """
    out = []
    for i in split_indices(dataset, split, task):
        clip = dataset[i]
        if clip.duration + 1e-6 >= seconds:
            out.append(crop(clip, 0.0, seconds))
        elif keep_shorter:
            out.append(crop(clip, 0.0, clip.duration))
        if len(out) == count:
            break
    if len(out) < 2:
        longer = "" if keep_shorter else f" of {seconds} s or more"
        raise ValueError(f"method.evaluation: fewer than 2 '{split}' clips{longer}")
    return out


def metric_motion(motion: np.ndarray, fps: float, model_fps: float, metric_fps: float) -> np.ndarray:
    """Motion at ``fps`` through the model's rate to ``metric_fps`` (ground truth and samples alike)."""
    at_model = resample_motion(motion, fps, model_fps) if abs(fps - model_fps) > 1e-9 else motion
    return resample_motion(at_model, model_fps, metric_fps).astype(np.float32)


def _music(clip: Clip) -> tuple[np.ndarray, int]:
    if clip.audio is None or not clip.sample_rate:
        raise ValueError(f"clip {clip.id!r} has no audio")
    return np.asarray(clip.audio), int(clip.sample_rate)


def _motion(clip: Clip) -> np.ndarray:
    if clip.motion is None:
        raise ValueError(f"clip {clip.id!r} has no motion")
    return np.asarray(clip.motion)


def _clip(base: Clip, motion: np.ndarray, fps: float, suffix: str, **meta: Any) -> Clip:
    return dataclasses.replace(
        base, id=base.id + suffix, motion=motion, fps=fps, trajectory=None, meta={**base.meta, **meta}
    )


def kinematic_columns(positions: np.ndarray, skeleton: str) -> tuple[float, float]:
    """``(bone-length temporal std, L/R bone-length difference)`` of one motion, in cm."""
    sk = get_skeleton(skeleton)
    lengths = bone_lengths(np.asarray(positions, dtype=np.float64), sk.bones)  # (T, B)
    pairs = mirror_bone_pairs(sk)
    asym = np.mean([np.abs(lengths[:, a] - lengths[:, b]).mean() for a, b in pairs]) if pairs else 0.0
    return 100.0 * float(lengths.std(axis=0, ddof=1).mean()), 100.0 * float(asym)


def _beats(clips: list[Clip], metric_fps: float) -> list[np.ndarray]:
    from momu.metrics.beats import resample_beat_frames

    return [resample_beat_frames(music_beats(*_music(c), recipe="bailando"), 60.0, metric_fps) for c in clips]


def _bas(motions: list[np.ndarray], beats: list[np.ndarray], seed_frames: int = 0) -> np.ndarray:
    return np.asarray([bas(m, b, seed_frames=seed_frames) for m, b in zip(motions, beats)], dtype=np.float64)


def _generate(
    ctx: RunContext, model: MoFusionModel, truth: list[Clip], ev: Any, seed: int
) -> dict[str, list]:
    """Samples at the model rate: ``row`` (own music) and ``other condition`` (clip π(i)'s music)."""
    perm = derangement(len(truth))

    def generate(indices: list[int]) -> list[dict[str, np.ndarray]]:
        seeds = eval_seeds(seed, indices)
        music = [_music(truth[j]) for j in indices]
        music += [_music(truth[perm[j]]) for j in indices]
        secs = [ev.seconds] * len(music)
        if ev.mode == "forecast":
            motions = [global_positions(truth[j]) for j in indices] * 2
            out = model.forecast(
                motions, music, secs, seeds * 2, seed_seconds=ev.seed_seconds, fps=truth[0].fps
            )
        else:
            out = model.music_to_dance(music, secs, seeds * 2)
        n = len(indices)
        return [{ROW: out[k], OTHER: out[n + k]} for k in range(n)]

    with ctx.timed("sample music→dance"):
        res = map_gathered(
            ctx.accelerator, list(range(len(truth))), generate, batch_size=ev.batch_size, desc="mofusion"
        )
    return {v: [r[v] for r in res] for v in (ROW, OTHER)}


def repeated_samples(
    ctx: RunContext,
    sample: Any,
    conds: list[Any],
    ev: Any,
    seed: int,
    seconds: list[float] | None = None,
) -> tuple[list[tuple[int, int]], list[np.ndarray]]:
    """``multimodality_samples`` generations for each of the first ``multimodality_clips`` conditions.

    ``sample(conds, seconds, seeds)`` is the model's generator (music or text); generation ``s`` of
    condition ``i`` has its own seed and is ``seconds[i]`` long (default: ``ev.seconds`` for all).
    Returns the ``(i, s)`` jobs and the motions, in job order.
    """
    k, m = int(ev.multimodality_samples), min(int(ev.multimodality_clips), len(conds))
    jobs = [(i, s) for i in range(m) for s in range(k)]
    lengths = [float(ev.seconds)] * len(conds) if seconds is None else [float(s) for s in seconds]

    def generate(indices: list[int]) -> list[np.ndarray]:
        seeds = [seed * 100_003 + 10_007 * (1 + jobs[j][1]) + jobs[j][0] for j in indices]
        conditions = [conds[jobs[j][0]] for j in indices]
        return list(sample(conditions, [lengths[jobs[j][0]] for j in indices], seeds))

    with ctx.timed("sample multimodality"):
        res = map_gathered(
            ctx.accelerator, list(range(len(jobs))), generate, batch_size=ev.batch_size, desc="mmodality"
        )
    return jobs, res


def _multimodality(
    ctx: RunContext, model: MoFusionModel, truth: list[Clip], gt: list[Clip], ev: Any, seed: int
) -> float:
    jobs, res = repeated_samples(ctx, model.music_to_dance, [_music(c) for c in truth], ev, seed)
    clips = [
        _clip(
            truth[i],
            metric_motion(r, model.fps, model.fps, ev.metric_fps),
            ev.metric_fps,
            f"/mm{s}",
            condition_id=i,
        )
        for (i, s), r in zip(jobs, res)
    ]
    return float(METRICS.build("multimodality", {})(clips, gt)["multimodality"])


def _distributional(gen: list[Clip], ref: list[Clip]) -> dict[str, float]:
    return {
        "fid_k": float(METRICS.build("fid_k", {})(gen, ref)["fid_k"]),
        "div_k": float(METRICS.build("div_k", {})(gen, ref)["div_k"]),
    }


def _gt_metric_clips(clips: list[Clip], ev: Any, model_fps: float) -> list[Clip]:
    return [
        _clip(c, metric_motion(global_positions(c), c.fps, model_fps, ev.metric_fps), ev.metric_fps, "/gt")
        for c in clips
    ]


def evaluate_music(ctx: RunContext, cfg: DictConfig, seed: int) -> Scores:
    """One music row for one seed: train (or reuse), generate, score (see the module docstring)."""
    method, model, dataset, folder = fit_mofusion(ctx, cfg, seed)
    ev = method.cfg.evaluation
    truth = eval_clips(dataset, ev.split, ev.num_clips, ev.seconds, "music")
    scores = Scores(metrics={}, artifacts={"model": folder})
    samples = _generate(ctx, model, truth, ev, seed)
    fps, mfps = model.fps, float(ev.metric_fps)
    with ctx.timed("metrics"):
        beats = _beats(truth, mfps)
        gt = _gt_metric_clips(truth, ev, fps)
        gen = {v: [metric_motion(m, fps, fps, mfps) for m in samples[v]] for v in samples}
        perm = derangement(len(truth))
        gt_motion = [_motion(c) for c in gt]
        ids = excerpt_ids(truth)  # every variant is scored on these crops
        scores.add_clips("bas", ROW, _bas(gen[ROW], beats), ids=ids)
        scores.add_clips("bas", OTHER, _bas(gen[OTHER], beats), ids=ids)
        scores.add_clips("bas", "shuffled", _bas([gt_motion[p] for p in perm], beats), ids=ids)
        scores.add_clips("bas", "ground truth", _bas(gt_motion, beats), ids=ids)
        seed_frames = int(round(ev.seed_seconds * mfps)) if ev.mode == "forecast" else 0
        after = {
            ROW: _bas(gen[ROW], beats, seed_frames),
            "ground truth": _bas(gt_motion, beats, seed_frames),
            "shuffled": _bas([gt_motion[p] for p in perm], beats, seed_frames),
        }
        for variant, values in after.items():
            scores.add_clips("bas_after_seed", variant, values, ids=ids)
        gen_clips = [_clip(t, m, mfps, "/gen") for t, m in zip(truth, gen[ROW])]
        scores.metrics.update(_distributional(gen_clips, gt))
        others = eval_clips(dataset, ev.reference_split, len(truth), ev.seconds, "music")
        floor = _distributional(_gt_metric_clips(others, ev, fps), gt)
        scores.add_seed_value("fid_k", "ground truth", floor["fid_k"])
        scores.add_seed_value("div_k", "ground truth", float(METRICS.build("div_k", {})(gt, gt)["div_k"]))
        _kinematics(scores, samples[ROW], truth, model)
        if ev.mode == "forecast":
            _forecast_columns(scores, samples[ROW], truth, model, ev)
        scores.metrics["bas"] = float(scores.clips["bas"][ROW].mean())
        scores.metrics["bas_after_seed"] = float(after[ROW].mean())
        scores.metrics["bas_other_condition"] = float(scores.clips["bas"][OTHER].mean())
    if ev.mode == "generate":
        with ctx.timed("metrics"):
            scores.metrics["multimodality"] = _multimodality(ctx, model, truth, gt, ev, seed)
    return scores


def _kinematics(scores: Scores, samples: list[np.ndarray], truth: list[Clip], model: MoFusionModel) -> None:
    ids = excerpt_ids(truth)
    gen = np.asarray([kinematic_columns(m, model.skeleton) for m in samples])
    gt = np.asarray(
        [
            kinematic_columns(resample_motion(global_positions(c), c.fps, model.fps), model.skeleton)
            for c in truth
        ]
    )
    for k, key in enumerate(("bone_std_cm", "asym_cm")):
        scores.add_clips(key, ROW, gen[:, k], ids=ids)
        scores.add_clips(key, "ground truth", gt[:, k], ids=ids)
        scores.metrics[key] = float(gen[:, k].mean())


def _boundary_jump(positions: np.ndarray, s: int, fps: float) -> float:
    """Mean over joints of ``|v(s) − v(s−1)|`` (m/s), velocities by first differences at ``fps``."""
    v = np.diff(np.asarray(positions, dtype=np.float64), axis=0) * fps  # v[k] = p[k+1] − p[k]
    return float(np.linalg.norm(v[s - 1] - v[s - 2], axis=-1).mean())


def _forecast_columns(
    scores: Scores, samples: list[np.ndarray], truth: list[Clip], model: MoFusionModel, ev: Any
) -> None:
    s = int(round(ev.seed_seconds * model.fps))
    gt = [resample_motion(global_positions(c), c.fps, model.fps) for c in truth]
    err = np.asarray([100.0 * float(np.abs(m[:s] - g[:s]).max()) for m, g in zip(samples, gt)])
    jump = np.asarray([_boundary_jump(m, s, model.fps) for m in samples])
    jump_gt = np.asarray([_boundary_jump(g, s, model.fps) for g in gt])
    ids = excerpt_ids(truth)
    scores.add_clips("seed_error_cm", ROW, err, ids=ids)
    scores.add_clips("boundary_jump", ROW, jump, ids=ids)
    scores.add_clips("boundary_jump", "ground truth", jump_gt, ids=ids)
    scores.metrics["seed_error_cm"] = float(err.mean())
    scores.metrics["boundary_jump"] = float(jump.mean())


def calibrate_music(ctx: RunContext, cfg: DictConfig, seed: int) -> dict[str, Scores]:
    """Ground truth and shuffled ground truth (music of clip i, motion of clip π(i)), same metric code."""
    method = build_component(cfg.method, "methods")
    dataset = build_component(cfg.dataset, "datasets")
    ev = method.cfg.evaluation
    fps = float(method.cfg.fps)
    truth = eval_clips(dataset, ev.split, ev.num_clips, ev.seconds, "music")
    skeleton = str(truth[0].skeleton)  # the data's own (a loader such as aistpp has no skeleton key)
    with ctx.timed("metrics"):
        beats = _beats(truth, ev.metric_fps)
        gt = _gt_metric_clips(truth, ev, fps)
        perm = derangement(len(truth))
        others = _gt_metric_clips(
            eval_clips(dataset, ev.reference_split, len(truth), ev.seconds, "music"), ev, fps
        )
        floor = _distributional(others, gt)
        motion = [_motion(c) for c in gt]
        out = {}
        for name, order in (
            ("ground truth", list(range(len(gt)))),
            ("ground truth, music and motion shuffled", perm),
        ):
            sc = Scores(metrics=dict(floor))
            values = _bas([motion[p] for p in order], beats)
            sc.add_clips("bas", ROW, values, ids=excerpt_ids(truth))  # clip i's music
            sc.metrics["bas"] = float(values.mean())
            seed_frames = int(round(ev.seed_seconds * ev.metric_fps)) if ev.mode == "forecast" else 0
            sc.metrics["bas_after_seed"] = float(_bas([motion[p] for p in order], beats, seed_frames).mean())
            kin = np.asarray(
                [
                    kinematic_columns(
                        resample_motion(global_positions(truth[p]), truth[p].fps, fps), skeleton
                    )
                    for p in order
                ]
            )
            sc.metrics["bone_std_cm"], sc.metrics["asym_cm"] = (
                float(kin[:, 0].mean()),
                float(kin[:, 1].mean()),
            )
            sc.metrics["div_k"] = float(METRICS.build("div_k", {})(gt, gt)["div_k"])
            if ev.mode == "forecast":
                s = int(round(ev.seed_seconds * fps))
                gts = [resample_motion(global_positions(truth[p]), truth[p].fps, fps) for p in order]
                sc.metrics["boundary_jump"] = float(np.mean([_boundary_jump(g, s, fps) for g in gts]))
                sc.metrics["seed_error_cm"] = 0.0 if name == "ground truth" else float("nan")
            out[name] = sc
        out["ground truth, music and motion shuffled"].metrics.pop("seed_error_cm", None)
    return out
