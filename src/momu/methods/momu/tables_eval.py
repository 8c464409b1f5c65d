"""MoMu-Diffusion Tables 2–6: our row's evaluation (motion→music, music→motion) and the calibration rows."""

from __future__ import annotations

import dataclasses
import logging
from collections.abc import Mapping, Sequence
from typing import Any

from omegaconf import DictConfig

from momu.config import ConfigError, build_component, to_container
from momu.data.types import Clip
from momu.engine.context import RunContext, stage_key_hash
from momu.engine.evaluate import map_gathered
from momu.engine.trainer import TrainConfig
from momu.methods.momu.data import eval_crops
from momu.methods.momu.evaluate import (
    _clip,
    beat_metric,
    derangement,
    onset_alignment,
    trained_extractors,
)
from momu.methods.momu.learnable import LearnableMotionToMusic, fit_learnable_motion_to_music
from momu.methods.momu.method import MoMu
from momu.methods.momu.model import MoMuModel
from momu.methods.momu.tables_setup import (
    beat_percent,
    check_subsets,
    music_onset_f1,
    shared_context,
    subset_config,
)
from momu.registry import METRICS

log = logging.getLogger(__name__)


def _eval_seeds(seed: int, indices: Sequence[int]) -> list[int]:
    return [seed * 100_003 + i for i in indices]


def _trained_momu(
    ctx: RunContext, cfg: DictConfig, seed: int
) -> tuple[MoMuModel, Any, dict[str, Any], list[Clip]]:
    """Fit (or reuse) the ``momu`` method on ``cfg.dataset``; save it once; the evaluation crops."""
    method = build_component(cfg.method, "methods")
    if not isinstance(method, MoMu):
        raise ValueError(f"method: expected 'momu', got {type(method).__name__}")
    data_key = to_container(cfg.dataset)
    dataset = build_component(cfg.dataset, "datasets")
    model = method.fit(ctx, dataset, data_key, seed)
    folder = ctx.out_dir / "models" / f"momu-{stage_key_hash(method.stage_keys(data_key, seed)['diffusion'])}"
    if ctx.accelerator.is_main_process and not (folder / "momu.json").is_file():
        model.save(folder)
    ev = method.cfg.evaluation
    truth = eval_crops(dataset, ev.split, ev.num_clips, [float(ev.seconds)])
    return model, dataset, data_key, truth


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


# ---------------------------------------------------------------------------------------- motion→music
def _score_motion_to_music(
    ctx: RunContext,
    sid: str,
    model: MoMuModel | LearnableMotionToMusic,
    truth: list[Clip],
    seed: int,
    ev: Any,
) -> dict[str, float]:
    perm = derangement(len(truth))
    shuffled_cond = bool(ev.shuffled_condition) and len(truth) > 1

    def generate(indices: list[int]) -> list[dict[str, Any]]:
        seeds = _eval_seeds(seed, indices)
        motions = [truth[i].motion for i in indices]
        fps = [float(truth[i].fps) for i in indices]
        if shuffled_cond:
            motions += [truth[perm[i]].motion for i in indices]
            fps += [float(truth[perm[i]].fps) for i in indices]
            seeds = seeds + seeds
        music = model.motion_to_music(motions, fps, seeds)  # type: ignore[arg-type]
        n = len(indices)
        return [
            {"audio": music[k], **({"shuffled": music[n + k]} if shuffled_cond else {})} for k in range(n)
        ]

    results = map_gathered(
        ctx.accelerator,
        list(range(len(truth))),
        generate,
        batch_size=ev.batch_size,
        desc=f"{sid} motion→music",
    )
    sr = int(model.rates.sample_rate)
    gen = [_clip(t, "/gen", audio=r["audio"], sample_rate=sr) for t, r in zip(truth, results)]
    out = beat_percent(sid, beat_metric("beat_scores", ev.beat_bin_seconds)(gen, truth))
    out[f"{sid}_onset_f1"] = music_onset_f1(gen, truth)
    if shuffled_cond:  # music generated from clip π(i)'s motion, scored against clip i's music
        shuf = [_clip(t, "/shuf", audio=r["shuffled"], sample_rate=sr) for t, r in zip(truth, results)]
        scores = beat_metric("beat_scores", ev.beat_bin_seconds, truncate="shortest")(shuf, truth)
        out[f"{sid}_f1_shuffled_cond"] = beat_percent(sid, scores)[f"{sid}_f1"]
        out[f"{sid}_onset_f1_shuffled_cond"] = music_onset_f1(shuf, truth)
    _plot(ctx, f"{sid}_beats", gen[0], figure=4)  # gen[i]: generated audio, clip i's motion
    return out


def evaluate_motion_to_music(
    ctx: RunContext, cfg: DictConfig, seed: int, *, subsets: Sequence[str], learnable: bool
) -> dict[str, float]:
    """Our row of Table 2 (``learnable=False``: the full method) or Tables 3–4 (learnable motion encoder).

    Per subset: train (or reuse) the model on its ``train`` split, generate music from each
    evaluation clip's motion (50 DDIM steps at the ``cpu``/``paper`` presets, CFG Eq. 7), and score
    it against the clip's music with ``beat_scores`` (LORIS onsets, one-second bins, App. B.4).
    ``<subset>_f1_shuffled_cond`` (results.json): music generated from another clip's motion, scored
    against clip *i*'s music — lower than ``<subset>_f1`` when the music follows its motion.
    """
    check_subsets(cfg, subsets)
    sctx = shared_context(ctx)
    out: dict[str, float] = {}
    for sid in subsets:
        scfg = subset_config(cfg, sid)
        method = build_component(scfg.method, "methods")
        ev = method.cfg.evaluation
        if learnable:
            dataset = build_component(scfg.dataset, "datasets")
            train = _train_config(scfg.learnable_train)
            model: MoMuModel | LearnableMotionToMusic = fit_learnable_motion_to_music(
                sctx,
                method,
                scfg.learnable_encoder,
                train,
                dataset,
                to_container(scfg.dataset),
                seed,
                frames_per_latent=int(scfg.learnable_frames_per_latent),
            )
            truth = eval_crops(dataset, ev.split, ev.num_clips, [float(ev.seconds)])
        else:
            model, _, _, truth = _trained_momu(sctx, scfg, seed)
        out.update(_score_motion_to_music(ctx, sid, model, truth, seed, ev))
    return out


def _train_config(node: Any) -> TrainConfig:
    params = dict(to_container(node) or {})
    valid = {f.name for f in dataclasses.fields(TrainConfig)}
    unknown = sorted(set(params) - valid)
    if unknown:
        raise ConfigError(
            f"learnable_train.{unknown[0]}: unknown key; valid keys: {', '.join(sorted(valid))}"
        )
    return TrainConfig(**params)


# ---------------------------------------------------------------------------------------- music→motion
def _generate_motion(
    ctx: RunContext, sid: str, model: MoMuModel, truth: list[Clip], seed: int, ev: Any
) -> tuple[list[Clip], list[Clip] | None]:
    """Motion generated from each clip's music (and, for the diagnostic, from clip π(i)'s music)."""
    perm = derangement(len(truth))
    shuffled_cond = bool(ev.shuffled_condition) and len(truth) > 1
    sr = int(truth[0].sample_rate or model.rates.sample_rate)

    def generate(indices: list[int]) -> list[dict[str, Any]]:
        seeds = _eval_seeds(seed, indices)
        conds = [truth[i].audio for i in indices]
        if shuffled_cond:
            conds += [truth[perm[i]].audio for i in indices]
            seeds = seeds + seeds
        motions = model.music_to_motion(conds, sr, seeds)  # type: ignore[arg-type]
        n = len(indices)
        return [
            {"motion": motions[k], **({"shuffled": motions[n + k]} if shuffled_cond else {})}
            for k in range(n)
        ]

    results = map_gathered(
        ctx.accelerator,
        list(range(len(truth))),
        generate,
        batch_size=ev.batch_size,
        desc=f"{sid} music→motion",
    )
    fps = model.rates.motion_fps
    gen = [_clip(t, "/gen", motion=r["motion"], fps=fps) for t, r in zip(truth, results)]
    shuf = (
        [_clip(t, "/shuf", motion=r["shuffled"], fps=fps) for t, r in zip(truth, results)]
        if shuffled_cond
        else None
    )
    return gen, shuf


def motion_extractor(ctx: RunContext, dataset: Any, data_key: Mapping[str, Any], ev: Any, seed: int) -> Any:
    """The FID / Diversity / Mean KLD motion classifier, trained once on the ``train`` split.

    The same cache file as :func:`momu.methods.momu.evaluate.ensure_extractors`, without the audio
    extractor that Table 6 does not need.
    """
    return trained_extractors(ctx, dataset, data_key, ev, seed, kinds=("motion",))["motion"]


def _quality(
    extractor: Any, generated: Sequence[Clip], reference: Sequence[Clip], prefix: str, ev: Any
) -> dict[str, float]:
    """FID (``fid_learned``), inter-Diversity (``diversity``) and paired Mean KLD (``mean_kld``)."""
    fid = METRICS.build("fid_learned", {}, extractor=extractor)(generated, reference)["fid_learned"]
    div = METRICS.build("diversity", {}, extractor=extractor)(generated)["diversity.inter"]
    kld = METRICS.build("mean_kld", {}, extractor=extractor)(generated, reference)["mean_kld"]
    return {f"{prefix}_fid": float(fid), f"{prefix}_diversity": float(div), f"{prefix}_mean_kld": float(kld)}


def evaluate_music_to_motion(
    ctx: RunContext, cfg: DictConfig, seed: int, *, subsets: Sequence[str], quality: bool
) -> dict[str, float]:
    """Our row of Table 5 (``quality=False``: beat scores) or Table 6 (FID / Diversity / Mean KLD).

    Per subset: train (or reuse) the full method, generate motion from each evaluation clip's
    music (CFG, Eq. 7). Table 5 scores the motion's kinematic beats against the clip's music
    (``kinematic_beat_scores``, App. B.5: music beats are the reference, BCS = N_m/N_s of the
    motion's beats); ``<subset>_f1_shuffled_cond`` is the F1 of motion generated from another
    clip's music. Table 6 compares generated and ground-truth motion with the subset's motion
    classifier: FID, inter-Diversity (App. B.4's definition) and paired Mean KLD (clip *i*'s
    ground truth vs the motion generated from its music).
    """
    check_subsets(cfg, subsets)
    sctx = shared_context(ctx)
    out: dict[str, float] = {}
    for sid in subsets:
        scfg = subset_config(cfg, sid)
        model, dataset, data_key, truth = _trained_momu(sctx, scfg, seed)
        ev = model.cfg.evaluation
        gen, shuf = _generate_motion(ctx, sid, model, truth, seed, ev)
        if quality:
            motion_ext = motion_extractor(sctx, dataset, data_key, ev, seed)
            out.update(_quality(motion_ext, gen, truth, sid, ev))
        else:
            out.update(
                beat_percent(sid, beat_metric("kinematic_beat_scores", ev.beat_bin_seconds)(gen, truth))
            )
            out[f"{sid}_onset_f1"] = onset_alignment(truth, gen)
            if shuf is not None:
                scores = beat_metric("kinematic_beat_scores", ev.beat_bin_seconds)(shuf, truth)
                out[f"{sid}_f1_shuffled_cond"] = beat_percent(sid, scores)[f"{sid}_f1"]
                out[f"{sid}_onset_f1_shuffled_cond"] = onset_alignment(truth, shuf)
            _plot(ctx, f"{sid}_beats", gen[0], figure=5)  # gen[i]: generated motion, clip i's music
    return out


# ---------------------------------------------------------------------------------------- calibration
def calibrate_tables(
    ctx: RunContext, cfg: DictConfig, *, subsets: Sequence[str], kind: str
) -> dict[str, dict[str, float]]:
    """Ground truth and shuffled ground truth per subset, through the same metric code as our row.

    ``kind``: ``"music"`` (Tables 2–4: ``beat_scores`` of ground-truth music against itself — 100/0
    by construction — and of clip π(i)'s music against clip *i*'s), ``"motion_beats"`` (Table 5:
    ``kinematic_beat_scores`` of clip *i*'s motion, resp. clip π(i)'s, against clip *i*'s music) or
    ``"motion_quality"`` (Table 6: the *ground truth* row puts ``reference_split`` crops in place of
    generated motion — the real-vs-real floor of FID and Mean KLD; *shuffled* pairs clip π(i)'s
    motion with clip *i*: FID and Diversity are distributional and equal the ground-truth row's,
    Mean KLD is paired and measures the mismatch). π is :func:`momu.methods.momu.evaluate.derangement`.
    """
    if kind not in ("music", "motion_beats", "motion_quality"):
        raise ValueError(f"calibrate_tables: unknown kind {kind!r}")
    sctx = shared_context(ctx)
    gt: dict[str, float] = {}
    shuffled: dict[str, float] = {}
    for sid in subsets:
        scfg = subset_config(cfg, sid)
        method = build_component(scfg.method, "methods")
        ev = method.cfg.evaluation
        dataset = build_component(scfg.dataset, "datasets")
        truth = eval_crops(dataset, ev.split, ev.num_clips, [float(ev.seconds)])
        perm = derangement(len(truth))
        moved = [
            _clip(truth[i], "/shuf", motion=truth[perm[i]].motion, audio=truth[perm[i]].audio)
            for i in range(len(truth))
        ]
        if kind == "music":
            gt.update(beat_percent(sid, beat_metric("beat_scores", ev.beat_bin_seconds)(truth, truth)))
            gt[f"{sid}_onset_f1"] = music_onset_f1(truth, truth)
            shuffled.update(
                beat_percent(
                    sid, beat_metric("beat_scores", ev.beat_bin_seconds, truncate="shortest")(moved, truth)
                )
            )
            shuffled[f"{sid}_onset_f1"] = music_onset_f1(moved, truth)
        elif kind == "motion_beats":
            gt.update(
                beat_percent(sid, beat_metric("kinematic_beat_scores", ev.beat_bin_seconds)(truth, truth))
            )
            gt[f"{sid}_onset_f1"] = onset_alignment(truth, truth)
            shuffled.update(
                beat_percent(sid, beat_metric("kinematic_beat_scores", ev.beat_bin_seconds)(moved, truth))
            )
            shuffled[f"{sid}_onset_f1"] = onset_alignment(truth, moved)
        else:
            data_key = to_container(scfg.dataset)
            motion_ext = motion_extractor(sctx, dataset, data_key, ev, int(cfg.get("seed", 0)))
            others = eval_crops(dataset, ev.reference_split, len(truth), [float(ev.seconds)])[: len(truth)]
            if len(others) != len(truth):
                raise ValueError(
                    f"subset {sid}: {len(others)} '{ev.reference_split}' clips for {len(truth)} test clips"
                )
            floor = _quality(motion_ext, others, truth, sid, ev)
            gt.update(floor)
            kld = METRICS.build("mean_kld", {}, extractor=motion_ext)(moved, truth)["mean_kld"]
            shuffled.update(
                {
                    f"{sid}_fid": floor[f"{sid}_fid"],
                    f"{sid}_diversity": floor[f"{sid}_diversity"],
                    f"{sid}_mean_kld": float(kld),
                }
            )
    return {"ground truth": gt, "ground truth, music and motion shuffled": shuffled}
