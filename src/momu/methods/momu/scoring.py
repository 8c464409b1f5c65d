"""The metric code every MoMu-Diffusion table shares: beat scores per clip, onsets, extractors, FID/FAD.

Beat columns (MoMu App. B.4–B.5, LORIS ``beats_scores.py``) are recorded as per-clip *components*
— each clip's BCS (cover) and BHS (hit), in percent — so the table runner can pair a row with a
comparison on the same clips (:class:`momu.engine.scores.Scores`). The cells are LORIS's: BCS / BHS
are the means over clips, CSD / HSD their sample standard deviations, F1 the F1 of the means.

The comparison variants a recipe records (:data:`momu.engine.scores.VARIANTS`) use the derangement
π(i) = (i + 1) mod N (:func:`derangement`): *shuffled* pairs clip i's reference with clip π(i)'s
ground truth, *other condition* scores the sample generated from clip π(i)'s condition against clip
i's reference, *other pair* scores one modality of jointly generated pair i against the other
modality of pair π(i).
"""

from __future__ import annotations

import dataclasses
import functools
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from momu.data.types import Clip
from momu.engine.context import RunContext, stage_key_hash
from momu.engine.scores import ROW, Scores, components
from momu.metrics.extractors import TrainConfig as ExtractorTrainConfig
from momu.metrics.extractors import load_extractor, train_extractor
from momu.metrics.extractors.training import Checkpointing
from momu.metrics.kinematic_beats import kinematic_beat_bins, kinematic_beat_frames
from momu.metrics.loris_scores import aggregate_beat_scores, onset_beat_bins, onset_times, pair_beat_scores
from momu.registry import METRICS

__all__ = [
    "BEAT_KEYS",
    "derangement",
    "excerpt_ids",
    "eval_lengths",
    "replace_clip",
    "beat_metric",
    "beat_components",
    "pair_components",
    "add_beat_scores",
    "beat_onset_f1",
    "music_onset_f1s",
    "motion_onset_f1s",
    "trained_extractors",
    "start_extractors",
    "fad",
    "fid",
]

BEAT_KEYS = ("bcs", "csd", "bhs", "hsd", "f1")
"""LORIS beat-score cells, in print order."""


def derangement(n: int) -> list[int]:
    """``π(i) = (i + 1) mod n``: every clip paired with another one (identity for n = 1)."""
    return [(i + 1) % n for i in range(n)]


def excerpt_ids(clips: Sequence[Clip]) -> list[str]:
    """The identities per-clip values are recorded under (``Scores.add_clips(..., ids=)``): each
    evaluation clip is a crop from the start of a dataset clip, named ``<clip id>@0-<seconds>s``, so
    two rows are paired clip by clip only when they were scored on the same crops of the same clips
    (not the 10-s and 20-s crops of one clip, nor another seed's variable lengths)."""
    return [f"{c.id}@0-{c.duration:g}s" for c in clips]


def eval_lengths(cfg: Any, seed: int) -> list[float]:
    """Per-clip lengths (s): all ``seconds``, or uniform in ``[min_seconds, seconds]`` (variable length)."""
    if not cfg.variable_length:
        return [float(cfg.seconds)] * int(cfg.num_clips)
    rng = np.random.default_rng([int(seed), 7])
    return [float(x) for x in rng.uniform(cfg.min_seconds, cfg.seconds, int(cfg.num_clips))]


def replace_clip(
    base: Clip,
    suffix: str,
    *,
    motion: np.ndarray | None = None,
    fps: float | None = None,
    audio: np.ndarray | None = None,
    sample_rate: int | None = None,
) -> Clip:
    """``base`` with a new id suffix and (some of) its motion / audio replaced."""
    return dataclasses.replace(
        base,
        id=base.id + suffix,
        motion=motion if motion is not None else base.motion,
        fps=fps if fps is not None else base.fps,
        audio=audio if audio is not None else base.audio,
        sample_rate=sample_rate if sample_rate is not None else base.sample_rate,
    )


def beat_metric(name: str, bin_seconds: float, **params: Any) -> Any:
    """The registered ``beat_scores`` / ``kinematic_beat_scores`` metric with bins of ``bin_seconds``."""
    return METRICS.build(name, {"bin_seconds": float(bin_seconds), **params})


def beat_components(
    kind: str, generated: Sequence[Clip], reference: Sequence[Clip], bin_seconds: float
) -> np.ndarray:
    """``(N, 2)`` per-clip (BCS, BHS) in percent of generated clips against their references.

    ``kind="music"``: ``beat_scores`` (App. B.4), the generated audio's onset bins against the
    reference audio's; ``kind="motion"``: ``kinematic_beat_scores`` (App. B.5), the generated
    motion's kinematic-beat bins against the reference's music. Both cut a pair to its shorter
    side (lengths differ by rounding, or by design for a shuffled pair).
    """
    if kind not in ("music", "motion"):
        raise ValueError(f"beat_components: kind must be 'music' or 'motion', got {kind!r}")
    name = "beat_scores" if kind == "music" else "kinematic_beat_scores"
    covers, hits = beat_metric(name, bin_seconds, truncate="shortest").pairs(generated, reference)
    return components(covers, hits)


def pair_components(
    music: Sequence[Clip], motion: Sequence[Clip], *, music_is_reference: bool, bin_seconds: float
) -> np.ndarray:
    """``(N, 2)`` per-clip (BCS, BHS) in percent between music onset bins and motion kinematic bins.

    For jointly generated pairs, which have no ground truth to score against: ``music_is_reference``
    is ``kinematic_beat_scores``' direction (motion beats scored against the music), ``False`` the
    reverse. F1 is symmetric in BCS and BHS, so both directions give the same F1.
    """
    covers, hits = [], []
    for a, m in zip(music, motion, strict=True):
        if a.audio is None or m.motion is None:
            raise ValueError("pair_components: clips need audio (music side) and motion (motion side)")
        music_bins = onset_beat_bins(a.audio, int(a.sample_rate or 0), bin_seconds=bin_seconds)
        motion_bins = kinematic_beat_bins(m.motion, m.fps, bin_seconds)
        ref, syn = (music_bins, motion_bins) if music_is_reference else (motion_bins, music_bins)
        cover, hit = pair_beat_scores(ref, syn, truncate="shortest")
        covers.append(cover)
        hits.append(hit)
    return components(covers, hits)


def add_beat_scores(
    scores: Scores, prefix: str, by_variant: Mapping[str, np.ndarray], ids: Sequence[str] | None = None
) -> None:
    """Cells ``<prefix>_{bcs,csd,bhs,hsd,f1}`` from the row's components, and the per-clip evidence.

    ``by_variant`` maps :data:`~momu.engine.scores.ROW` and comparison variants to ``(N, 2)``
    components; the F1 column gets both components (reducer ``f1``), BCS and BHS one each (``mean``).
    ``ids``: the clips' identities (:func:`excerpt_ids`), recorded with every column.
    """
    row = np.asarray(by_variant[ROW], dtype=np.float64)
    cells = aggregate_beat_scores((row[:, 0] / 100.0).tolist(), (row[:, 1] / 100.0).tolist())
    scores.metrics.update({f"{prefix}_{k}": 100.0 * float(cells[k]) for k in BEAT_KEYS})
    for variant, comp in by_variant.items():
        comp = np.asarray(comp, dtype=np.float64)
        scores.add_clips(f"{prefix}_f1", variant, comp, ids=ids)
        scores.add_clips(f"{prefix}_bcs", variant, comp[:, :1], ids=ids)
        scores.add_clips(f"{prefix}_bhs", variant, comp[:, 1:], ids=ids)


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


def music_onset_f1s(
    generated: Sequence[Clip], reference: Sequence[Clip], tolerance: float = 0.05
) -> np.ndarray:
    """Per-clip onset F-measure (percent) of generated music against its reference music (±50 ms).

    A finer diagnostic than the LORIS bins, which saturate on music with a beat every half second:
    onset *times* (LORIS detector, App. B.4) matched within ``± tolerance`` s (:func:`beat_onset_f1`).
    """
    out = []
    for g, r in zip(generated, reference, strict=True):
        if g.audio is None or r.audio is None:
            raise ValueError(f"music_onset_f1s: clip {g.id!r} or {r.id!r} has no audio")
        out.append(
            beat_onset_f1(
                onset_times(r.audio, int(r.sample_rate or 0)),
                onset_times(g.audio, int(g.sample_rate or 0)),
                tolerance,
            )
        )
    return 100.0 * np.asarray(out, dtype=np.float64)


def motion_onset_f1s(music: Sequence[Clip], motion: Sequence[Clip], tolerance: float = 0.05) -> np.ndarray:
    """Per-clip F-measure (percent) of each motion's kinematic beats (MoMu Eq. 2) against the paired
    music's onsets within ``± tolerance`` s."""
    out = []
    for a, m in zip(music, motion, strict=True):
        if a.audio is None or m.motion is None:
            raise ValueError(f"motion_onset_f1s: clip {a.id!r} needs audio and {m.id!r} motion")
        onsets = onset_times(a.audio, int(a.sample_rate or 0))
        beats = kinematic_beat_frames(m.motion, m.fps) / float(m.fps)
        out.append(beat_onset_f1(onsets, beats, tolerance))
    return 100.0 * np.asarray(out, dtype=np.float64)


def trained_extractors(
    ctx: RunContext,
    dataset: Any,
    data_key: Mapping[str, Any],
    cfg: Any,
    kinds: Sequence[str] = ("motion", "audio"),
) -> dict[str, Any]:
    """The FID/FAD feature extractors of ``kinds``, trained once per dataset on its train split.

    ``cfg`` is the evaluation config (``extractor_epochs``, ``extractor_samples_per_clip``,
    ``extractor_embed_dim``, ``extractor_seed``). The extractors do not depend on the models'
    training seed: every row and seed of a table is scored by the same feature maps, so the spread
    over seeds is the models' alone (docs/statistics.md). Cached under
    ``<out>/parts/extractor-<kind>-<hash>.safetensors`` (the hash covers the data, the training
    settings and the extractor seed, not the kind list, so a run that
    needs only the motion classifier shares its file with one that needs both); the main process
    trains, the others wait and load the same files. An extractor another ``--jobs`` worker is
    training is waited for last (:func:`start_extractors`).
    """
    paths = _extractor_paths(ctx, data_key, cfg, kinds)
    for wait in (False, True):
        _train_missing_extractors(ctx, dataset, cfg, paths, wait=wait)
    return {kind: load_extractor(path) for kind, path in paths.items()}


def start_extractors(
    ctx: RunContext, dataset: Any, data_key: Mapping[str, Any], cfg: Any, kinds: Sequence[str]
) -> None:
    """Train now the extractors of ``kinds`` that no other ``--jobs`` worker has or is training.

    A unit calls this before it trains its own stages: two workers that start together then train
    one extractor each (the motion classifier costs several times the audio one), and neither
    waits for an extractor when it comes to score. Numbers do not change: an extractor is seeded
    by ``extractor_seed`` alone, whichever worker trains it and whenever.
    """
    _train_missing_extractors(ctx, dataset, cfg, _extractor_paths(ctx, data_key, cfg, kinds), wait=False)


def _extractor_settings(cfg: Any) -> tuple[ExtractorTrainConfig, int]:
    """The extractors' training settings and embedding width (0: the default) from the evaluation config."""
    train = ExtractorTrainConfig(
        epochs=int(cfg.extractor_epochs),
        samples_per_clip=int(cfg.extractor_samples_per_clip),
        seed=int(getattr(cfg, "extractor_seed", 0)),
        val_fraction=0.0,
    )
    return train, int(getattr(cfg, "extractor_embed_dim", 0) or 0)


def _extractor_paths(
    ctx: RunContext, data_key: Mapping[str, Any], cfg: Any, kinds: Sequence[str]
) -> dict[str, Path]:
    train, embed = _extractor_settings(cfg)
    key = {
        "data": dict(data_key),
        "epochs": train.epochs,
        "samples_per_clip": train.samples_per_clip,
        "seed": train.seed,
        **({"embed_dim": embed} if embed else {}),
    }
    digest = stage_key_hash(key)
    return {kind: ctx.parts_dir / f"extractor-{kind}-{digest}.safetensors" for kind in kinds}


def _train_missing_extractors(
    ctx: RunContext, dataset: Any, cfg: Any, paths: Mapping[str, Path], *, wait: bool
) -> None:
    """Train (main process) or mark reused each extractor of ``paths``; with ``wait=False`` skip
    those whose lock another ``--jobs`` worker holds."""
    from momu.methods.momu.data import select_split

    train, embed = _extractor_settings(cfg)
    clips: list[Clip] = []  # the train split, built once and only if an extractor is trained
    for kind, path in paths.items():
        with ctx.lock(path.stem, wait=wait) as held:
            if not held:
                continue
            # every process passes one barrier per extractor, whatever it finds: the main process may
            # finish a small extractor before another process looks for it, and a skipped barrier
            # would pair with the next extractor's and leave the processes out of step (a hang)
            reused = path.is_file()
            if reused:
                ctx.mark_reused(path.stem, path.with_suffix(".json"))  # the extractor's sidecar
            elif ctx.accelerator.is_main_process:
                if not clips:
                    clips.extend(dataset[i] for i in select_split(dataset, "train"))
                path.parent.mkdir(parents=True, exist_ok=True)
                train_extractor(
                    kind,
                    clips,
                    path,
                    model_config=_extractor_config(kind, embed),
                    train=train,
                    provenance={"git_commit": ctx.commit},
                    checkpointing=Checkpointing(path.with_name(f"{path.stem}.checkpoints"), ctx.resume),
                    on_step=None
                    if ctx.progress is None
                    else functools.partial(ctx.progress.side_step, kind + " extractor"),
                )
            ctx.accelerator.wait_for_everyone()
            if not reused:
                ctx.trained[path.stem] = "trained"


def _extractor_config(kind: str, embed: int) -> Any:
    """The extractor's model config with its embedding width (``None``: the default config)."""
    if not embed:
        return None
    from momu.metrics.extractors import AudioClassifierConfig, MotionClassifierConfig

    return (
        MotionClassifierConfig(embed_dim=embed)
        if kind == "motion"
        else AudioClassifierConfig(embed_dim=embed)
    )


def fad(extractor: Any, generated: Sequence[Clip], reference: Sequence[Clip]) -> float:
    """``fad`` of generated against reference music with a trained audio extractor."""
    return float(METRICS.build("fad", {}, extractor=extractor)(generated, reference)["fad"])


def fid(extractor: Any, generated: Sequence[Clip], reference: Sequence[Clip]) -> float:
    """``fid_learned`` of generated against reference motion with a trained motion extractor."""
    return float(METRICS.build("fid_learned", {}, extractor=extractor)(generated, reference)["fid_learned"])
