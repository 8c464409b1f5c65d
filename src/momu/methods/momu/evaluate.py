"""Evaluation shared by the MoMu-Diffusion recipes (Table 7, Table 10): one row, and the calibration rows.

Columns (``F1`` in percent like the paper; FAD/FID on extractors trained on the dataset at hand, so
their scale is not the paper's):

* ``music_fad`` — :mod:`fad <momu.metrics.learned>` between the generated and the ground-truth
  music of the evaluation clips (momu's audio-classifier embedding, MoMu Fig. 3 / App. B.4).
* ``music_f1`` — cross rows: LORIS beat scores (``beat_scores``; BCS/BHS/F1, MoMu App. B.4) of the
  music generated from clip *i*'s motion against clip *i*'s ground-truth music.
  Joint rows: there is no ground-truth pairing (both modalities come from noise), so the jointly
  generated music's onset bins are scored against the jointly generated motion's kinematic-beat
  bins (the motion plays the reference). Since F1 is symmetric in BCS and BHS, this equals the
  joint ``motion_f1`` up to truncation: both measure how well the generated pair agrees.
* ``motion_fid`` — ``fid_learned`` between generated and ground-truth motion of the evaluation clips
  (motion style classifier features, MoMu App. B.5).
* ``motion_f1`` — cross rows: ``kinematic_beat_scores`` (MoMu App. B.5) of the motion generated from
  clip *i*'s music against clip *i*'s music. Joint rows: against the jointly generated music.
* ``motion_onset_f1`` — a finer diagnostic than the one-second LORIS bins (which saturate on music
  with a beat every half second): the F-measure of the motion's kinematic beats against the music's
  onsets within ±50 ms (:func:`onset_alignment`); ``*_shuffled_cond`` likewise.
* ``motion_f1_shuffled_cond`` (cross rows) — the same score for motion generated from *another*
  clip's music (a derangement), still scored against clip *i*'s music: if the model follows its
  condition, this is clearly lower than ``motion_f1``.

Calibration rows (:func:`calibrate_momu`) run the same metric code on ground truth: *ground truth*
(music F1 of the ground truth against itself is 100 by construction; motion F1 = ground-truth motion
vs its music; FAD/FID = the evaluation clips against the same number of clips of
``reference_split``, the real-vs-real floor) and *shuffled* (music of clip π(i) scored against clip
*i*'s music; motion of clip π(i) against clip *i*'s music; FAD/FID are distributional and do not
change under shuffling, so they repeat the ground-truth values).
"""

from __future__ import annotations

import dataclasses
import logging
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np
from omegaconf import DictConfig

from momu.config import build_component, to_container
from momu.data.types import Clip
from momu.engine.context import RunContext, stage_key_hash
from momu.engine.evaluate import map_gathered
from momu.methods.momu.data import eval_crops, select_split
from momu.methods.momu.method import MoMu
from momu.metrics.extractors import TrainConfig as ExtractorTrainConfig
from momu.metrics.extractors import load_extractor, train_extractor
from momu.metrics.kinematic_beats import kinematic_beat_bins, kinematic_beat_frames
from momu.metrics.loris_scores import aggregate_beat_scores, onset_beat_bins, onset_times, pair_beat_scores
from momu.registry import METRICS

__all__ = [
    "derangement",
    "eval_lengths",
    "ensure_extractors",
    "beat_metric",
    "trained_extractors",
    "pair_f1",
    "beat_onset_f1",
    "onset_alignment",
    "score_clips",
    "evaluate_momu",
    "calibrate_momu",
]

log = logging.getLogger(__name__)


def derangement(n: int) -> list[int]:
    """``π(i) = (i + 1) mod n``: every clip paired with another one (identity for n = 1)."""
    return [(i + 1) % n for i in range(n)]


def eval_lengths(cfg: Any, seed: int) -> list[float]:
    """Per-clip lengths (s): all ``seconds``, or uniform in ``[min_seconds, seconds]`` (variable length)."""
    if not cfg.variable_length:
        return [float(cfg.seconds)] * int(cfg.num_clips)
    rng = np.random.default_rng([int(seed), 7])
    return [float(x) for x in rng.uniform(cfg.min_seconds, cfg.seconds, int(cfg.num_clips))]


def trained_extractors(
    ctx: RunContext,
    dataset: Any,
    data_key: Mapping[str, Any],
    cfg: Any,
    seed: int,
    kinds: Sequence[str] = ("motion", "audio"),
) -> dict[str, Any]:
    """The FID/FAD feature extractors of ``kinds``, trained once per run on the train split.

    Cached under ``<out>/parts/extractor-<kind>-<hash>.safetensors`` (the hash covers the data, the
    epochs, the samples per clip and the seed, not the kind list, so a run that needs only the
    motion classifier shares its file with one that needs both); the main process trains, the
    others wait and load the same files.
    """
    key = {
        "data": dict(data_key),
        "epochs": int(cfg.extractor_epochs),
        "samples_per_clip": int(cfg.extractor_samples_per_clip),
        "seed": seed,
    }
    digest = stage_key_hash(key)
    acc = ctx.accelerator
    paths = {kind: ctx.parts_dir / f"extractor-{kind}-{digest}.safetensors" for kind in kinds}
    clips: list[Clip] | None = None
    for kind, path in paths.items():
        if path.is_file():
            ctx.trained.setdefault(path.stem, "reused")  # "trained" stays if this run trained it
            continue
        if acc.is_main_process:
            if clips is None:
                clips = [dataset[i] for i in select_split(dataset, "train")]
            train = ExtractorTrainConfig(
                epochs=int(cfg.extractor_epochs),
                samples_per_clip=int(cfg.extractor_samples_per_clip),
                seed=seed,
                val_fraction=0.0,
            )
            path.parent.mkdir(parents=True, exist_ok=True)
            train_extractor(kind, clips, path, train=train)
        acc.wait_for_everyone()
        ctx.trained[path.stem] = "trained"
    return {kind: load_extractor(path) for kind, path in paths.items()}


def ensure_extractors(
    ctx: RunContext, dataset: Any, data_key: Mapping[str, Any], cfg: Any, seed: int
) -> tuple[Any, Any]:
    """``(motion, audio)`` extractors of FID/FAD (:func:`trained_extractors`)."""
    both = trained_extractors(ctx, dataset, data_key, cfg, seed)
    return both["motion"], both["audio"]


def beat_metric(name: str, bin_seconds: float, **params: Any) -> Any:
    """The registered ``beat_scores`` / ``kinematic_beat_scores`` metric with bins of ``bin_seconds``."""
    return METRICS.build(name, {"bin_seconds": float(bin_seconds), **params})


def pair_f1(
    music: Sequence[Clip], motion: Sequence[Clip], *, music_is_reference: bool, bin_seconds: float = 1.0
) -> dict[str, float]:
    """Beat scores between music onset bins and motion kinematic-beat bins, clip by clip.

    ``music_is_reference=True`` is ``kinematic_beat_scores`` (MoMu App. B.5: motion beats scored
    against the music); ``False`` swaps the roles (music scored against the motion's beats).
    """
    covers, hits = [], []
    for a, m in zip(music, motion):
        if a.audio is None or m.motion is None:
            raise ValueError("pair_f1: clips need audio (music side) and motion (motion side)")
        music_bins = onset_beat_bins(a.audio, int(a.sample_rate or 0), bin_seconds=bin_seconds)
        motion_bins = kinematic_beat_bins(m.motion, m.fps, bin_seconds)
        ref, syn = (music_bins, motion_bins) if music_is_reference else (motion_bins, music_bins)
        cover, hit = pair_beat_scores(ref, syn, truncate="shortest")
        covers.append(cover)
        hits.append(hit)
    return aggregate_beat_scores(covers, hits)


def beat_onset_f1(
    reference: Sequence[float] | np.ndarray, estimate: Sequence[float] | np.ndarray, tolerance: float = 0.05
) -> float:
    """F-measure of ``estimate`` beat times against ``reference`` times (s) within ``± tolerance`` s.

    Greedy one-to-one matching in time order (each reference beat matches at most one estimate, the
    nearest unmatched one); 0 when either side is empty.
    """
    ref = np.sort(np.asarray(reference, dtype=np.float64))
    est = np.sort(np.asarray(estimate, dtype=np.float64))
    if ref.size == 0 or est.size == 0:
        return 0.0
    used = np.zeros(ref.size, dtype=bool)
    hits = 0
    for e in est:
        dist = np.where(used, np.inf, np.abs(ref - e))
        j = int(np.argmin(dist))
        if dist[j] <= tolerance:
            used[j] = True
            hits += 1
    precision, recall = hits / est.size, hits / ref.size
    return 0.0 if hits == 0 else 2 * precision * recall / (precision + recall)


def onset_alignment(music: Sequence[Clip], motion: Sequence[Clip], tolerance: float = 0.05) -> float:
    """Mean :func:`beat_onset_f1` (percent) of each motion's kinematic beats vs the paired music's onsets.

    A finer diagnostic than the LORIS one-second bins (which saturate on dense beats): kinematic beats
    (:func:`momu.metrics.kinematic_beats.kinematic_beat_frames`, MoMu Eq. 2) within ``± tolerance`` s
    of a music onset (LORIS detector) count as hits.
    """
    scores = []
    for a, m in zip(music, motion):
        assert a.audio is not None and m.motion is not None
        onsets = onset_times(a.audio, int(a.sample_rate or 0))
        beats = kinematic_beat_frames(m.motion, m.fps) / float(m.fps)
        scores.append(beat_onset_f1(onsets, beats, tolerance))
    return 100.0 * float(np.mean(scores))


def _beats(prefix: str, scores: Mapping[str, float]) -> dict[str, float]:
    def get(k: str) -> float:
        return float(
            scores.get(k, scores.get(f"beat_scores.{k}", scores.get(f"kinematic_beat_scores.{k}", 0.0)))
        )

    return {
        f"{prefix}_f1": 100.0 * get("f1"),
        f"{prefix}_bcs": 100.0 * get("bcs"),
        f"{prefix}_bhs": 100.0 * get("bhs"),
    }


def score_clips(
    gen_music: Sequence[Clip],
    gen_motion: Sequence[Clip],
    truth: Sequence[Clip],
    extractors: tuple[Any, Any],
    *,
    joint: bool,
    fad_reference: Sequence[Clip] | None = None,
    bin_seconds: float = 1.0,
) -> dict[str, float]:
    """The four Table 7 columns (+ BCS/BHS) for generated music and motion against ``truth``.

    ``bin_seconds``: bin width of the F1 columns (MoMu's 1 s by default).
    """
    motion_ext, audio_ext = extractors
    ref = list(fad_reference) if fad_reference is not None else list(truth)
    out = {
        "music_fad": float(METRICS.build("fad", {}, extractor=audio_ext)(gen_music, ref)["fad"]),
        "motion_fid": float(
            METRICS.build("fid_learned", {}, extractor=motion_ext)(gen_motion, ref)["fid_learned"]
        ),
    }
    if joint:
        out.update(
            _beats("music", pair_f1(gen_music, gen_motion, music_is_reference=False, bin_seconds=bin_seconds))
        )
        out.update(
            _beats("motion", pair_f1(gen_music, gen_motion, music_is_reference=True, bin_seconds=bin_seconds))
        )
        out["motion_onset_f1"] = onset_alignment(gen_music, gen_motion)
    else:
        out.update(_beats("music", beat_metric("beat_scores", bin_seconds)(gen_music, truth)))
        out.update(_beats("motion", beat_metric("kinematic_beat_scores", bin_seconds)(gen_motion, truth)))
        out["motion_onset_f1"] = onset_alignment(truth, gen_motion)
    return out


def _clip(
    base: Clip,
    suffix: str,
    *,
    motion: np.ndarray | None = None,
    fps: float | None = None,
    audio: np.ndarray | None = None,
    sample_rate: int | None = None,
) -> Clip:
    return dataclasses.replace(
        base,
        id=base.id + suffix,
        motion=motion if motion is not None else base.motion,
        fps=fps if fps is not None else base.fps,
        audio=audio if audio is not None else base.audio,
        sample_rate=sample_rate if sample_rate is not None else base.sample_rate,
    )


def _model_folder(ctx: RunContext, method: MoMu, data_key: Mapping[str, Any], seed: int) -> Path:
    return ctx.out_dir / "models" / f"momu-{stage_key_hash(method.stage_keys(data_key, seed)['diffusion'])}"


def evaluate_momu(ctx: RunContext, cfg: DictConfig, seed: int) -> dict[str, float]:
    """One Table 7 / Table 10 row: train (or reuse) the row's stages, generate, score."""
    method = build_component(cfg.method, "methods")
    if not isinstance(method, MoMu):
        raise ValueError(f"method: expected 'momu', got {type(method).__name__}")
    data_key = to_container(cfg.dataset)
    dataset = build_component(cfg.dataset, "datasets")
    model = method.fit(ctx, dataset, data_key, seed)
    folder = _model_folder(ctx, method, data_key, seed)
    if ctx.accelerator.is_main_process and not (folder / "momu.json").is_file():
        model.save(folder)
    ev = method.cfg.evaluation
    truth = eval_crops(dataset, ev.split, ev.num_clips, eval_lengths(ev, seed))
    extractors = ensure_extractors(ctx, dataset, data_key, ev, seed)
    joint = ev.task == "joint"
    perm = derangement(len(truth))
    rates = model.rates

    def generate(indices: list[int]) -> list[dict[str, np.ndarray]]:
        seeds = [seed * 100_003 + i for i in indices]
        if joint:
            pairs = model.joint([truth[i].duration for i in indices], seeds)
            return [{"audio": a, "motion": m} for a, m in pairs]
        items = [truth[i] for i in indices]
        sr = int(items[0].sample_rate or rates.sample_rate)
        conds = [it.audio for it in items]
        if ev.shuffled_condition:
            conds += [np.asarray(truth[perm[i]].audio)[: len(np.asarray(truth[i].audio))] for i in indices]
        motions = model.music_to_motion(conds, sr, seeds + seeds[: len(conds) - len(seeds)])  # type: ignore[arg-type]
        music = model.motion_to_music([it.motion for it in items], [it.fps for it in items], seeds)  # type: ignore[misc]
        out = []
        for k in range(len(items)):
            rec = {"audio": music[k], "motion": motions[k]}
            if ev.shuffled_condition:
                rec["motion_shuffled"] = motions[len(items) + k]
            out.append(rec)
        return out

    results = map_gathered(
        ctx.accelerator, list(range(len(truth))), generate, batch_size=ev.batch_size, desc="momu generate"
    )
    gen_music = [
        _clip(t, "/gen", audio=r["audio"], sample_rate=rates.sample_rate) for t, r in zip(truth, results)
    ]
    gen_motion = [_clip(t, "/gen", motion=r["motion"], fps=rates.motion_fps) for t, r in zip(truth, results)]
    bins = float(ev.beat_bin_seconds)
    metrics = score_clips(gen_music, gen_motion, truth, extractors, joint=joint, bin_seconds=bins)
    if not joint and ev.shuffled_condition:
        shuffled = [
            _clip(t, "/shuf", motion=r["motion_shuffled"], fps=rates.motion_fps)
            for t, r in zip(truth, results)
        ]
        metrics["motion_f1_shuffled_cond"] = _beats(
            "m", beat_metric("kinematic_beat_scores", bins)(shuffled, truth)
        )["m_f1"]
        metrics["motion_onset_f1_shuffled_cond"] = onset_alignment(truth, shuffled)
    _maybe_plot(ctx, folder, truth[0], gen_music[0], gen_motion[0], joint)
    return metrics


def calibrate_momu(ctx: RunContext, cfg: DictConfig) -> dict[str, dict[str, float]]:
    """Ground-truth and shuffled-ground-truth rows through the same metric code (see the module docstring)."""
    method = build_component(cfg.method, "methods")
    seed = int(cfg.get("seed", 0))
    data_key = to_container(cfg.dataset)
    dataset = build_component(cfg.dataset, "datasets")
    ev = method.cfg.evaluation
    truth = eval_crops(dataset, ev.split, ev.num_clips, [float(ev.seconds)])
    others = eval_crops(dataset, ev.reference_split, len(truth), [float(ev.seconds)])
    extractors = ensure_extractors(ctx, dataset, data_key, ev, seed)
    perm = derangement(len(truth))
    shuffled = [
        _clip(truth[i], "/shuf", motion=truth[perm[i]].motion, audio=truth[perm[i]].audio)
        for i in range(len(truth))
    ]
    bins = float(ev.beat_bin_seconds)
    gt = score_clips(others, others, truth, extractors, joint=False, bin_seconds=bins)
    gt.update(_beats("music", beat_metric("beat_scores", bins)(truth, truth)))
    gt.update(_beats("motion", beat_metric("kinematic_beat_scores", bins)(truth, truth)))
    gt["motion_onset_f1"] = onset_alignment(truth, truth)
    shuf = {"music_fad": gt["music_fad"], "motion_fid": gt["motion_fid"]}
    shuf.update(_beats("music", beat_metric("beat_scores", bins)(shuffled, truth)))
    shuf.update(_beats("motion", beat_metric("kinematic_beat_scores", bins)(shuffled, truth)))
    shuf["motion_onset_f1"] = onset_alignment(truth, shuffled)
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
