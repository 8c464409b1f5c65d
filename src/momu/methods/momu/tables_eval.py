"""MoMu-Diffusion Tables 2–6: our row's evaluation (motion→music, music→motion) and the calibration rows.

Every beat column records per-clip evidence for its verdicts (:mod:`momu.methods.momu.scoring`):
the row, the *shuffled* calibration on the same clips, the same model given *another clip's
condition* and (music→motion) *ground truth*. Table 6's FID and Diversity are distributional: they
record this seed's real-vs-real floor (``reference_split`` crops against the evaluation clips);
Mean KLD is paired clip by clip and records per-clip values.
"""

from __future__ import annotations

import dataclasses
import logging
from collections.abc import Sequence
from typing import Any

import numpy as np
from omegaconf import DictConfig

from momu.config import ConfigError, build_component, to_container
from momu.data.types import Clip
from momu.engine.context import RunContext
from momu.engine.scores import ROW, Scores
from momu.engine.trainer import TrainConfig
from momu.methods.momu.data import eval_crops
from momu.methods.momu.evaluate import fit_momu
from momu.methods.momu.generation import generate_motion, generate_music
from momu.methods.momu.learnable import fit_learnable_motion_to_music
from momu.methods.momu.scoring import (
    add_beat_scores,
    beat_components,
    derangement,
    excerpt_ids,
    motion_onset_f1s,
    music_onset_f1s,
    replace_clip,
    trained_extractors,
)
from momu.methods.momu.tables_setup import check_subsets, shared_context, subset_config
from momu.metrics.learned import paired_kl_values
from momu.registry import METRICS

__all__ = ["evaluate_motion_to_music", "evaluate_music_to_motion", "calibrate_tables", "CALIBRATION_KINDS"]

log = logging.getLogger(__name__)

CALIBRATION_KINDS = ("music", "motion_beats", "motion_quality")


def _plot(ctx: RunContext, name: str, clip: Clip, *, figure: int) -> None:
    """MoMu Figure 4 (``figure=4``: generated music with the conditioning motion, poses at the
    musical beats) or Figure 5 (``figure=5``: generated motion with its music, poses at the
    kinematic beats) for one clip, written to ``<out>/<table>/<name>.png`` (main process only)."""
    if not ctx.accelerator.is_main_process:
        return
    try:
        from momu.render.beat_plot import clip_beat_figure

        what = (
            "generated music, conditioning motion" if figure == 4 else "generated motion, conditioning music"
        )
        clip_beat_figure(
            ctx.out_dir / f"{name}.png",
            clip,
            title=f"MoMu Figure {figure}-style beat matching: {clip.id} ({what})",
            strip_at="music" if figure == 4 else "motion",
        )
    except Exception as exc:  # a plot must never fail a table
        log.warning("beat plot skipped: %s", exc)


def _shuffled(truth: Sequence[Clip]) -> list[Clip]:
    perm = derangement(len(truth))
    return [
        replace_clip(truth[i], "/shuf", motion=truth[perm[i]].motion, audio=truth[perm[i]].audio)
        for i in range(len(truth))
    ]


def _truth(dataset: Any, ev: Any) -> list[Clip]:
    truth = eval_crops(dataset, ev.split, ev.num_clips, [float(ev.seconds)])
    if len(truth) < 2:
        raise ValueError(
            f"method.evaluation: the '{ev.split}' split has {len(truth)} clip; the table needs 2 or more"
        )
    return truth


def _train_config(node: Any) -> TrainConfig:
    params = dict(to_container(node) or {})
    valid = {f.name for f in dataclasses.fields(TrainConfig)}
    unknown = sorted(set(params) - valid)
    if unknown:
        raise ConfigError(
            f"learnable_train.{unknown[0]}: unknown key; valid keys: {', '.join(sorted(valid))}"
        )
    return TrainConfig(**params)


def _add_onsets(scores: Scores, key: str, by_variant: dict[str, np.ndarray], ids: list[str]) -> None:
    scores.metrics[key] = float(by_variant[ROW].mean())
    for variant, values in by_variant.items():
        scores.add_clips(key, variant, values, ids=ids)


# ---------------------------------------------------------------------------------------- motion→music
def evaluate_motion_to_music(
    ctx: RunContext, cfg: DictConfig, seed: int, *, subsets: Sequence[str], learnable: bool
) -> Scores:
    """Our row of Table 2 (``learnable=False``: the full method) or Tables 3–4 (learnable motion encoder).

    Per subset: train (or reuse) the model on its ``train`` split, generate music from each
    evaluation clip's motion and from clip π(i)'s (CFG, Eq. 7), and score both against clip *i*'s
    music with ``beat_scores`` (LORIS onsets, App. B.4).
    """
    check_subsets(cfg, subsets)
    sctx = shared_context(ctx)
    scores = Scores(metrics={})
    for sid in subsets:
        scfg = subset_config(cfg, sid)
        method = build_component(scfg.method, "methods")
        ev = method.cfg.evaluation
        if learnable:
            dataset = build_component(scfg.dataset, "datasets")
            model: Any = fit_learnable_motion_to_music(
                sctx,
                method,
                scfg.learnable_encoder,
                _train_config(scfg.learnable_train),
                dataset,
                to_container(scfg.dataset),
                seed,
                frames_per_latent=int(scfg.learnable_frames_per_latent),
            )
        else:
            _, model, dataset, _, folder = fit_momu(sctx, scfg, seed)
            scores.artifacts[f"{sid} model"] = str(folder.relative_to(sctx.out_dir.parent))
        truth = _truth(dataset, ev)
        gen = generate_music(ctx, model, truth, seed, ev.batch_size, other=ev.shuffled_condition)
        shuffled = _shuffled(truth)
        bins = float(ev.beat_bin_seconds)
        ids = excerpt_ids(truth)
        with ctx.timed("metrics"):
            beats = {v: beat_components("music", clips, truth, bins) for v, clips in gen.items()}
            beats["shuffled"] = beat_components("music", shuffled, truth, bins)
            add_beat_scores(scores, sid, beats, ids)
            onsets = {v: music_onset_f1s(clips, truth) for v, clips in gen.items()}
            onsets["shuffled"] = music_onset_f1s(shuffled, truth)
            _add_onsets(scores, f"{sid}_onset_f1", onsets, ids)
        _plot(ctx, f"{sid}_beats", gen[ROW][0], figure=4)  # generated audio, clip 0's motion
    return scores


# ---------------------------------------------------------------------------------------- music→motion
def _quality_extractor(ctx: RunContext, dataset: Any, data_key: Any, ev: Any) -> Any:
    with ctx.timed("extractors"):
        return trained_extractors(ctx, dataset, data_key, ev, kinds=("motion",))["motion"]


def _quality_cells(
    extractor: Any, generated: Sequence[Clip], reference: Sequence[Clip], prefix: str
) -> dict[str, float]:
    """FID (``fid_learned``), inter-Diversity (``diversity``) and paired Mean KLD (``mean_kld``)."""
    fid = METRICS.build("fid_learned", {}, extractor=extractor)(generated, reference)["fid_learned"]
    div = METRICS.build("diversity", {}, extractor=extractor)(generated)["diversity.inter"]
    kld = METRICS.build("mean_kld", {}, extractor=extractor)(generated, reference)["mean_kld"]
    return {f"{prefix}_fid": float(fid), f"{prefix}_diversity": float(div), f"{prefix}_mean_kld": float(kld)}


def _kl_per_clip(extractor: Any, generated: Sequence[Clip], reference: Sequence[Clip]) -> np.ndarray:
    return paired_kl_values(extractor.log_probabilities(reference), extractor.log_probabilities(generated))


def _floor_clips(dataset: Any, ev: Any, truth: Sequence[Clip], sid: str) -> list[Clip]:
    others = eval_crops(dataset, ev.reference_split, len(truth), [float(ev.seconds)])[: len(truth)]
    if len(others) != len(truth):
        raise ValueError(
            f"subset {sid}: {len(others)} '{ev.reference_split}' clips for {len(truth)} test clips"
        )
    return others


def evaluate_music_to_motion(
    ctx: RunContext, cfg: DictConfig, seed: int, *, subsets: Sequence[str], quality: bool
) -> Scores:
    """Our row of Table 5 (``quality=False``: beat scores) or Table 6 (FID / Diversity / Mean KLD).

    Per subset: train (or reuse) the full method, generate motion from each evaluation clip's
    music and from clip π(i)'s (CFG, Eq. 7). Table 5 scores the motion's kinematic beats against
    clip *i*'s music (``kinematic_beat_scores``, App. B.5). Table 6 compares generated and
    ground-truth motion with the subset's motion classifier: FID, inter-Diversity (App. B.4) and
    paired Mean KLD (clip *i*'s ground truth vs the motion generated from its music).
    """
    check_subsets(cfg, subsets)
    sctx = shared_context(ctx)
    scores = Scores(metrics={})
    for sid in subsets:
        scfg = subset_config(cfg, sid)
        _, model, dataset, data_key, folder = fit_momu(
            sctx, scfg, seed, extractors=("motion",) if quality else ()
        )
        scores.artifacts[f"{sid} model"] = str(folder.relative_to(sctx.out_dir.parent))
        ev = model.cfg.evaluation
        truth = _truth(dataset, ev)
        gen = generate_motion(
            ctx, model, truth, seed, ev.batch_size, other=ev.shuffled_condition and not quality
        )
        shuffled = _shuffled(truth)
        bins = float(ev.beat_bin_seconds)
        ids = excerpt_ids(truth)
        if quality:
            extractor = _quality_extractor(sctx, dataset, data_key, ev)
            with ctx.timed("metrics"):
                others = _floor_clips(dataset, ev, truth, sid)
                scores.metrics.update(_quality_cells(extractor, gen[ROW], truth, sid))
                for key, value in _quality_cells(extractor, others, truth, sid).items():
                    scores.add_seed_value(key, "ground truth", value)
                kld = {
                    ROW: _kl_per_clip(extractor, gen[ROW], truth),
                    "shuffled": _kl_per_clip(extractor, shuffled, truth),
                    "ground truth": _kl_per_clip(extractor, others, truth),
                }
                for variant, values in kld.items():
                    scores.add_clips(f"{sid}_mean_kld", variant, values, ids=ids)
            continue
        with ctx.timed("metrics"):
            beats = {v: beat_components("motion", clips, truth, bins) for v, clips in gen.items()}
            beats["shuffled"] = beat_components("motion", shuffled, truth, bins)
            beats["ground truth"] = beat_components("motion", truth, truth, bins)
            add_beat_scores(scores, sid, beats, ids)
            onsets = {v: motion_onset_f1s(truth, clips) for v, clips in gen.items()}
            onsets["shuffled"] = motion_onset_f1s(truth, shuffled)
            onsets["ground truth"] = motion_onset_f1s(truth, truth)
            _add_onsets(scores, f"{sid}_onset_f1", onsets, ids)
        _plot(ctx, f"{sid}_beats", gen[ROW][0], figure=5)  # generated motion, clip 0's music
    return scores


# ---------------------------------------------------------------------------------------- calibration
def calibrate_tables(
    ctx: RunContext, cfg: DictConfig, seed: int, *, subsets: Sequence[str], kind: str
) -> dict[str, Scores]:
    """Ground truth and shuffled ground truth per subset, through the same metric code as our row.

    ``kind``: ``"music"`` (Tables 2–4: ``beat_scores`` of ground-truth music against itself — 100/0
    by construction — and of clip π(i)'s music against clip *i*'s), ``"motion_beats"`` (Table 5:
    ``kinematic_beat_scores`` of clip *i*'s motion, resp. clip π(i)'s, against clip *i*'s music) or
    ``"motion_quality"`` (Table 6: the *ground truth* row puts ``reference_split`` crops in place of
    generated motion — the real-vs-real floor of FID and Mean KLD, with this seed's extractor;
    *shuffled* pairs clip π(i)'s motion with clip *i*: FID and Diversity are distributional and
    equal the ground-truth row's, Mean KLD is paired and measures the mismatch).
    """
    if kind not in CALIBRATION_KINDS:
        raise ValueError(f"calibrate_tables: unknown kind {kind!r}")
    sctx = shared_context(ctx)
    gt, shuf = Scores(metrics={}), Scores(metrics={})
    for sid in subsets:
        scfg = subset_config(cfg, sid)
        ev = build_component(scfg.method, "methods").cfg.evaluation
        dataset = build_component(scfg.dataset, "datasets")
        truth = _truth(dataset, ev)
        moved = _shuffled(truth)
        bins = float(ev.beat_bin_seconds)
        if kind == "quality" or kind == "motion_quality":
            extractor = _quality_extractor(sctx, dataset, to_container(scfg.dataset), ev)
            floor = _quality_cells(extractor, _floor_clips(dataset, ev, truth, sid), truth, sid)
            gt.metrics.update(floor)
            kld = float(np.mean(_kl_per_clip(extractor, moved, truth)))
            shuf.metrics.update({**floor, f"{sid}_mean_kld": max(0.0, kld)})
            continue
        which = "music" if kind == "music" else "motion"
        onset = music_onset_f1s if kind == "music" else (lambda g, r: motion_onset_f1s(r, g))
        ids = excerpt_ids(truth)
        add_beat_scores(gt, sid, {ROW: beat_components(which, truth, truth, bins)}, ids)
        add_beat_scores(shuf, sid, {ROW: beat_components(which, moved, truth, bins)}, ids)
        gt.metrics[f"{sid}_onset_f1"] = float(onset(truth, truth).mean())
        shuf.metrics[f"{sid}_onset_f1"] = float(onset(moved, truth).mean())
    return {"ground truth": gt, "ground truth, music and motion shuffled": shuf}
