"""The ``momu`` method's configuration: :class:`MoMuConfig` (MoMu §3–4) and :class:`MoMuEvalConfig`."""

from __future__ import annotations

import dataclasses
import logging
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from momu.config import to_container
from momu.engine.trainer import TrainConfig
from momu.registry import BACKBONES

log = logging.getLogger(__name__)

__all__ = ["MoMuConfig", "MoMuEvalConfig", "backbone_node", "check_config", "vocoder_node"]


def _node(name: str, **params: Any) -> Callable[[], dict[str, Any]]:
    return lambda: {"name": name, **params}


@dataclass
class MoMuEvalConfig:
    """How a trained MoMu is evaluated (not part of any stage key).

    Attributes:
        task: ``"cross"`` (motion→music and music→motion conditioned on ground truth, Table 7 #1–#4,
            #7) or ``"joint"`` (both generated together by cross guidance, #5, #6, Table 10).
        split: dataset split the evaluation clips come from.
        num_clips: evaluation clips (the first of ``split``).
        seconds: clip length in seconds (the longest when ``variable_length``).
        variable_length: each clip gets its own length in ``[min_seconds, seconds]`` (Table 7 #6).
        min_seconds: shortest length with ``variable_length``.
        reference_split: split whose crops give the real-vs-real FAD/FID floor of the calibration row.
        shuffled_condition: also generate each sample from another clip's condition (same sampling
            seed) — the "other condition" comparison of every cross-modal verdict: a model that
            follows its condition scores lower with it.
        batch_size: clips generated per batch (per process).
        extractor_epochs: epochs of the FID/FAD feature extractors (trained once per run).
        extractor_samples_per_clip: windows/segments per clip per extractor epoch.
        extractor_seed: seed of the extractors' training; fixed, not the models' seed, so every row
            and seed of a table is scored by the same feature maps.
        extractor_embed_dim: width of the extractors' feature (0: the classifiers' own, 224-d motion
            and 128-d audio at the default sizes); a Fréchet distance needs more samples than feature
            dimensions for a full-rank covariance, so small evaluation sets use a narrower feature.
        beat_bin_seconds: bin width of the F1 columns' beat vectors (``beat_scores``,
            ``kinematic_beat_scores``); 1 s is MoMu's / LORIS's. On music with an onset in every
            second one-second bins match every pair (ground truth and shuffled both score 100), so
            the synthetic-data presets use finer bins (see ``recipes/configs/momu.yaml``).
    """

    task: str = "cross"
    split: str = "test"
    num_clips: int = 8
    seconds: float = 4.0
    variable_length: bool = False
    min_seconds: float = 2.0
    reference_split: str = "val"
    shuffled_condition: bool = True
    batch_size: int = 8
    extractor_epochs: int = 20
    extractor_samples_per_clip: int = 8
    extractor_seed: int = 0
    extractor_embed_dim: int = 0
    beat_bin_seconds: float = 1.0


@dataclass
class MoMuConfig:
    """The ``momu`` method (MoMu §3–4; Tables 8–9 and App. A.2/B.3 are the ``paper`` preset).

    Component nodes (``{name: ..., **params}``):
        encoder: the BiCoR-VAE (``bicor_vae``; Table 7 #1/#2 via its ``motion_encoder``/``music_encoder``).
        discriminator_encoder: the mel discriminator of stage 1 (``null``: no GAN term).
        vae_loss, gan_loss, contrastive_loss (``null`` = w/o RCL, Table 7 #3), diffusion_loss.
        scheduler: the training noise schedule (DDPM, T = 1000, linear β 1e-4…0.02).
        music_backbone: θ_a, motion→music; motion_backbone: θ_m, music→motion (``dit``, or ``unet1d``
            for Table 7 #4); in/cond channels are derived from the latent width.
        sampler: cross-modal generation (``cfg``, Eq. 7); joint_sampler: joint generation
            (``cross_guidance``, Alg. 2, γ); vocoder: mel → waveform (``griffin_lim`` or ``bigvgan``).

    Attributes:
        sample_rate: music sample rate in Hz (MoMu App. B.2: 16 kHz).
        window_seconds: training window length (the paper trains on its 10–30 s clips).
        window_hop_seconds: hop between training windows.
        train_min_seconds: variable-length training (MoMu §5.3): each diffusion training item keeps
            a prefix of its window of a length uniform in ``[train_min_seconds, window_seconds]``
            (the rest masked), so variable-length evaluation samples lengths seen in training;
            ``None`` trains at the window length only.
        train_lengths: how those lengths are drawn: ``item`` (each item its own, the rest of the
            window masked) or ``batch`` (one length per batch, every item cut to it: the same
            distribution of lengths with no padded tokens and no attention mask, so a step costs
            what its valid frames cost).
        motion_condition: θ_m's condition *features* (a registered encoder node with
            ``features``/``track``, e.g. ``{name: music_rhythm}``: the song's beat phase, tempo and
            onset envelope at the latent rate); ``null`` conditions θ_m on the music latent alone
            (MoMu Eq. 6).
        music_condition: θ_a's condition features (e.g. ``{name: motion_rhythm}``); ``null``: the
            motion latent alone.
        condition_latents: with condition features, keep the other modality's latent in the
            condition too (concatenated before the features); ``false`` conditions on the features
            alone — what transfers from synthetic to real music (issue 32). Joint generation by
            cross guidance needs latent conditions: without them ``joint`` generates the music
            unconditionally, then the dance to it.
        motion_representation: what the motion VAE learns: ``positions`` (the papers' keypoints) or
            ``root_velocity`` (root-relative pose + the root's horizontal velocity, so a dancer can
            travel; :mod:`momu.features.root_motion`, 3D skeletons only).
        rigid_bones: re-pose generated 3D motion on rigid bones (the training data's mean lengths)
            by forward kinematics of the fitted bone directions (:func:`momu.export.rigid.rigid_motion`),
            so the dancer's limbs keep their length; a generation setting, not part of any stage.
        bone_correction: apply MoMu App. E's bone-length correction to generated motion.
        bone_ratio: its threshold (bones longer than ``ratio ×`` the mean are shortened; 1.3).
        music_sampler, motion_sampler: the sampler node of motion→music (θ_a) and of music→motion
            (θ_m) when the two directions should differ (steps, scheduler, guidance scale w of Eq. 7,
            which the paper does not give); ``null`` uses ``sampler``.
        diffusion_losses: other methods' pose losses added to θ_m's training on its clean estimate
            x̂₀ decoded to joint positions (registered loss nodes with ``decoded_loss``, e.g.
            ``scheduled_kinematic`` — MoFusion Eq. 4–7, 3D skeletons — or ``harmony`` — HarmoGAN
            Eq. 16; :mod:`momu.methods.momu.decoded_losses`); a loss's ``skeleton`` is the data's.
            Needs ``motion_representation: positions``. Empty (the default): MoMu Eq. 6 alone.
        diffusion_loss_weights: the weight of each of ``diffusion_losses`` (empty: 1 each).
        train_music_vae, train_motion_vae, train_diffusion: engine settings of the three stages.
        evaluation: :class:`MoMuEvalConfig`.
    """

    encoder: Any = field(default_factory=_node("bicor_vae"))
    discriminator_encoder: Any = field(default_factory=_node("mel_discriminator"))
    vae_loss: Any = field(default_factory=_node("vae"))
    gan_loss: Any = field(default_factory=_node("gan"))
    contrastive_loss: Any = field(default_factory=_node("rhythmic_contrastive"))
    diffusion_loss: Any = field(default_factory=_node("diffusion"))
    scheduler: Any = field(default_factory=_node("ddpm"))
    music_backbone: Any = field(default_factory=_node("dit"))
    motion_backbone: Any = field(default_factory=_node("dit"))
    sampler: Any = field(default_factory=_node("cfg"))
    joint_sampler: Any = field(default_factory=_node("cross_guidance"))
    vocoder: Any = field(default_factory=_node("griffin_lim"))
    sample_rate: int = 16000
    window_seconds: float = 4.0
    window_hop_seconds: float = 2.0
    train_min_seconds: float | None = None
    train_lengths: str = "item"
    motion_condition: Any = None
    music_condition: Any = None
    condition_latents: bool = True
    motion_representation: str = "positions"
    rigid_bones: bool = False
    bone_correction: bool = False
    bone_ratio: float = 1.3
    music_sampler: Any = None
    motion_sampler: Any = None
    diffusion_losses: list[Any] = field(default_factory=list)
    diffusion_loss_weights: list[float] = field(default_factory=list)
    train_music_vae: TrainConfig = field(default_factory=lambda: TrainConfig(steps=1000, lr=2e-4))
    train_motion_vae: TrainConfig = field(default_factory=lambda: TrainConfig(steps=1000, lr=2e-4))
    train_diffusion: TrainConfig = field(default_factory=lambda: TrainConfig(steps=2000, lr=1e-4))
    evaluation: MoMuEvalConfig = field(default_factory=MoMuEvalConfig)

    def sampler_node(self, direction: str) -> Any:
        """The sampler node of ``"music"`` (motion→music), ``"motion"`` (music→motion) or ``"default"``."""
        node = {"music": self.music_sampler, "motion": self.motion_sampler}.get(direction)
        return node if node is not None else self.sampler


def _plain(node: Any) -> Any:
    plain = to_container(node) if not isinstance(node, (dict, list, str, type(None))) else node
    if isinstance(plain, str):
        return {"name": plain}
    return plain


def backbone_node(node: Any, latent_channels: int, cond_channels: int | None = None) -> dict[str, Any]:
    """The backbone node with ``in_channels`` set to the latent width ``d`` and ``cond_channels`` to
    ``cond_channels`` (default ``d``: the other modality's latent).

    Only fields the backbone's config dataclass has are set, so a plugin backbone whose config has
    neither is built as configured.
    """
    plain = dict(_plain(node))
    entry = BACKBONES.get(plain["name"])
    fields = {f.name for f in dataclasses.fields(entry.config)} if entry.config is not None else set()
    widths = {
        "in_channels": latent_channels,
        "cond_channels": latent_channels if cond_channels is None else cond_channels,
    }
    for key, width in widths.items():
        if key in fields:
            plain[key] = int(width)
    return plain


def check_config(cfg: MoMuConfig) -> None:
    ev = cfg.evaluation
    if ev.task not in ("cross", "joint"):
        raise ValueError(f"method.evaluation.task must be 'cross' or 'joint', got {ev.task!r}")
    if cfg.window_seconds <= 0 or cfg.window_hop_seconds <= 0:
        raise ValueError("method.window_seconds and method.window_hop_seconds must be > 0")
    if ev.seconds <= 0 or ev.num_clips < 1 or ev.batch_size < 1:
        raise ValueError("method.evaluation: seconds, num_clips and batch_size must be positive")
    if ev.variable_length and not 0 < ev.min_seconds <= ev.seconds:
        raise ValueError(
            f"method.evaluation: need 0 < min_seconds <= seconds, got {ev.min_seconds} and {ev.seconds}"
        )
    if cfg.train_min_seconds is not None and not 0 < cfg.train_min_seconds <= cfg.window_seconds:
        raise ValueError(
            f"method.train_min_seconds must be in (0, window_seconds={cfg.window_seconds}], "
            f"got {cfg.train_min_seconds}"
        )
    if cfg.train_lengths not in ("item", "batch"):
        raise ValueError(f"method.train_lengths must be 'item' or 'batch', got {cfg.train_lengths!r}")
    if not cfg.condition_latents and (cfg.motion_condition is None or cfg.music_condition is None):
        raise ValueError(
            "method.condition_latents: false needs both motion_condition and music_condition features "
            "(each denoiser needs some condition)"
        )
    from momu.features.root_motion import check_representation
    from momu.methods.momu.conditions import check_condition_parts

    try:
        check_representation(cfg.motion_representation)
    except ValueError as exc:
        raise ValueError(f"method.motion_representation: {exc}") from None
    check_condition_parts(cfg)
    _check_prediction_types(cfg)
    if cfg.bone_ratio <= 0:
        raise ValueError(f"method.bone_ratio must be > 0, got {cfg.bone_ratio}")
    _check_diffusion_losses(cfg)


def _check_diffusion_losses(cfg: MoMuConfig) -> None:
    """``diffusion_losses``: losses that take decoded poses, one weight each, positions motion."""
    losses, weights = list(cfg.diffusion_losses or []), list(cfg.diffusion_loss_weights or [])
    if weights and len(weights) != len(losses):
        raise ValueError(
            f"method.diffusion_loss_weights: {len(weights)} weight(s) for {len(losses)} diffusion_losses "
            "(give one per loss, or none for 1 each)"
        )
    if any(w < 0 for w in weights):
        raise ValueError(f"method.diffusion_loss_weights must be >= 0, got {weights}")
    if losses and cfg.motion_representation != "positions":
        raise ValueError(
            "method.diffusion_losses: needs motion_representation 'positions' (the losses take the "
            f"decoder's joint positions), got {cfg.motion_representation!r}"
        )
    if losses:
        from momu.methods.momu.decoded_losses import build_decoded_losses, loss_nodes

        build_decoded_losses(loss_nodes(cfg))  # a loss that cannot take decoded poses fails here


def _prediction_type(node: Any) -> str:
    plain = _plain(node)
    if isinstance(plain, dict) and isinstance(plain.get("scheduler"), (dict, str)):
        plain = _plain(plain["scheduler"])  # a sampler node: its scheduler
    return str(plain.get("prediction_type", "epsilon")) if isinstance(plain, dict) else "epsilon"


def _check_prediction_types(cfg: MoMuConfig) -> None:
    """Every prediction type is known, and every sampler's scheduler reads the denoisers' output as
    training defined it."""
    from momu.schedulers.diffusers_schedulers import PREDICTION_TYPES

    keys = ("scheduler", "sampler", "music_sampler", "motion_sampler", "joint_sampler")
    for key in keys:
        node = getattr(cfg, key)
        kind = _prediction_type(node) if node is not None else "epsilon"
        if kind not in PREDICTION_TYPES:
            where = "scheduler" if key == "scheduler" else f"{key}.scheduler"
            raise ValueError(
                f"method.{where}.prediction_type: unknown prediction type {kind!r}; "
                f"valid: {', '.join(PREDICTION_TYPES)}"
            )
    trained = _prediction_type(cfg.scheduler)
    for key in keys[1:]:
        node = getattr(cfg, key)
        if node is not None and _prediction_type(node) != trained:
            raise ValueError(
                f"method.{key}.scheduler.prediction_type is {_prediction_type(node)!r} but the denoisers are "
                f"trained with method.scheduler.prediction_type {trained!r}"
            )


def vocoder_node(node: Any) -> dict[str, Any]:
    """The vocoder node to build: ``bigvgan`` without a local ``checkpoint`` becomes Griffin-Lim.

    MoMu App. A.2 vocodes with BigVGAN, whose weights momu cannot download; a BigVGAN with random
    weights only makes noise. So when no checkpoint is given the method logs a warning and uses
    ``griffin_lim`` on the same mel features, and the results name the vocoder actually used.
    """
    plain = dict(_plain(node))
    if plain.get("name") == "bigvgan" and not plain.get("checkpoint"):
        log.warning(
            "method.vocoder: bigvgan has no local checkpoint (method.vocoder.checkpoint=PATH); "
            "vocoding with griffin_lim instead"
        )
        fallback: dict[str, Any] = {"name": "griffin_lim"}
        if plain.get("mel") is not None:
            fallback["mel"] = plain["mel"]
        return fallback
    return plain
