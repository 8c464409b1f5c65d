"""The ``mofusion`` method's configuration (MoFusion §3–4, supp. B)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from momu.engine.trainer import TrainConfig

__all__ = ["MoFusionConfig", "MoFusionEvalConfig", "TASKS", "EVALUATOR_KINDS", "check_config"]

TASKS = ("music", "text")
EVALUATOR_KINDS = ("momu", "t2m")


def _node(name: str, **params: Any) -> Callable[[], dict[str, Any]]:
    return lambda: {"name": name, **params}


@dataclass
class MoFusionEvalConfig:
    """How the MoFusion tables evaluate a trained model (not part of any stage key).

    Attributes:
        split: dataset split of the evaluation clips.
        num_clips: evaluation clips (the first of ``split``).
        seconds: generation length in seconds (Table 1: 10 s; supp. Table 1: 10 s and 20 s).
        mode: ``generate`` (from the condition alone) or ``forecast`` (supp. Table 2: the first
            ``seed_seconds`` of ground truth are kept, §4.4 / supp. A).
        seed_seconds: the forecasting seed (§4.4: S = 40 frames = 2 s).
        metric_fps: frame rate motion is resampled to before BAS / FID_k / Div_k / Multimodality
            (60: the AIST++/Bailando scale; σ = 3 frames = 50 ms).
        multimodality_clips: conditions of the Multimodality column (MoFusion: all test music).
        multimodality_samples: generations per condition (MoFusion: K = 50).
        reference_split: split whose crops give the real-vs-real FID_k floor.
        batch_size: sequences generated per batch (per process).
        r_precision_batch: T2M's retrieval batch (32) for R-precision (Table 2).
        top_k: R-precision's k (T2M's Top-3; the paper does not say which, A16).
        evaluator: the from-scratch text–motion evaluator's settings (Table 2;
            :class:`TextMotionEvaluatorConfig` fields, trained on the train split per seed).
        evaluator_kind: ``momu`` (that evaluator, or a folder it saved: ``evaluator_checkpoint``) or
            ``t2m`` (T2M's pre-trained evaluator: ``evaluator_checkpoint`` = its ``finest.tar``,
            ``glove_dir``, ``evaluator_meta_dir``; without all three the from-scratch one is trained,
            with a warning). Each seed records the evaluator used (``artifacts.text_evaluator``).
        evaluator_checkpoint: ``momu``: an evaluator folder used instead of training one; ``t2m``:
            T2M's ``checkpoints/t2m/text_mot_match/model/finest.tar``.
        glove_dir: ``t2m``: T2M's ``glove/`` folder (``our_vab_data.npy``, ``_words.pkl``, ``_idx.pkl``).
        evaluator_meta_dir: ``t2m``: the folder of the evaluator's ``mean.npy`` / ``std.npy`` (T2M's
            ``checkpoints/t2m/Comp_v6_KLD01/meta``).
    """

    split: str = "test"
    num_clips: int = 32
    seconds: float = 10.0
    mode: str = "generate"
    seed_seconds: float = 2.0
    metric_fps: float = 60.0
    multimodality_clips: int = 8
    multimodality_samples: int = 5
    reference_split: str = "val"
    batch_size: int = 16
    r_precision_batch: int = 32
    top_k: int = 3
    evaluator: dict[str, Any] = field(default_factory=dict)
    evaluator_kind: str = "momu"
    evaluator_checkpoint: str | None = None
    glove_dir: str | None = None
    evaluator_meta_dir: str | None = None


@dataclass
class MoFusionConfig:
    """The ``mofusion`` method (MoFusion §3, supp. B; the paper preset pins every value it gives).

    Component nodes:
        backbone: the ε-predictor over the ``(T, 3J)`` pose vector (``unet1d``; any backbone of
            docs/protocols.md); ``in_channels`` and ``cond_channels`` are derived.
        loss: ``scheduled_kinematic`` (Eq. 4–7; its ``skeleton`` is derived from the data).
        scheduler: DDPM, T = 1000, linear β 1e-4…0.02 (supp. B).
        sampler: generation (``cfg``; guidance 1 = no classifier-free guidance, as the paper).
        inpainting_sampler: forecasting / in-betweening / editing (§4.4).
        text_encoder: ``text_transformer`` or ``clip_text`` (``task: text``).

    Attributes:
        task: ``music`` (music→dance, §3.3 mel condition) or ``text`` (text→motion).
        fps: the model's motion rate (§4.4: S = 40 frames = 2 s ⇒ 20 fps).
        window_seconds: training window (music; the text task trains on whole clips ≤ this).
        window_hop_seconds: hop between training windows.
        mel_bins: mel bands of the condition (§3.3: 80).
        train_text: also train the text encoder (from-scratch ``text_transformer``); a
            frozen CLIP stays fixed.
        train: engine settings (supp. B: AdamW 5e-4, batch 32 for music; 2e-4, batch 128, 500
            warm-up iterations for text; steps not given).
        evaluation: :class:`MoFusionEvalConfig`.
    """

    task: str = "music"
    backbone: Any = field(default_factory=_node("unet1d"))
    loss: Any = field(default_factory=_node("scheduled_kinematic"))
    scheduler: Any = field(default_factory=_node("ddpm"))
    sampler: Any = field(
        default_factory=_node("cfg", guidance_scale=1.0, num_inference_steps=None, scheduler={"name": "ddpm"})
    )
    inpainting_sampler: Any = field(
        default_factory=_node(
            "inpainting", guidance_scale=1.0, num_inference_steps=None, scheduler={"name": "ddpm"}
        )
    )
    text_encoder: Any = field(default_factory=_node("text_transformer"))
    fps: float = 20.0
    window_seconds: float = 10.0
    window_hop_seconds: float = 2.0
    mel_bins: int = 80
    train_text: bool = True
    train: TrainConfig = field(default_factory=lambda: TrainConfig(steps=200_000, batch_size=32, lr=5e-4))
    evaluation: MoFusionEvalConfig = field(default_factory=MoFusionEvalConfig)


def check_config(cfg: MoFusionConfig) -> None:
    """Raise ``ValueError`` naming the first invalid field."""
    ev = cfg.evaluation
    if cfg.task not in TASKS:
        raise ValueError(f"method.task must be one of {TASKS}, got {cfg.task!r}")
    if cfg.fps <= 0 or cfg.window_seconds <= 0 or cfg.window_hop_seconds <= 0:
        raise ValueError("method.fps, method.window_seconds and method.window_hop_seconds must be > 0")
    if ev.mode not in ("generate", "forecast"):
        raise ValueError(f"method.evaluation.mode must be 'generate' or 'forecast', got {ev.mode!r}")
    if ev.seconds <= 0 or ev.num_clips < 2 or ev.batch_size < 1:
        raise ValueError("method.evaluation: seconds > 0, num_clips >= 2 and batch_size >= 1 are needed")
    if ev.mode == "forecast" and not 0 < ev.seed_seconds < ev.seconds:
        raise ValueError(
            f"method.evaluation.seed_seconds must be in (0, seconds={ev.seconds}), got {ev.seed_seconds}"
        )
    if ev.multimodality_samples < 2 or ev.multimodality_clips < 1:
        raise ValueError("method.evaluation: multimodality_samples >= 2 and multimodality_clips >= 1")
    if ev.top_k < 1 or ev.r_precision_batch < ev.top_k:
        raise ValueError("method.evaluation: need 1 <= top_k <= r_precision_batch")
    if ev.evaluator_kind not in EVALUATOR_KINDS:
        raise ValueError(
            f"method.evaluation.evaluator_kind must be one of {EVALUATOR_KINDS}, got {ev.evaluator_kind!r}"
        )
