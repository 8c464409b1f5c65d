"""Evaluation of MoFusion's text→motion row (Table 2) and its calibration rows.

Per evaluation clip *i* (the first ``num_clips`` test clips, cut to at most ``seconds``; shorter
clips whole) the model generates, at clip *i*'s own length (T2M's protocol: the lengths come from
the data), from clip *i*'s caption (``row``) and — same sampling seed and length — from clip π(i)'s
caption (*other condition*). A text–motion evaluator (:mod:`momu.metrics.text_motion`) is trained
from scratch on the train split per seed (or loaded from ``evaluation.evaluator_checkpoint``) — or,
with ``evaluation.evaluator_kind: t2m`` and its three paths, T2M's pre-trained evaluator
(:mod:`momu.metrics.t2m_evaluator`) — and scores, on its embeddings (each seed records which
evaluator in ``Scores.artifacts["text_evaluator"]``):

* ``r_precision`` (↑) — T2M's top-k R-precision in batches of 32, per clip a 0/1 hit; *shuffled* =
  clip π(i)'s ground-truth motion retrieved for clip i's caption, *ground truth* = clip i's own;
* ``mm_dist`` (↓) — caption-to-motion embedding distance per clip;
* ``diversity`` (→, closer to ground truth's is better: ``Column.closer_to``) — mean pairwise
  distance of the generated motions' embeddings; this seed's ground-truth value is the reference;
* ``multimodality`` (↑) — mean distance between K generations per caption (at its clip's length).
"""

from __future__ import annotations

import dataclasses
import logging
from typing import Any

import numpy as np
import torch
from omegaconf import DictConfig
from torch.utils.data import Dataset

from momu.config import build_component, to_container
from momu.data.types import Clip
from momu.engine.context import RunContext
from momu.engine.evaluate import map_gathered
from momu.engine.scores import ROW, Scores
from momu.engine.trainer import TrainConfig
from momu.features.mofusion_pose import encode_pose
from momu.features.skeletons import get_skeleton
from momu.methods.mofusion.data import (
    clip_caption,
    collate_text,
    crop,
    global_positions,
    resample_motion,
    split_indices,
)
from momu.methods.mofusion.evaluate import eval_clips, fit_mofusion, repeated_samples
from momu.methods.momu.generation import eval_seeds
from momu.methods.momu.scoring import derangement, excerpt_ids
from momu.methods.momu.stages import stage_step
from momu.metrics.t2m_evaluator import T2MEvaluator
from momu.metrics.text_motion import (
    TextEvaluator,
    TextMotionEvaluator,
    TextMotionEvaluatorConfig,
    caption_tokens,
    embedding_diversity,
    embedding_multimodality,
    mm_distances,
    r_precision_hits,
    vocab_from,
)

__all__ = ["evaluator_for", "t2m_evaluator", "evaluate_text", "calibrate_text"]

log = logging.getLogger(__name__)

OTHER = "other condition"
_EVAL_TRAIN = {"steps": 400, "batch_size": 32, "lr": 1.0e-3, "warmup_steps": 20, "lr_schedule": "cosine"}


class _Pairs(Dataset[dict[str, Any]]):
    def __init__(self, poses: list[np.ndarray], texts: list[list[str]]) -> None:
        self.poses = [torch.as_tensor(p, dtype=torch.float32) for p in poses]
        self.texts = texts

    def __len__(self) -> int:
        return len(self.poses)

    def __getitem__(self, i: int) -> dict[str, Any]:
        pick = int(torch.randint(len(self.texts[i]), ()).item()) if len(self.texts[i]) > 1 else 0
        return {"x": self.poses[i], "text": self.texts[i][pick]}


def _poses(clips: list[Clip], fps: float) -> list[np.ndarray]:
    return [encode_pose(resample_motion(global_positions(c), c.fps, fps)) for c in clips]


_T2M_PATHS = ("evaluator_checkpoint", "glove_dir", "evaluator_meta_dir")


def t2m_evaluator(cfg: DictConfig) -> T2MEvaluator | None:
    """T2M's pre-trained evaluator when ``evaluation.evaluator_kind`` is ``t2m`` and its three paths
    are set; ``None`` otherwise (with a warning naming the unset options when the kind is ``t2m``).

    Raises:
        DataFileError: a path that does not hold T2M's files.
        ValueError: the model does not run at T2M's 20 fps.
    """
    ev = cfg.method.evaluation
    if str(ev.get("evaluator_kind") or "momu") != "t2m":
        return None
    unset = [f"method.evaluation.{k}" for k in _T2M_PATHS if not ev.get(k)]
    if unset:
        log.warning(
            "evaluator_kind=t2m but %s not set (T2M's finest.tar, glove/ and meta/ with mean.npy, std.npy): "
            "training momu's own text–motion evaluator instead",
            ", ".join(unset),
        )
        return None
    if float(cfg.method.fps) != 20.0:
        raise ValueError(
            f"method.evaluation.evaluator_kind=t2m reads 20 fps motion; method.fps is {cfg.method.fps}"
        )
    checkpoint, glove_dir, meta_dir = (str(ev.get(k)) for k in _T2M_PATHS)
    return T2MEvaluator.load(checkpoint, glove_dir, meta_dir)


def evaluator_for(ctx: RunContext, cfg: DictConfig, dataset: Any, seed: int) -> TextEvaluator:
    """The text–motion evaluator of this seed: T2M's (:func:`t2m_evaluator`), the user's momu folder
    (``evaluator_checkpoint``) or one trained from scratch on the train split (a cached stage
    ``t2m_evaluator-<hash>``)."""
    ev = cfg.method.evaluation
    pretrained = t2m_evaluator(cfg)
    if pretrained is not None:
        return pretrained
    if ev.evaluator_checkpoint and str(ev.get("evaluator_kind") or "momu") == "momu":
        return TextMotionEvaluator.load(ev.evaluator_checkpoint)
    fps, seconds = float(cfg.method.fps), float(cfg.method.window_seconds)
    clips = [dataset[i] for i in split_indices(dataset, "train", "text")]
    clips = [crop(c, 0.0, min(seconds, c.duration)) for c in clips]
    params = dict(to_container(ev.evaluator) or {})
    train = TrainConfig(**{**_EVAL_TRAIN, **params.pop("train", {}), "seed": seed})
    channels = 3 * get_skeleton(str(clips[0].skeleton)).num_joints
    ecfg = TextMotionEvaluatorConfig(
        **{**params, "channels": channels, "vocab": vocab_from([t for c in clips for t in c.text], 32)}
    )
    poses = _poses(clips, fps)

    def build() -> TextMotionEvaluator:  # under the stage's own seed (RunContext.stage)
        model = TextMotionEvaluator(ecfg)
        model.set_statistics(poses)
        return model

    key = {
        "stage": "t2m_evaluator",
        "data": to_container(cfg.dataset),
        "fps": fps,
        "seconds": seconds,
        "config": dataclasses.asdict(ecfg),
        "train": dataclasses.asdict(train),
        "seed": seed,
    }
    with ctx.timed("extractors"):
        trained = ctx.stage(
            "t2m_evaluator",
            key,
            build,
            lambda: _Pairs(poses, [list(c.text) for c in clips]),
            stage_step,
            train,
            collate_text,
        )
    assert isinstance(trained, TextMotionEvaluator)
    trained.source = f"momu evaluator trained from scratch on the train split (seed {seed})"
    return trained.to("cpu").eval()


def _texts(evaluator: TextEvaluator, clips: list[Clip]) -> np.ndarray:
    return evaluator.embed_texts([clip_caption(c) for c in clips], [caption_tokens(c) for c in clips])


def _generate(
    ctx: RunContext, model: Any, truth: list[Clip], ev: Any, seed: int
) -> dict[str, list[np.ndarray]]:
    perm = derangement(len(truth))
    texts = [clip_caption(c) for c in truth]

    def generate(indices: list[int]) -> list[dict[str, np.ndarray]]:
        seeds = eval_seeds(seed, indices)
        caps = [texts[j] for j in indices] + [texts[perm[j]] for j in indices]
        out = model.text_to_motion(caps, [truth[j].duration for j in indices] * 2, seeds * 2)
        n = len(indices)
        return [{ROW: out[k], OTHER: out[n + k]} for k in range(n)]

    with ctx.timed("sample text→motion"):
        res = map_gathered(
            ctx.accelerator, list(range(len(truth))), generate, batch_size=ev.batch_size, desc="t2m"
        )
    return {v: [r[v] for r in res] for v in (ROW, OTHER)}


def _multimodality(
    ctx: RunContext, model: Any, truth: list[Clip], ev: Any, seed: int, evaluator: TextEvaluator
) -> float:
    captions, lengths = [clip_caption(c) for c in truth], [c.duration for c in truth]
    jobs, res = repeated_samples(ctx, model.text_to_motion, captions, ev, seed, lengths)
    k = int(ev.multimodality_samples)
    emb = evaluator.embed_motions([encode_pose(r) for r in res])
    return embedding_multimodality([emb[i * k : (i + 1) * k] for i in range(len(jobs) // k)])


def _scores(text: np.ndarray, motion: dict[str, np.ndarray], ev: Any, ids: list[str]) -> Scores:
    """R-precision, MM-Dist and Diversity of clip i's caption (``text[i]``) against each variant's
    motion embeddings; per-clip values recorded under the clips' ``ids``."""
    sc = Scores(metrics={})
    for variant, emb in motion.items():
        hits = r_precision_hits(text, emb, batch=ev.r_precision_batch, top_k=ev.top_k)
        sc.add_clips("r_precision", variant, hits, ids=ids)
        sc.add_clips("mm_dist", variant, mm_distances(text, emb), ids=ids)
    sc.metrics["r_precision"] = float(sc.clips["r_precision"][ROW].mean())
    sc.metrics["mm_dist"] = float(sc.clips["mm_dist"][ROW].mean())
    sc.metrics["diversity"] = embedding_diversity(motion[ROW])
    return sc


def evaluate_text(ctx: RunContext, cfg: DictConfig, seed: int) -> Scores:
    """The Table 2 row for one seed: train (or reuse) model and evaluator, generate, score."""
    method, model, dataset, folder = fit_mofusion(ctx, cfg, seed)
    ev = method.cfg.evaluation
    truth = eval_clips(dataset, ev.split, ev.num_clips, ev.seconds, "text", keep_shorter=True)
    evaluator = evaluator_for(ctx, cfg, dataset, seed)
    samples = _generate(ctx, model, truth, ev, seed)
    with ctx.timed("metrics"):
        text = _texts(evaluator, truth)
        gt = evaluator.embed_motions(_poses(truth, model.fps))
        perm = derangement(len(truth))
        emb = {
            ROW: evaluator.embed_motions([encode_pose(m) for m in samples[ROW]]),
            OTHER: evaluator.embed_motions([encode_pose(m) for m in samples[OTHER]]),
            "shuffled": gt[perm],
            "ground truth": gt,
        }
        scores = _scores(text, emb, ev, excerpt_ids(truth))
        scores.artifacts["model"] = folder
        scores.artifacts["text_evaluator"] = evaluator.describe()
        scores.add_seed_value("diversity", "ground truth", embedding_diversity(gt))
        scores.add_seed_value("diversity", "shuffled", embedding_diversity(gt[perm]))
        scores.metrics["r_precision_other_condition"] = float(scores.clips["r_precision"][OTHER].mean())
        scores.metrics["multimodality"] = _multimodality(ctx, model, truth, ev, seed, evaluator)
    return scores


def calibrate_text(ctx: RunContext, cfg: DictConfig, seed: int) -> dict[str, Scores]:
    """Real text–motion pairs and pairs with the motions shuffled across clips, same evaluator."""
    method = build_component(cfg.method, "methods")
    dataset = build_component(cfg.dataset, "datasets")
    ev = method.cfg.evaluation
    truth = eval_clips(dataset, ev.split, ev.num_clips, ev.seconds, "text", keep_shorter=True)
    evaluator = evaluator_for(ctx, cfg, dataset, seed)
    ids = excerpt_ids(truth)
    with ctx.timed("metrics"):
        text = _texts(evaluator, truth)
        gt = evaluator.embed_motions(_poses(truth, float(method.cfg.fps)))
        perm = derangement(len(truth))
        out = {
            "real text–motion pairs": _scores(text, {ROW: gt}, ev, ids),
            "text and motion shuffled": _scores(text, {ROW: gt[perm]}, ev, ids),
        }
        for sc in out.values():
            sc.artifacts["text_evaluator"] = evaluator.describe()
        return out
