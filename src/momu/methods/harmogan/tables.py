"""The cells of HarmoGAN's Tables I–II and Figures 9, 11 and 12 from per-clip measures (Scores API).

Each ``evaluate_*`` is a table runner ``evaluate(ctx, row_config, seed) -> Scores``: the row's cells,
and per column the per-clip values of the row and of its comparison variants on the same clips
(:func:`momu.methods.harmogan.evaluate.row_clips`), so the runner gives intervals and verdicts.

* Tables I / II (:func:`evaluate_table1`, :func:`evaluate_table2`): ``h`` / hit rate (%) per genre
  column and their average. The paper's "Average" is the unweighted mean of its genre columns
  (checked to 4 decimals), so the average column's per-clip components are the clip values weighted
  by ``N / (G · n_g)`` (``G`` genres, ``n_g`` clips of the clip's genre): their plain mean is the
  mean of the genre means. Columns: the Dance with Melody stand-in's four genres (cha-cha, rumba,
  tango, waltz: its held-out windows) or, with ``ballroom.root`` set, the paper's seven Ballroom
  columns (:mod:`momu.methods.harmogan.ballroom`; model rows and the static-pose row only — the other
  calibration rows need ground-truth motion and stay on the Dance with Melody windows).
* Fig. 12 (:func:`evaluate_fig12`): ``h`` and hit rate over all held-out windows.
* Fig. 9 (:func:`evaluate_fig9`): MSE, cosine distance, a Fréchet distance of poses (a stand-in for
  the paper's FID; LPIPS needs pretrained image networks and is not computed) and the realism checks
  (bone-length error, foot height).
* Fig. 11 (:func:`evaluate_fig11`): the metric side of the user study.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np
from omegaconf import DictConfig

from momu.config import ConfigError, build_component
from momu.data.types import Clip
from momu.engine.context import RunContext
from momu.engine.scores import ROW, Scores
from momu.io import write_json
from momu.methods.harmogan.ballroom import ballroom_test_clips
from momu.methods.harmogan.data import Window, replace_motion
from momu.methods.harmogan.evaluate import (
    RunData,
    fit_model,
    generate,
    harmony_values,
    motion_values,
    row_clips,
    run_data,
    test_set,
    training_bones,
    with_row,
)
from momu.methods.harmogan.perturb import chunk_permuted, static_pose, time_warped
from momu.methods.momu.scoring import derangement
from momu.metrics._clips import clip_motion
from momu.metrics.frechet import frechet_distance

__all__ = [
    "DWM_GENRES",
    "genre_scores",
    "check_genre_columns",
    "evaluate_table1",
    "evaluate_table2",
    "evaluate_fig12",
    "evaluate_fig9",
    "evaluate_fig11",
    "calibrate_table1",
    "calibrate_table2",
    "calibrate_fig12",
    "calibrate_fig9",
    "calibrate_fig11",
]

DWM_GENRES: tuple[str, ...] = ("cha-cha", "rumba", "tango", "waltz")


def check_genre_columns(cfg: DictConfig) -> None:
    """A Table I/II row must have clips of a genre column: fail before training when it has none.

    A row scores the Ballroom clips (``ballroom.root`` set, model and static-pose rows) or the dance
    data's held-out windows. The synthetic stand-in (no ``dance.root``) has no ballroom genre unless
    ``dance.synth_dataset.styles`` names one, and its table would come out empty.

    Raises:
        ConfigError: the row's clips would fall in no genre column.
    """
    on_ballroom = (cfg.get("ballroom") or {}).get("root") and cfg.get("calibration_row") in (None, "static")
    dance = cfg.get("dance") or {}
    if on_ballroom or dance.get("root"):
        return
    styles = list((dance.get("synth_dataset") or {}).get("styles") or [])
    if not set(styles) & set(DWM_GENRES):
        raise ConfigError(
            f"dance.synth_dataset.styles: the synthetic stand-in's styles ({', '.join(styles) or 'none'}) "
            f"are no ballroom genre ({', '.join(DWM_GENRES)}), so Tables I-II would have no column; "
            "pass --data DIR (a folder holding dance_with_melody/) or ballroom.root=DIR"
        )


def genre_scores(
    values: Mapping[str, np.ndarray], styles: Sequence[str | None], prefix: str, genres: Sequence[str]
) -> Scores:
    """Per-genre and average cells (``<prefix>_<genre>``, ``<prefix>_average``) of per-clip ``values``
    ``{variant: (N,)}``; see the module docstring for the average's weights."""
    style = np.asarray([s or "" for s in styles])
    scores = Scores(metrics={})
    present = [g for g in genres if np.any(style == g)]
    counts = {g: int(np.sum(style == g)) for g in present}
    inside = np.isin(style, present)
    weights = np.zeros(len(style))
    for g in present:
        weights[style == g] = inside.sum() / (len(present) * counts[g])
    for variant, v in values.items():
        for g in present:
            scores.add_clips(f"{prefix}_{g}", variant, v[style == g])
        if present:
            scores.add_clips(f"{prefix}_average", variant, (v * weights)[inside])
    for g in present:
        scores.metrics[f"{prefix}_{g}"] = float(values[ROW][style == g].mean())
    if present:
        scores.metrics[f"{prefix}_average"] = float(
            np.mean([scores.metrics[f"{prefix}_{g}"] for g in present])
        )
    return scores


def _harmony_variants(clips: Mapping[str, list[Clip]], seconds: float) -> dict[str, dict[str, np.ndarray]]:
    return {variant: harmony_values(c, seconds) for variant, c in clips.items()}


def _ballroom_row(
    ctx: RunContext, cfg: DictConfig, data: RunData, seed: int
) -> tuple[dict[str, list[Clip]], dict[str, str]]:
    """Model and static-pose rows on the Ballroom clips (no ground-truth motion: *other condition* only)."""
    node = dict(cfg.ballroom.dataset)
    node["root"] = str(cfg.ballroom.root)
    music = ballroom_test_clips(
        build_component(node, "datasets"),
        float(cfg.ballroom.fraction),
        data.method.cfg.evaluation.clip_seconds,
        int(cfg.ballroom.seed),
    )
    if len(music) < 2:
        raise ValueError("ballroom: fewer than 2 test clips")
    fps = data.method.cfg.fps
    frames = [int(np.floor(c.duration * fps + 1e-6)) for c in music]
    if cfg.get("calibration_row") == "static":
        rng = np.random.default_rng([int(seed), 15])
        mean = np.concatenate([d.motion[: d.split_frame] for d in data.dances]).mean(axis=0)
        ev = data.method.cfg.evaluation
        rows = [
            Clip(
                **{
                    **c.__dict__,
                    "motion": static_pose(np.repeat(mean[None], n, 0), ev.static_noise_m, rng),
                    "fps": fps,
                }
            )
            for c, n in zip(music, frames)
        ]
        return {ROW: rows}, {}
    model, folder = fit_model(ctx, data, seed)
    perm = derangement(len(music))
    own = generate(ctx, model, music, [None] * len(music), seed)
    other = generate(ctx, model, [music[perm[i]] for i in range(len(music))], [None] * len(music), seed)
    base = [Clip(**{**c.__dict__, "fps": fps, "skeleton": "dwm21"}) for c in music]
    return (
        {
            ROW: [replace_motion(c, m[:n], "/gen") for c, m, n in zip(base, own, frames)],
            "other condition": [replace_motion(c, m[:n], "/other") for c, m, n in zip(base, other, frames)],
        },
        {"model": folder},
    )


def _table(ctx: RunContext, cfg: DictConfig, seed: int, metric: str, scale: float) -> Scores:
    data = run_data(ctx, cfg)
    seconds = data.method.cfg.evaluation.clip_seconds
    ballroom = (cfg.get("ballroom") or {}).get("root")
    if ballroom and cfg.get("calibration_row") in (None, "static"):
        from momu.methods.harmogan.ballroom import COLUMNS

        clips, artifacts = _ballroom_row(ctx, cfg, data, seed)
        genres: Sequence[str] = COLUMNS
    else:
        clips, _, artifacts = row_clips(ctx, cfg, data, seed)
        genres = DWM_GENRES
    with ctx.timed("metrics"):
        values = {v: scale * h[metric] for v, h in _harmony_variants(clips, seconds).items()}
    scores = genre_scores(values, [c.style for c in clips[ROW]], "h" if metric == "h" else "hit_rate", genres)
    scores.artifacts.update(artifacts)
    scores.metrics["clips"] = float(len(clips[ROW]))
    return scores


def record_timings(ctx: RunContext, scores: Scores) -> Scores:
    """Write the run's wall and CPU seconds per category so far (training stages, sampling, metrics, data)
    to ``<out>/<table>/timings.json`` (main process); returns ``scores``."""
    if ctx.accelerator.is_main_process:
        write_json(ctx.out_dir / "timings.json", ctx.timings)
    return scores


def evaluate_table1(ctx: RunContext, cfg: DictConfig, seed: int) -> Scores:
    """HarmoGAN Table I: harmony score ``h`` per genre column and their average."""
    return record_timings(ctx, _table(ctx, cfg, seed, "h", 1.0))


def evaluate_table2(ctx: RunContext, cfg: DictConfig, seed: int) -> Scores:
    """HarmoGAN Table II: hit rate (%) per genre column and their average."""
    return record_timings(ctx, _table(ctx, cfg, seed, "hit_rate", 100.0))


def evaluate_fig12(ctx: RunContext, cfg: DictConfig, seed: int) -> Scores:
    """HarmoGAN Fig. 12: ``h`` and hit rate (%) over all held-out windows of the Dance data."""
    data = run_data(ctx, cfg)
    clips, _, artifacts = row_clips(ctx, cfg, data, seed)
    with ctx.timed("metrics"):
        values = _harmony_variants(clips, data.method.cfg.evaluation.clip_seconds)
    scores = Scores(metrics={}, artifacts=artifacts)
    ids = [c.id for c in clips["ground truth"]]  # every variant is scored on these windows
    for key, scale in (("h", 1.0), ("hit_rate", 100.0)):
        for variant, v in values.items():
            scores.add_clips(key, variant, scale * v[key], ids=ids)
        scores.metrics[key] = float(scale * values[ROW][key].mean())
    scores.metrics["clips"] = float(len(clips[ROW]))
    return record_timings(ctx, scores)


def evaluate_fig9(ctx: RunContext, cfg: DictConfig, seed: int) -> Scores:
    """HarmoGAN Fig. 9: MSE, cosine distance and a pose Fréchet distance against ground truth, plus the
    realism checks (bone-length error %, foot height cm); per clip against the same ground truth.

    The pose FD of the ground-truth row is the training frames against the held-out frames (the
    real-vs-real floor), and that same quantity is the *ground truth* every row's pose FD is compared
    with: the held-out frames against themselves would be 0 by construction and say nothing. The
    shuffled, half-beat and ×1.25 calibration rows pool the held-out frames themselves, so their pose
    FD is 0 up to rounding and the same for every seed (no verdict: :func:`momu.engine.statistics.judge`).
    """
    data = run_data(ctx, cfg)
    clips, truth, artifacts = row_clips(ctx, cfg, data, seed)
    true_motion = [clip_motion(c, "fig9") for c in truth]
    ids = [c.id for c in truth]  # every variant is scored against these windows
    bones = training_bones(data.dances)
    scores = Scores(metrics={}, artifacts=artifacts)
    with ctx.timed("metrics"):
        for variant, cs in clips.items():
            vals = motion_values([clip_motion(c, "fig9") for c in cs], true_motion, bones)
            for key, v in vals.items():
                scores.add_clips(key, variant, v, ids=ids)
                if variant == ROW:
                    scores.metrics[key] = float(v.mean())
        gt_frames = np.concatenate([m.reshape(len(m), -1) for m in true_motion])
        train = np.concatenate([d.motion[: d.split_frame].reshape(d.split_frame, -1) for d in data.dances])
        floor = frechet_distance(train, gt_frames)
        if cfg.get("calibration_row") == "truth":
            scores.metrics["fid"] = floor
        else:
            row_frames = np.concatenate([np.asarray(c.motion).reshape(c.num_frames, -1) for c in clips[ROW]])
            scores.metrics["fid"] = frechet_distance(row_frames, gt_frames)
            scores.add_seed_value("fid", "ground truth", floor)
    return record_timings(ctx, scores)


FIG11_KINDS = ("chunks", "slow", "fast", "shuffled", "half_beat", "static")


def evaluate_fig11(ctx: RunContext, cfg: DictConfig, seed: int) -> Scores:
    """HarmoGAN Fig. 11 (metric side): on every 6-s window of the dances, how often ``h`` (and the hit
    rate) ranks the ground truth above its perturbation (%; ties count ½), and the perturbed ``h``."""
    data = run_data(ctx, cfg)
    kinds = list(cfg.get("fig11_perturbations") or ["chunks"])
    bad = [k for k in kinds if k not in FIG11_KINDS]
    if bad:
        raise ValueError(f"fig11_perturbations: unknown {bad}; valid: {', '.join(FIG11_KINDS)}")
    ev = data.method.cfg.evaluation
    windows, truth = test_set(data, split="all")
    gt = harmony_values(truth, ev.clip_seconds)
    agree_h, agree_hr, pert_h, gt_h = [], [], [], []
    rng = np.random.default_rng([int(seed), 11])
    for kind in kinds:
        if kind in ("chunks", "slow", "fast"):
            pert = [
                replace_motion(c, _fig11_motion(data, w, c, kind, rng), f"/{kind}")
                for w, c in zip(windows, truth)
            ]
        else:
            sub = DictConfig({"calibration_row": kind})
            pert = row_clips(ctx, sub, data, seed, split="all")[0][ROW]
        with ctx.timed("metrics"):
            p = harmony_values(pert, ev.clip_seconds)
        agree_h.append(_agreement(gt["h"], p["h"]))
        agree_hr.append(_agreement(gt["hit_rate"], p["hit_rate"]))
        pert_h.append(p["h"])
        gt_h.append(gt["h"])
    scores = Scores(metrics={})
    for key, values in (("agreement_h", agree_h), ("agreement_hit_rate", agree_hr)):
        v = np.concatenate(values)
        scores.add_clips(key, ROW, v)
        scores.metrics[key] = float(v.mean())
    scores.add_clips("h", ROW, np.concatenate(pert_h))
    scores.add_clips("h", "ground truth", np.concatenate(gt_h))
    scores.metrics["h"] = float(np.concatenate(pert_h).mean())
    scores.metrics["pairs"] = float(len(np.concatenate(pert_h)))
    return record_timings(ctx, scores)


def _fig11_motion(
    data: RunData, window: Window, clip: Clip, kind: str, rng: np.random.Generator
) -> np.ndarray:
    ev = data.method.cfg.evaluation
    dance = data.dances[window.dance]
    if kind == "chunks":
        return chunk_permuted(clip_motion(clip, "fig11"), int(round(ev.chunk_seconds * dance.fps)), rng)
    return time_warped(dance, window, ev.slow_factor if kind == "slow" else ev.speed_factor)


def _agreement(truth: np.ndarray, perturbed: np.ndarray) -> np.ndarray:
    """Per pair: 100 when the ground truth scores higher, 50 on a tie, 0 otherwise."""
    return 100.0 * ((truth > perturbed) + 0.5 * (truth == perturbed))


def calibrate_table1(ctx: RunContext, cfg: DictConfig, seed: int) -> dict[str, Scores]:
    """Table I's ground-truth row (the same code, ``calibration_row: truth``)."""
    return {"ground truth": _as_dwm(evaluate_table1(ctx, with_row(cfg, "truth"), seed))}


def calibrate_table2(ctx: RunContext, cfg: DictConfig, seed: int) -> dict[str, Scores]:
    """Table II's ground-truth row."""
    return {"ground truth": _as_dwm(evaluate_table2(ctx, with_row(cfg, "truth"), seed))}


def calibrate_fig12(ctx: RunContext, cfg: DictConfig, seed: int) -> dict[str, Scores]:
    """Fig. 12's human ground-truth bar."""
    return {"ground truth": evaluate_fig12(ctx, with_row(cfg, "truth"), seed)}


def calibrate_fig9(ctx: RunContext, cfg: DictConfig, seed: int) -> dict[str, Scores]:
    """Fig. 9's ground-truth row (MSE and cosine 0 by construction; the realism checks of the data)."""
    return {"ground truth": evaluate_fig9(ctx, with_row(cfg, "truth"), seed)}


def calibrate_fig11(ctx: RunContext, cfg: DictConfig, seed: int) -> dict[str, Scores]:
    """Fig. 11's ground-truth ``h`` over the same windows."""
    data = run_data(ctx, cfg)
    _, truth = test_set(data, split="all")
    h = harmony_values(truth, data.method.cfg.evaluation.clip_seconds)["h"]
    return {"ground truth": Scores(metrics={"h": float(h.mean()), "pairs": float(len(h))})}


def _as_dwm(scores: Scores) -> Scores:
    """Cells only (the ground-truth row is always on the Dance with Melody windows)."""
    return Scores(metrics=dict(scores.metrics))
