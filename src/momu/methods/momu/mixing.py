"""The cross-method mixing table (``recipes/mixing.py``): parts of one paper on another paper's model.

Rows (config overrides over ``recipes/configs/momu.yaml`` and :data:`BASE`; nothing in code):

* ``base`` — MoMu-Diffusion at the cpu preset on ``synth_dance`` with a 3D skeleton (``dwm21``);
* ``+kin`` — MoFusion's scheduled kinematic loss (Eq. 4–7: L_s + L_a + L_m weighted by ᾱ_t) on θ_m's
  clean estimate decoded to poses (``method.diffusion_losses``, :mod:`.decoded_losses`);
* ``+harmony`` — HarmoGAN's harmony loss (Eq. 16, normalised by N′) on the same decoded poses, weighted
  by ᾱ_t and 0.1;
* ``+mfcc`` — HarmoGAN's ``mfcc`` audio encoder as θ_m's condition features beside the music latent
  (``method.motion_condition``; :meth:`momu.encoders.mfcc.MfccEncoder.track`).

Each (row, seed) trains MoMu (the rows share the two VAE stages of a seed; only the diffusion stage
differs) and is scored on music→motion:

* ``motion_fid`` (``fid_learned`` on the MoMu tables' motion extractor, against the evaluation clips;
  the real-vs-real floor as *ground truth*) and ``motion_f1`` (kinematic beat F1, per clip, against
  *shuffled* and *ground truth*), as in MoMu Table 7;
* the music-following benchmark (:mod:`momu.following`) on the ``val`` songs: input sensitivity,
  tempo following (slope), tempo match, beat phase and matched-vs-mismatched BAS (Bailando), and the
  realism statistic bone-length variation — one value per song (the mean over the generation seeds),
  against *ground truth* on the same songs.

The table compares every row with ``base`` per column (:func:`momu.engine.table_results.versus_baseline`),
paired on the same clips or songs and pooled over the training seeds, with the project's verdict rule.
"""

from __future__ import annotations

import warnings
from typing import Any

import numpy as np
from omegaconf import DictConfig, OmegaConf

from momu.config import to_container
from momu.config.schema import FollowingConfig
from momu.engine.context import RunContext
from momu.engine.scores import ROW, Scores
from momu.engine.table import Column, Row, TableSpec
from momu.methods.momu.evaluate import _floors, _shuffled, _truth, calibration_truth, check_rows, fit_momu
from momu.methods.momu.generation import generate_motion
from momu.methods.momu.recipes import BASE_CONFIG, PRESETS
from momu.methods.momu.scoring import add_beat_scores, beat_components, eval_lengths, excerpt_ids, fid

__all__ = [
    "FOLLOWING",
    "COLUMNS",
    "BASE",
    "MIXING_PRESETS",
    "mixing_spec",
    "evaluate_mixing",
    "calibrate_mixing",
]

FOLLOWING: dict[str, tuple[str, bool]] = {
    "input_sensitivity": ("Input sensitivity↑", True),
    "tempo_following": ("Tempo slope↑", True),
    "tempo_match": ("Tempo match↑", True),
    "beat_phase_bailando": ("Beat phase BAS↑", True),
    "matched_bailando": ("Matched − mismatched BAS↑", True),
}
"""Benchmark tests that are table columns (:data:`momu.following.TESTS`): label, higher is better."""
REALISM: dict[str, tuple[str, bool]] = {"bone_length_cv": ("Bone-length CV↓", False)}
"""Realism statistics that are columns (:data:`momu.following.realism.REALISM_KEYS`)."""
DIAGNOSTIC_REALISM = ("root_travel_m_per_min", "foot_speed", "joint_speed")
"""Realism statistics kept in ``per_seed`` only (their "better" is "closer to the real range")."""

COLUMNS = [
    Column("motion_fid", "Motion FID↓", False),
    Column("motion_f1", "Motion F1↑", True, reducer="f1"),
    *(Column(k, label, hib) for k, (label, hib) in FOLLOWING.items()),
    *(Column(k, label, hib) for k, (label, hib) in REALISM.items()),
]

BASE = (
    "dataset.skeleton=dwm21",  # 3D: MoFusion's kinematic terms and the benchmark's realism need it
    "following={split: val, songs: 12, seconds: 5.0, generation_seeds: [0, 1],"
    " factors: [0.8, 0.9, 1.1, 1.25]}",
)
"""Overrides every row and preset shares: the data's skeleton and the benchmark's size."""

MIXING_PRESETS: dict[str, list[str]] = {
    "smoke": [
        *PRESETS["smoke"],
        "dataset.min_seconds=4.0",
        "dataset.max_seconds=4.0",
        "dataset.num_clips=12",
        "following.songs=2",
        "following.seconds=4.0",
        "following.factors=[0.8]",
    ],
    # cpu: the MoMu cpu preset with fewer steps, so a row trains in about 3 CPU-minutes (the VAE
    # stages once per seed, shared by the rows): 60 music-VAE, 400 motion-VAE, 1000 diffusion steps
    "cpu": [
        "method.train_music_vae.steps=60",
        "method.train_motion_vae.steps=400",
        "method.train_diffusion.steps=1000",
        "method.evaluation.num_clips=32",
        "method.evaluation.extractor_epochs=5",
    ],
}

_ROWS = [
    Row("base", "MoMu-Diffusion (baseline)", ()),
    Row(
        "+kin",
        "MoMu + MoFusion's scheduled kinematic loss on decoded poses",
        ("method.diffusion_losses=[{name: scheduled_kinematic}]",),
    ),
    Row(
        "+harmony",
        "MoMu + HarmoGAN's harmony loss on decoded poses",
        (
            "method.diffusion_losses=[{name: harmony, normalize: true}]",
            "method.diffusion_loss_weights=[0.1]",
        ),
    ),
    Row(
        "+mfcc",
        "MoMu + HarmoGAN's MFCC encoder as θ_m's condition",
        ("method.motion_condition={name: mfcc, normalize: true}",),
    ),
]

_NOTES = (
    "Music→motion only: θ_a (motion→music) is trained in every row but not scored; the pose losses "
    "act on θ_m alone.",
    "Motion FID uses the MoMu tables' learned motion extractor (16-d) on the evaluation clips of the "
    "`test` split; its *ground truth* is the real-vs-real floor. Motion F1 is the kinematic beat F1 in "
    "0.25-s bins.",
    "The music-following columns are the benchmark's tests (docs/following.md) on the first songs of "
    "the `val` split, one value per song (the mean over the generation seeds); *ground truth* is the "
    "real dance of the same song.",
    "Against the baseline: each row minus `base` on the same clips or songs, pooled over the training "
    "seeds by the clip bootstrap (FID: per seed), with the project's verdict rule.",
)


def mixing_spec(base_config: Any = BASE_CONFIG) -> TableSpec:
    """The mixing table (module docstring)."""
    presets = {name: [*BASE, *overrides] for name, overrides in MIXING_PRESETS.items()}
    return TableSpec(
        name="mixing",
        title="Cross-method mixing: MoFusion's and HarmoGAN's parts on MoMu-Diffusion (music→motion)",
        base_config=base_config,
        presets=presets,
        columns=COLUMNS,
        rows=_ROWS,
        evaluate=evaluate_mixing,
        calibrate=calibrate_mixing,
        check=check_rows,
        notes=_NOTES,
        baseline="base",
    )


def _following(cfg: DictConfig) -> FollowingConfig:
    """The table's ``following`` section with its defaults filled in."""
    node = to_container(cfg.get("following")) or {}
    merged = OmegaConf.merge(OmegaConf.structured(FollowingConfig), node)
    out = OmegaConf.to_object(merged)
    assert isinstance(out, FollowingConfig)
    return out


def _benchmark_pairs(ctx: RunContext, cfg: DictConfig) -> list[Any]:
    """The benchmark's songs: the first ``following.songs`` clips of the table's dataset's
    ``following.split``."""
    from momu.following import load_pairs

    fol = _following(cfg)
    node = {**to_container(cfg.dataset), "split": fol.split}
    songs, seconds = int(fol.songs), float(fol.seconds)
    key = ("mixing pairs", node, songs, seconds)
    return list(ctx.remember(key, lambda: load_pairs(node, seconds, songs)))


def _benchmark(pairs: list[Any], generators: dict[str, Any], cfg: DictConfig) -> dict[str, Any]:
    from momu.following import run_benchmark

    fol = _following(cfg)
    return run_benchmark(
        pairs,
        generators,
        direction="dance",
        seeds=[int(s) for s in fol.generation_seeds],
        factors=[float(f) for f in fol.factors],
        calibration=("ground_truth",),
        controls=False,
        progress=False,
    )


def _per_song(result: dict[str, Any], row_id: str, key: str) -> np.ndarray:
    """``(songs,)``: a test's (or realism statistic's) mean over the generation seeds per song."""
    row = next(r for r in result["rows"] if r["id"] == row_id)
    rec = row["tests"].get(key) or row.get("realism", {}).get(key) or {}
    table = rec.get("per_song_seed", [])
    values = np.asarray([[np.nan if v is None else v for v in song] for song in table], dtype=np.float64)
    if values.size == 0:
        return np.full(len(result["songs"]), np.nan)
    with warnings.catch_warnings():  # a song with no value at any seed stays NaN
        warnings.simplefilter("ignore", RuntimeWarning)
        return np.asarray(np.nanmean(values, axis=1))


def _add_following(scores: Scores, result: dict[str, Any], row_id: str, ids: list[str]) -> None:
    """Cells, per-song evidence (row and ground truth) of every benchmark column; diagnostics."""
    for key in (*FOLLOWING, *REALISM):
        row = _per_song(result, row_id, key)
        scores.metrics[key] = float(np.nanmean(row)) if np.isfinite(row).any() else float("nan")
        if not np.isfinite(row).all():
            continue  # a song without a value: no per-song evidence (no paired comparison)
        scores.add_clips(key, ROW, row, ids=ids)
        if row_id != "ground_truth":
            truth = _per_song(result, "ground_truth", key)
            if np.isfinite(truth).all():
                scores.add_clips(key, "ground truth", truth, ids=ids)
    for key in DIAGNOSTIC_REALISM:
        values = _per_song(result, row_id, key)
        if np.isfinite(values).any():
            scores.metrics[key] = float(np.nanmean(values))


def evaluate_mixing(ctx: RunContext, cfg: DictConfig, seed: int) -> Scores:
    """One row and training seed: train (or reuse) MoMu, then motion FID / F1 and the benchmark."""
    from momu.following.adapters import _MoMuDance
    from momu.methods.momu.scoring import trained_extractors

    method, model, dataset, data_key, folder = fit_momu(ctx, cfg, seed, extractors=("motion",))
    ev = method.cfg.evaluation
    truth = _truth(ctx, dataset, data_key, ev, eval_lengths(ev, seed))
    with ctx.timed("extractors"):
        extractors = trained_extractors(ctx, dataset, data_key, ev, kinds=("motion",))
    scores = Scores(metrics={}, artifacts={"model": str(folder.relative_to(ctx.out_dir))})
    motion = generate_motion(ctx, model, truth, seed, ev.batch_size, other=False)[ROW]
    bins = float(ev.beat_bin_seconds)
    with ctx.timed("metrics"):
        floor = _floors(ctx, extractors, dataset, data_key, ev, truth, kinds=("motion",))["motion_fid"]
        scores.metrics["motion_fid"] = fid(extractors["motion"], motion, truth)
        scores.add_seed_value("motion_fid", "ground truth", floor)
        add_beat_scores(
            scores,
            "motion",
            {
                ROW: beat_components("motion", motion, truth, bins),
                "shuffled": beat_components("motion", _shuffled(truth), truth, bins),
                "ground truth": beat_components("motion", truth, truth, bins),
            },
            excerpt_ids(truth),
        )
    pairs = _benchmark_pairs(ctx, cfg)
    with ctx.timed("following"):
        result = _benchmark(pairs, {"row": _MoMuDance(model)}, cfg)
    _add_following(scores, result, "row", [p.id for p in pairs])
    return scores


def calibrate_mixing(ctx: RunContext, cfg: DictConfig, seed: int) -> dict[str, Scores]:
    """Ground truth (and shuffled ground truth for the beat F1) through the same metric code."""
    ev, truth, floors = calibration_truth(ctx, cfg, kinds=("motion",))
    bins = float(ev.beat_bin_seconds)
    ids = excerpt_ids(truth)
    gt, shuf = Scores(metrics=dict(floors)), Scores(metrics=dict(floors))
    add_beat_scores(gt, "motion", {ROW: beat_components("motion", truth, truth, bins)}, ids)
    add_beat_scores(shuf, "motion", {ROW: beat_components("motion", _shuffled(truth), truth, bins)}, ids)
    pairs = _benchmark_pairs(ctx, cfg)
    result = ctx.remember(("mixing ground truth", [p.id for p in pairs]), lambda: _benchmark(pairs, {}, cfg))
    _add_following(gt, result, "ground_truth", [p.id for p in pairs])
    return {"ground truth": gt, "ground truth, music and motion shuffled": shuf}
