"""Evaluation of the MoMu-Diffusion Table 7 / Table 10 rows, and their calibration rows.

Columns (``F1`` in percent like the paper; FAD/FID on extractors trained on the dataset at hand, so
their scale is not the paper's):

* ``music_fad`` — :mod:`fad <momu.metrics.learned>` between the generated and the ground-truth
  music of the evaluation clips (momu's audio-classifier embedding, MoMu Fig. 3 / App. B.4).
* ``music_f1`` — cross rows: LORIS beat scores (``beat_scores``; BCS/BHS/F1, MoMu App. B.4) of the
  music generated from clip *i*'s motion against clip *i*'s ground-truth music. Joint rows: there
  is no ground-truth pairing (both modalities come from noise), so the jointly generated music's
  onset bins are scored against the jointly generated motion's kinematic-beat bins. F1 is
  symmetric in BCS and BHS, so this equals the joint ``motion_f1``: both measure how well the
  generated pair agrees.
* ``motion_fid`` — ``fid_learned`` between generated and ground-truth motion (motion style
  classifier features, MoMu App. B.5).
* ``motion_f1`` — cross rows: ``kinematic_beat_scores`` (MoMu App. B.5) of the motion generated
  from clip *i*'s music against clip *i*'s music. Joint rows: against the jointly generated music.
* ``*_onset_f1`` — a finer diagnostic than the LORIS bins: onset / kinematic-beat times matched
  within ±50 ms.

Every F1 column records per-clip evidence (:class:`momu.engine.scores.Scores`) for its verdicts:
the row itself, the *shuffled* calibration on the same clips (clip π(i)'s ground truth against clip
*i*'s), *ground truth* (motion F1), and — cross rows — the same model given *another clip's
condition* (clip π(i)'s motion or music, clip *i*'s sampling seed), or — joint rows — *another
generated pair* (music of pair *i* against motion of pair π(i)). FAD / FID record this seed's
real-vs-real floor (``reference_split`` crops against the evaluation clips, the same extractor).

Calibration rows (:func:`calibrate_momu`, per seed): *ground truth* (music F1 against itself is
100 by construction; motion F1 = ground-truth motion vs its music; FAD/FID = the floor) and
*shuffled* (clip π(i)'s music / motion against clip *i*'s music; FAD/FID are distributional and
repeat the floor).
"""

from __future__ import annotations

import dataclasses
import logging
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from omegaconf import DictConfig

from momu.config import build_component, to_container
from momu.data.types import Clip
from momu.engine.context import RunContext, stage_key_hash
from momu.engine.scores import ROW, Scores
from momu.methods.momu.data import count_split, eval_crops
from momu.methods.momu.generation import OTHER, generate_joint, generate_motion, generate_music
from momu.methods.momu.method import MoMu
from momu.methods.momu.model import MoMuModel
from momu.methods.momu.scoring import (
    add_beat_scores,
    beat_components,
    derangement,
    eval_lengths,
    excerpt_ids,
    fad,
    fid,
    motion_onset_f1s,
    music_onset_f1s,
    pair_components,
    replace_clip,
    start_extractors,
    trained_extractors,
)

__all__ = [
    "fit_momu",
    "evaluate_momu",
    "calibrate_momu",
    "model_folder",
    "check_evaluation_splits",
    "check_rows",
]

log = logging.getLogger(__name__)


def model_folder(ctx: RunContext, method: MoMu, data_key: Any, seed: int) -> Path:
    """Where a trained row's model is saved: ``<out>/models/momu-<hash of its diffusion stage>``."""
    return ctx.out_dir / "models" / f"momu-{stage_key_hash(method.stage_keys(data_key, seed)['diffusion'])}"


def fit_momu(
    ctx: RunContext, cfg: DictConfig, seed: int, *, extractors: Sequence[str] = ()
) -> tuple[MoMu, MoMuModel, Any, dict[str, Any], Path]:
    """Train (or reuse) ``cfg.method`` on ``cfg.dataset`` for ``seed`` and save the model once.

    ``extractors``: the FID/FAD extractors the caller will score with; those no ``--jobs`` worker
    has yet are trained first (:func:`~momu.methods.momu.scoring.start_extractors`).
    Returns ``(method, model, dataset, data_key, model folder)``.
    """
    method = build_component(cfg.method, "methods")
    if not isinstance(method, MoMu):
        raise ValueError(f"method: expected 'momu', got {type(method).__name__}")
    data_key = to_container(cfg.dataset)
    dataset = build_component(cfg.dataset, "datasets")
    method = method.for_dataset(dataset)
    check_evaluation_splits(method.cfg.evaluation, dataset)  # before any training
    if extractors:
        with ctx.timed("extractors"):
            start_extractors(ctx, dataset, data_key, method.cfg.evaluation, kinds=extractors)
    model = method.fit(ctx, dataset, data_key, seed)
    folder = model_folder(ctx, method, data_key, seed)
    if ctx.accelerator.is_main_process and not (folder / "momu.json").is_file():
        model.save(folder)
    return method, model, dataset, data_key, folder


def check_rows(cfg: DictConfig) -> None:
    """The table's ``check`` for one row: its dataset serves it (skeleton, split sizes)."""
    method = build_component(cfg.method, "methods")
    if not isinstance(method, MoMu):
        raise ValueError(f"method: expected 'momu', got {type(method).__name__}")
    dataset = build_component(cfg.dataset, "datasets")
    check_evaluation_splits(method.cfg.evaluation, dataset)


def check_evaluation_splits(ev: Any, dataset: Any) -> None:
    """Fail before training when a split is too small for the table's comparisons.

    Every comparison pairs clip i with clip π(i) ≠ i, so the evaluation split needs 2 clips; the
    real-vs-real floor of FAD/FID takes as many ``reference_split`` clips as evaluation clips.
    """
    n_eval = min(int(ev.num_clips), count_split(dataset, ev.split))
    if n_eval < 2:
        raise ValueError(
            f"method.evaluation.split: the '{ev.split}' split has {n_eval} clip(s) with motion and audio; "
            "the table needs at least 2 (each clip is compared with another clip's ground truth)"
        )
    n_ref = count_split(dataset, ev.reference_split)
    if n_ref < n_eval:
        raise ValueError(
            f"method.evaluation.reference_split: the '{ev.reference_split}' split has {n_ref} clip(s) for "
            f"{n_eval} evaluation clips; the real-vs-real FID/FAD floor needs as many"
        )


def _shuffled(truth: list[Clip]) -> list[Clip]:
    """Clip π(i)'s ground truth (motion and music) in clip i's place."""
    perm = derangement(len(truth))
    return [
        replace_clip(truth[i], "/shuf", motion=truth[perm[i]].motion, audio=truth[perm[i]].audio)
        for i in range(len(truth))
    ]


def _truth(ctx: RunContext, dataset: Any, data_key: Any, ev: Any, lengths: list[float]) -> list[Clip]:
    """The ground-truth evaluation clips cut to ``lengths`` (built once per process for them)."""
    return ctx.remember(
        ("momu eval crops", data_key, ev.split, int(ev.num_clips), lengths),
        lambda: eval_crops(dataset, ev.split, ev.num_clips, lengths),
    )


def _floors(
    ctx: RunContext,
    extractors: dict[str, Any],
    dataset: Any,
    data_key: Any,
    ev: Any,
    truth: list[Clip],
    kinds: Sequence[str] = ("audio", "motion"),
) -> dict[str, float]:
    """The real-vs-real FAD (``audio``) and FID (``motion``): ``reference_split`` crops against the
    evaluation clips.

    They depend on the data, the evaluation settings (extractors included) and the clips' lengths,
    not on the row or its seed, so a process computes them once for those.
    """

    def compute() -> dict[str, float]:
        others = eval_crops(dataset, ev.reference_split, len(truth), [c.duration for c in truth])
        if len(others) < len(truth):
            raise ValueError(
                f"method.evaluation: {len(others)} '{ev.reference_split}' clips for {len(truth)} "
                "evaluation clips; the real-vs-real floor needs as many (raise dataset.num_clips)"
            )
        out = {}
        if "audio" in kinds:
            out["music_fad"] = fad(extractors["audio"], others, truth)
        if "motion" in kinds:
            out["motion_fid"] = fid(extractors["motion"], others, truth)
        return out

    clips = [(c.id, c.duration) for c in truth]
    key = ("momu floors", data_key, dataclasses.asdict(ev), clips, tuple(sorted(kinds)))
    return dict(ctx.remember(key, compute))


def evaluate_momu(ctx: RunContext, cfg: DictConfig, seed: int) -> Scores:
    """One Table 7 / Table 10 row for one seed: train (or reuse) its stages, generate, score."""
    method, model, dataset, data_key, folder = fit_momu(ctx, cfg, seed, extractors=("motion", "audio"))
    ev = method.cfg.evaluation
    truth = _truth(ctx, dataset, data_key, ev, eval_lengths(ev, seed))
    if len(truth) < 2:
        raise ValueError(
            f"method.evaluation: the '{ev.split}' split has {len(truth)} clip; the table needs 2 or more"
        )
    with ctx.timed("extractors"):
        extractors = trained_extractors(ctx, dataset, data_key, ev)
    joint = ev.task == "joint"
    bins = float(ev.beat_bin_seconds)
    scores = Scores(
        metrics={}, artifacts={"model": str(folder.relative_to(ctx.out_dir)), "vocoder": model.vocoder_name}
    )
    shuffled = _shuffled(truth)
    gen_music: dict[str, list[Clip]] = {}
    gen_motion: dict[str, list[Clip]] = {}
    if joint:
        music, motion = generate_joint(ctx, model, truth, seed, ev.batch_size)
    else:
        gen_music = generate_music(ctx, model, truth, seed, ev.batch_size, other=ev.shuffled_condition)
        gen_motion = generate_motion(ctx, model, truth, seed, ev.batch_size, other=ev.shuffled_condition)
        music, motion = gen_music[ROW], gen_motion[ROW]
    ids = excerpt_ids(truth)  # every variant of a column is scored on these crops
    with ctx.timed("metrics"):
        floors = _floors(ctx, extractors, dataset, data_key, ev, truth)
        scores.metrics["music_fad"] = fad(extractors["audio"], music, truth)
        scores.metrics["motion_fid"] = fid(extractors["motion"], motion, truth)
        for key, floor in floors.items():
            scores.add_seed_value(key, "ground truth", floor)
        if joint:
            perm = derangement(len(truth))
            other_motion = [motion[j] for j in perm]
            for prefix, music_ref in (("music", False), ("motion", True)):
                add_beat_scores(
                    scores,
                    prefix,
                    {
                        ROW: pair_components(music, motion, music_is_reference=music_ref, bin_seconds=bins),
                        "other pair": pair_components(
                            music, other_motion, music_is_reference=music_ref, bin_seconds=bins
                        ),
                        "shuffled": pair_components(
                            truth, shuffled, music_is_reference=music_ref, bin_seconds=bins
                        ),
                        "ground truth": pair_components(
                            truth, truth, music_is_reference=music_ref, bin_seconds=bins
                        ),
                    },
                    ids,
                )
            scores.metrics["motion_onset_f1"] = float(motion_onset_f1s(music, motion).mean())
        else:
            music_variants = {
                v: beat_components("music", clips, truth, bins) for v, clips in gen_music.items()
            }
            music_variants["shuffled"] = beat_components("music", shuffled, truth, bins)
            add_beat_scores(scores, "music", music_variants, ids)
            motion_variants = {
                v: beat_components("motion", clips, truth, bins) for v, clips in gen_motion.items()
            }
            motion_variants["shuffled"] = beat_components("motion", shuffled, truth, bins)
            motion_variants["ground truth"] = beat_components("motion", truth, truth, bins)
            add_beat_scores(scores, "motion", motion_variants, ids)
            scores.metrics["music_onset_f1"] = float(music_onset_f1s(music, truth).mean())
            scores.metrics["motion_onset_f1"] = float(motion_onset_f1s(truth, motion).mean())
            if OTHER in gen_motion:
                scores.metrics["music_onset_f1_shuffled_cond"] = float(
                    music_onset_f1s(gen_music[OTHER], truth).mean()
                )
                scores.metrics["motion_onset_f1_shuffled_cond"] = float(
                    motion_onset_f1s(truth, gen_motion[OTHER]).mean()
                )
    _maybe_plot(ctx, folder, truth[0], music[0], motion[0], joint)
    return scores


def calibration_truth(
    ctx: RunContext, cfg: DictConfig, kinds: Sequence[str] = ("motion", "audio")
) -> tuple[Any, list[Clip], dict[str, float]]:
    """What a calibration scores: the evaluation config, the ground-truth excerpts, and their
    real-vs-real floors (FID / FAD with the trained extractors of ``kinds``)."""
    method = build_component(cfg.method, "methods")
    data_key = to_container(cfg.dataset)
    dataset = build_component(cfg.dataset, "datasets")
    ev = method.cfg.evaluation
    truth = _truth(ctx, dataset, data_key, ev, [float(ev.seconds)] * int(ev.num_clips))
    with ctx.timed("extractors"):
        extractors = trained_extractors(ctx, dataset, data_key, ev, kinds=kinds)
    return ev, truth, _floors(ctx, extractors, dataset, data_key, ev, truth, kinds=kinds)


def calibrate_momu(ctx: RunContext, cfg: DictConfig, seed: int) -> dict[str, Scores]:
    """Ground-truth and shuffled-ground-truth rows of one seed through the same metric code."""
    ev, truth, floors = calibration_truth(ctx, cfg)
    shuffled = _shuffled(truth)
    bins = float(ev.beat_bin_seconds)
    gt, shuf = Scores(metrics=dict(floors)), Scores(metrics=dict(floors))
    ids = excerpt_ids(truth)
    with ctx.timed("metrics"):
        add_beat_scores(gt, "music", {ROW: beat_components("music", truth, truth, bins)}, ids)
        add_beat_scores(gt, "motion", {ROW: beat_components("motion", truth, truth, bins)}, ids)
        add_beat_scores(shuf, "music", {ROW: beat_components("music", shuffled, truth, bins)}, ids)
        add_beat_scores(shuf, "motion", {ROW: beat_components("motion", shuffled, truth, bins)}, ids)
        gt.metrics["motion_onset_f1"] = float(motion_onset_f1s(truth, truth).mean())
        shuf.metrics["motion_onset_f1"] = float(motion_onset_f1s(truth, shuffled).mean())
        shuf.metrics["music_onset_f1"] = float(music_onset_f1s(shuffled, truth).mean())
    return {"ground truth": gt, "ground truth, music and motion shuffled": shuf}


def _maybe_plot(ctx: RunContext, folder: Path, truth: Clip, music: Clip, motion: Clip, joint: bool) -> None:
    """A Figure 4/5-style beat plot of the first generated sample (main process only)."""
    if not ctx.accelerator.is_main_process:
        return
    try:
        from momu.methods.momu.plot import beat_plot
    except ImportError:  # pragma: no cover - matplotlib missing
        return
    try:
        beat_plot(truth, music, motion, folder / "beats.png", joint=joint)
    except Exception as exc:  # a plot must never fail a table
        log.warning("beat plot skipped: %s", exc)
