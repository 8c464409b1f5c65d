"""``momu``: the MoMu-Diffusion method (MoMu §3–4, App. A–B) assembled from registered parts.

Training (:meth:`MoMu.fit`, every stage through :meth:`momu.engine.context.RunContext.stage`):

1. **Stage 1 — music VAE** (App. A.2, Eq. 10): ``L_recon + λ1 L_KL + λ2 L_GAN`` with the mel
   discriminator (λ1 = 1e-5 in ``vae_loss``, λ2 = 0.5 in ``gan_loss``).
2. **Stage 2 — motion VAE** (Eq. 11): ``L_recon + λ3 L_KL + λ4 L_contrast`` with the music VAE
   frozen (λ3 = 1e-5, λ4 = 1 in ``contrastive_loss``; ``contrastive_loss: null`` is Table 7 #3).
3. **Diffusion** (Eq. 6): θ_a (motion→music) and θ_m (music→motion) on the aligned latents,
   ε-prediction with condition dropout for classifier-free guidance.

Stage keys hold everything that determines a stage's weights — its part configs, its training
config, the dataset config and window, the seed, and the keys of the stages it builds on — so
rows of a table that share a stage train it once (Table 7 #1 and #3 reuse stage 1; #5–#7 share
everything and differ only in how they sample).

Backbone widths are derived, not configured: ``in_channels`` and ``cond_channels`` of both
backbones are set to the VAE latent width ``d`` when they are fields of the backbone's config
dataclass (``dit``, ``unet1d`` and any plugin backbone following docs/protocols.md).

Generation (:class:`MoMuModel`): motion→music (``sampler``, CFG Eq. 7; decode the mel and vocode
it, or decode the waveform), music→motion (CFG; decode keypoints; optional App. E bone-length
correction), joint (``joint_sampler``, cross guidance Alg. 2 with T_c = γT) and variable length
(each item its own length; padded batches with masks, MoMu §5.3). A trained model saves as a
folder of parts (``config.json`` + ``model.safetensors`` each, strict loading) plus JSON
normalisation statistics (:meth:`MoMuModel.save` / :meth:`MoMuModel.load`).
"""

from __future__ import annotations

import dataclasses
import logging
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import torch
from omegaconf import OmegaConf
from torch import nn

from momu.config import build_component, to_container
from momu.encoders.bicor_vae import BiCoRVAE
from momu.engine.context import RunContext, stage_key_hash
from momu.engine.trainer import TrainConfig
from momu.features.bones import correct_bone_lengths, mean_bone_lengths
from momu.features.preprocess import Normalizer
from momu.features.skeletons import get_skeleton
from momu.io import read_json, write_json
from momu.methods.momu_data import MoMuNormalizers, Rates, WindowDataset, select_split
from momu.methods.momu_stages import DiffusionStage, MotionVAEStage, stage_step, train_music_vae_stage
from momu.parts_io import load_part, save_part
from momu.registry import BACKBONES, METHODS
from momu.samplers.base import lengths_to_mask

__all__ = ["MoMuConfig", "MoMuEvalConfig", "MoMu", "MoMuModel", "build_momu", "backbone_node"]

log = logging.getLogger(__name__)

FORMAT_VERSION = 1


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
        shuffled_condition: also generate motion from a shuffled music condition and report its F1
            (``motion_f1_shuffled_cond``): the check that motion follows its own music.
        batch_size: clips generated per batch (per process).
        extractor_epochs: epochs of the FID/FAD feature extractors (trained once per run).
        extractor_samples_per_clip: windows/segments per clip per extractor epoch.
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
        bone_correction: apply MoMu App. E's bone-length correction to generated motion.
        bone_ratio: its threshold (bones longer than ``ratio ×`` the mean are shortened; 1.3).
        music_sampler, motion_sampler: the sampler node of motion→music (θ_a) and of music→motion
            (θ_m) when the two directions should differ (steps, scheduler, guidance scale w of Eq. 7,
            which the paper does not give); ``null`` uses ``sampler``.
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
    bone_correction: bool = False
    bone_ratio: float = 1.3
    music_sampler: Any = None
    motion_sampler: Any = None
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


def backbone_node(node: Any, latent_channels: int) -> dict[str, Any]:
    """The backbone node with ``in_channels`` / ``cond_channels`` set to the latent width ``d``.

    Only fields the backbone's config dataclass has are set, so a plugin backbone whose config has
    neither is built as configured.
    """
    plain = dict(_plain(node))
    entry = BACKBONES.get(plain["name"])
    fields = {f.name for f in dataclasses.fields(entry.config)} if entry.config is not None else set()
    for key in ("in_channels", "cond_channels"):
        if key in fields:
            plain[key] = int(latent_channels)
    return plain


def _check_config(cfg: MoMuConfig) -> None:
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
    if cfg.bone_ratio <= 0:
        raise ValueError(f"method.bone_ratio must be > 0, got {cfg.bone_ratio}")


class MoMu:
    """The registered ``momu`` method: builds the parts and trains them through a run context."""

    def __init__(self, cfg: MoMuConfig) -> None:
        _check_config(cfg)
        self.cfg = cfg

    # ---------------------------------------------------------------- parts
    def build_encoder(self) -> BiCoRVAE:
        vae = build_component(self.cfg.encoder, "encoders")
        if not isinstance(vae, BiCoRVAE):
            raise ValueError(f"method.encoder: expected a BiCoR-VAE, got {type(vae).__name__}")
        return vae

    def rates(self, vae: BiCoRVAE) -> Rates:
        return Rates(
            sample_rate=int(self.cfg.sample_rate),
            hop_length=256,
            music_frames_per_latent=int(vae.music_vae.frames_per_latent),
            motion_frames_per_latent=int(vae.motion_vae.frames_per_latent),
            music_input=vae.music_input,
        )

    def backbone_nodes(self, latent_channels: int) -> tuple[dict[str, Any], dict[str, Any]]:
        return (
            backbone_node(self.cfg.music_backbone, latent_channels),
            backbone_node(self.cfg.motion_backbone, latent_channels),
        )

    # ---------------------------------------------------------------- stage keys
    def _encoder_parts(self) -> tuple[dict[str, Any], dict[str, Any]]:
        enc = dict(_plain(self.cfg.encoder))
        music_keys = ("name", "mel_bins", "music", "music_encoder")
        music = {k: enc.get(k) for k in music_keys}
        motion = {k: v for k, v in enc.items() if k not in music_keys[1:]}
        return music, motion

    def stage_keys(self, data_key: Mapping[str, Any], seed: int) -> dict[str, dict[str, Any]]:
        """The keys of the three stages (see the module docstring)."""
        c = self.cfg
        music, motion = self._encoder_parts()
        data = {
            "dataset": dict(data_key),
            "sample_rate": c.sample_rate,
            "window_seconds": c.window_seconds,
            "window_hop_seconds": c.window_hop_seconds,
        }
        k1 = {
            "stage": "music_vae",
            "data": data,
            "music_vae": music,
            "discriminator": _plain(c.discriminator_encoder),
            "vae_loss": _plain(c.vae_loss),
            "gan_loss": _plain(c.gan_loss),
            "train": dataclasses.asdict(c.train_music_vae),
            "seed": seed,
        }
        k2 = {
            "stage": "motion_vae",
            "after": stage_key_hash(k1),
            "data": data,
            "motion_vae": motion,
            "vae_loss": _plain(c.vae_loss),
            "contrastive_loss": _plain(c.contrastive_loss),
            "train": dataclasses.asdict(c.train_motion_vae),
            "seed": seed,
        }
        k3 = {
            "stage": "diffusion",
            "after": stage_key_hash(k2),
            "data": data,
            "music_backbone": _plain(c.music_backbone),
            "motion_backbone": _plain(c.motion_backbone),
            "scheduler": _plain(c.scheduler),
            "diffusion_loss": _plain(c.diffusion_loss),
            "train": dataclasses.asdict(c.train_diffusion),
            "seed": seed,
        }
        return {"music_vae": k1, "motion_vae": k2, "diffusion": k3}

    # ---------------------------------------------------------------- training
    def fit(self, ctx: RunContext, dataset: Any, data_key: Mapping[str, Any], seed: int) -> MoMuModel:
        """Train (or reuse) the three stages on the dataset's ``train`` split; returns the model."""
        c = self.cfg
        train_idx = select_split(dataset, "train")
        if not train_idx:
            raise ValueError("the dataset has no 'train' clips with motion and audio")
        train_clips = [dataset[i] for i in train_idx]
        norms = MoMuNormalizers.fit(train_clips, c.sample_rate)
        torch.manual_seed(seed)  # initial weights are part of the stage (the key holds the seed)
        vae = self.build_encoder()
        rates = self.rates(vae)
        keys = self.stage_keys(data_key, seed)
        cache: dict[str, WindowDataset] = {}

        def windows() -> WindowDataset:
            if "w" not in cache:
                cache["w"] = WindowDataset(
                    train_clips,
                    norms,
                    rates,
                    c.window_seconds,
                    c.window_hop_seconds,
                    need_mel=vae.music_input == "mel",
                    need_wave=vae.music_input == "waveform",
                )
                log.info("momu: %d training windows of %.2f s", len(cache["w"]), cache["w"].window_seconds)
            return cache["w"]

        # Stage 1: music VAE (+ GAN), Eq. 10.
        train_music_vae_stage(ctx, vae, c, keys["music_vae"], windows, seed)

        # Stage 2: motion VAE + rhythmic contrastive loss, music VAE frozen, Eq. 11.
        vae.freeze_music(True)
        contrastive = (
            build_component(c.contrastive_loss, "losses") if c.contrastive_loss is not None else None
        )
        stage2 = MotionVAEStage(vae, build_component(c.vae_loss, "losses"), contrastive)

        def stage2_data() -> WindowDataset:
            data = windows()
            fit_lengths = getattr(vae.motion_vae, "fit_bone_lengths", None)
            if callable(fit_lengths):  # directional vectors decode with the data's mean bone lengths
                fit_lengths(torch.stack([item["motion"] for item in data.items]))
            return data

        ctx.stage(
            "motion_vae",
            keys["motion_vae"],
            stage2,
            stage2_data,
            stage_step,
            dataclasses.replace(c.train_motion_vae, seed=seed),
        )
        vae = vae.to("cpu").eval()

        # Diffusion: θ_a and θ_m on the aligned latents, Eq. 6.
        music_node, motion_node = self.backbone_nodes(vae.latent_channels)
        music_bb = build_component(music_node, "backbones")
        motion_bb = build_component(motion_node, "backbones")
        scheduler = build_component(c.scheduler, "schedulers")
        loss = build_component(c.diffusion_loss, "losses", scheduler=scheduler)
        diffusion = DiffusionStage(music_bb, motion_bb, loss, vae.latent_channels)

        def latent_data() -> LatentDataset:
            z_music, z_motion = encode_windows(vae, windows())
            diffusion.set_statistics(z_music, z_motion)
            return LatentDataset(z_music, z_motion)

        ctx.stage(
            "diffusion",
            keys["diffusion"],
            diffusion,
            latent_data,
            stage_step,
            dataclasses.replace(c.train_diffusion, seed=seed),
        )
        diffusion = diffusion.to("cpu").eval()
        skeleton = str(train_clips[0].skeleton or "")
        bones = get_skeleton(skeleton).bones if skeleton else ()
        lengths = (
            np.asarray(
                mean_bone_lengths([np.asarray(cl.motion, dtype=np.float64) for cl in train_clips], bones)
            )
            if bones
            else np.zeros(0)
        )
        return MoMuModel(
            cfg=c,
            vae=vae,
            music_backbone=diffusion.music_backbone,
            motion_backbone=diffusion.motion_backbone,
            norms=norms,
            latent_music=Normalizer(diffusion.statistic("music_mean"), diffusion.statistic("music_std")),
            latent_motion=Normalizer(diffusion.statistic("motion_mean"), diffusion.statistic("motion_std")),
            rates=rates,
            skeleton=skeleton,
            bone_lengths=lengths,
            backbone_nodes=(music_node, motion_node),
        )


class LatentDataset(torch.utils.data.Dataset[dict[str, torch.Tensor]]):
    """Paired raw latents ``(T_z, d)`` of the training windows."""

    def __init__(self, z_music: torch.Tensor, z_motion: torch.Tensor) -> None:
        self.z_music, self.z_motion = z_music, z_motion

    def __len__(self) -> int:
        return int(self.z_music.shape[0])

    def __getitem__(self, index: int) -> dict[str, torch.Tensor]:
        return {"z_music": self.z_music[index], "z_motion": self.z_motion[index]}


@torch.no_grad()
def encode_windows(
    vae: BiCoRVAE, data: WindowDataset, batch_size: int = 32
) -> tuple[torch.Tensor, torch.Tensor]:
    """Posterior means of every window: ``(N, T_z, d)`` music and motion latents (aligned, §3.2)."""
    vae = vae.eval()
    key = "wave" if vae.music_input == "waveform" else "mel"
    device = next(vae.parameters()).device
    zs_a, zs_m = [], []
    for start in range(0, len(data), batch_size):
        items = data.items[start : start + batch_size]
        music = torch.stack([it[key] for it in items]).to(device)
        motion = torch.stack([it["motion"] for it in items]).to(device)
        q_m, q_a, _ = vae.encode_pair(motion, music)
        zs_a.append(q_a.mode().cpu())
        zs_m.append(q_m.mode().cpu())
    return torch.cat(zs_a), torch.cat(zs_m)


def _item_noise(length: int, channels: int, seed: int) -> tuple[torch.Tensor, torch.Generator]:
    """An item's initial noise ``(length, channels)`` and its generator, which then draws the item's
    stochastic sampling steps: a sample depends on its seed only, not on the batch, the process or
    what ran before it."""
    gen = torch.Generator().manual_seed(int(seed))
    return torch.randn(length, channels, generator=gen), gen


def _pad(items: Sequence[torch.Tensor]) -> tuple[torch.Tensor, torch.Tensor | None]:
    """Stack ``(T_i, C)`` tensors into ``(B, T_max, C)`` (zero padded) and a mask (None if all equal)."""
    lengths = [int(x.shape[0]) for x in items]
    longest = max(lengths)
    out = torch.zeros(len(items), longest, items[0].shape[-1], dtype=items[0].dtype)
    for i, x in enumerate(items):
        out[i, : x.shape[0]] = x
    mask = None if len(set(lengths)) == 1 else lengths_to_mask(lengths, longest)
    return out, mask


def sample_items(
    sampler: Any,
    backbone: nn.Module,
    conds: Sequence[torch.Tensor],
    seeds: Sequence[int],
    channels: int,
    guidance_scale: float | None = None,
) -> list[torch.Tensor]:
    """One CFG sample ``(T_i, channels)`` per condition ``(T_i, C)``, in one padded batch.

    Each item's initial noise and stochastic steps come from a generator seeded by its seed, so a
    sample depends on its seed and condition only.
    """
    if len(conds) != len(seeds):
        raise ValueError(f"seeds: {len(seeds)} seeds for {len(conds)} inputs")
    items = [_item_noise(c.shape[0], channels, s) for c, s in zip(conds, seeds)]
    noise, x_mask = _pad([n for n, _ in items])
    cond, cond_mask = _pad(list(conds))
    z = sampler.sample(
        backbone,
        noise,
        cond,
        x_mask=x_mask,
        cond_mask=cond_mask,
        guidance_scale=guidance_scale,
        generator=[g for _, g in items],
    )
    return [z[i, : c.shape[0]] for i, c in enumerate(conds)]


class MoMuModel:
    """A trained MoMu-Diffusion: BiCoR-VAE, θ_a, θ_m, normalisers; generation in every direction.

    Every generator takes per-item ``seeds``. In cross-modal generation an item's initial noise and
    the noise of its stochastic steps (DDPM) come from its own seeded generator, so an item is
    generated identically alone, in a batch, on another process, or after any other work (joint
    generation: the initial noise, with the deterministic DDIM steps of the default sampler).
    """

    def __init__(
        self,
        *,
        cfg: MoMuConfig,
        vae: BiCoRVAE,
        music_backbone: nn.Module,
        motion_backbone: nn.Module,
        norms: MoMuNormalizers,
        latent_music: Normalizer,
        latent_motion: Normalizer,
        rates: Rates,
        skeleton: str,
        bone_lengths: np.ndarray,
        backbone_nodes: tuple[dict[str, Any], dict[str, Any]],
    ) -> None:
        self.cfg = cfg
        self.vae = vae.eval()
        self.music_backbone = music_backbone.eval()
        self.motion_backbone = motion_backbone.eval()
        self.norms = norms
        self.latent_music = latent_music
        self.latent_motion = latent_motion
        self.rates = rates
        self.skeleton = skeleton
        self.bone_lengths = np.asarray(bone_lengths, dtype=np.float64)
        self.backbone_nodes = backbone_nodes
        self._samplers: dict[str, Any] = {}
        self._joint: Any = None
        self._vocoder: Any = None

    # ---------------------------------------------------------------- lazily built parts
    @property
    def sampler(self) -> Any:
        """The default cross-modal sampler (``cfg.sampler``)."""
        return self.sampler_for("default")

    def sampler_for(self, direction: str) -> Any:
        """The sampler of ``"music"`` (motion→music), ``"motion"`` (music→motion) or ``"default"``."""
        if direction not in self._samplers:
            self._samplers[direction] = build_component(self.cfg.sampler_node(direction), "samplers")
        return self._samplers[direction]

    @property
    def joint_sampler(self) -> Any:
        if self._joint is None:
            self._joint = build_component(self.cfg.joint_sampler, "samplers")
        return self._joint

    @property
    def vocoder(self) -> Any:
        if self._vocoder is None:
            self._vocoder = build_component(self.cfg.vocoder, "vocoders")
        return self._vocoder

    @property
    def latent_channels(self) -> int:
        return int(self.vae.latent_channels)

    # ---------------------------------------------------------------- encoders
    def _standardise(self, z: torch.Tensor, norm: Normalizer) -> torch.Tensor:
        return norm.transform(z.float())

    @torch.no_grad()
    def encode_music(self, audio: np.ndarray, sample_rate: int) -> torch.Tensor:
        """Standardised music latent ``(T_z, d)`` of a waveform (``T_z`` = whole latent frames it covers)."""
        from momu.data.types import Clip
        from momu.methods.momu_data import _waveform

        wave = _waveform(
            Clip(id="input", motion=None, fps=1.0, audio=audio, sample_rate=sample_rate),
            self.rates.sample_rate,
        )
        n = self.rates.latent_frames(len(wave) / self.rates.sample_rate)
        if self.rates.music_input == "waveform":
            need = n * self.rates.samples_per_latent
            x = torch.from_numpy(np.pad(wave, (0, max(0, need - len(wave))))[:need])[None]
        else:
            mel = self.norms.mel_of(wave, self.rates.sample_rate)
            need = n * self.rates.music_frames_per_latent
            if mel.shape[1] < need:
                mel = np.pad(mel, ((0, 0), (0, need - mel.shape[1])), mode="edge")
            x = torch.from_numpy(np.ascontiguousarray(mel[:, :need]))[None]
        z = self.vae.encode_music(x).mode()[0]
        return self._standardise(z, self.latent_music)

    @torch.no_grad()
    def encode_motion(self, motion: np.ndarray, fps: float) -> torch.Tensor:
        """Standardised motion latent ``(T_z, d)`` of ``(T, J, D)`` keypoints at ``fps``."""
        m = np.asarray(motion, dtype=np.float32)
        if m.ndim != 3:
            raise ValueError(f"motion must be (T, J, D), got shape {m.shape}")
        n = self.rates.latent_frames(m.shape[0] / float(fps))
        x = torch.from_numpy(self.norms.motion.transform(m))[None]
        z = self.vae.encode_motion(x, n).mode()[0]
        return self._standardise(z, self.latent_motion)

    # ---------------------------------------------------------------- decoders
    @torch.no_grad()
    def decode_music(self, z: torch.Tensor) -> np.ndarray:
        """Standardised latent ``(T_z, d)`` -> waveform ``(S,)`` at ``rates.sample_rate``."""
        raw = self.latent_music.inverse(z.float())[None]
        out = self.vae.decode_music(raw)[0].cpu().numpy()
        if self.rates.music_input == "waveform":
            return np.clip(out, -1.0, 1.0).astype(np.float32)
        return np.asarray(self.vocoder.synthesize(self.norms.mel_inverse(out)), dtype=np.float32)

    @torch.no_grad()
    def decode_motion(self, z: torch.Tensor) -> np.ndarray:
        """Standardised latent ``(T_z, d)`` -> keypoints ``(T_z · frames_per_latent, J, D)``.

        The frame rate is ``rates.motion_fps``.
        """
        raw = self.latent_motion.inverse(z.float())[None]
        out = self.vae.decode_motion(raw)[0].cpu().numpy()
        motion = np.asarray(self.norms.motion.inverse(out), dtype=np.float32)
        if self.cfg.bone_correction and self.bone_lengths.size:
            motion = np.asarray(
                correct_bone_lengths(
                    motion.astype(np.float64),
                    get_skeleton(self.skeleton).bones,
                    self.bone_lengths,
                    self.cfg.bone_ratio,
                ),
                dtype=np.float32,
            )
        return motion

    # ---------------------------------------------------------------- generation
    def _cfg_sample(
        self,
        direction: str,
        conds: Sequence[torch.Tensor],
        seeds: Sequence[int],
        guidance_scale: float | None,
    ) -> list[torch.Tensor]:
        backbone = self.music_backbone if direction == "music" else self.motion_backbone
        return sample_items(
            self.sampler_for(direction), backbone, conds, seeds, self.latent_channels, guidance_scale
        )

    def music_to_motion(
        self,
        audios: Sequence[np.ndarray],
        sample_rate: int,
        seeds: Sequence[int],
        *,
        guidance_scale: float | None = None,
    ) -> list[np.ndarray]:
        """Music→motion (θ_m, CFG Eq. 7): one ``(T, J, D)`` motion at ``rates.motion_fps`` per waveform.

        ``guidance_scale`` overrides the sampler's (``motion_sampler``, else ``sampler``).
        """
        conds = [self.encode_music(a, sample_rate) for a in audios]
        return [self.decode_motion(z) for z in self._cfg_sample("motion", conds, seeds, guidance_scale)]

    def motion_to_music(
        self,
        motions: Sequence[np.ndarray],
        fps: float | Sequence[float],
        seeds: Sequence[int],
        *,
        guidance_scale: float | None = None,
    ) -> list[np.ndarray]:
        """Motion→music (θ_a, CFG Eq. 7; mel decoded and vocoded): waveforms at ``rates.sample_rate``.

        ``guidance_scale`` overrides the sampler's (``music_sampler``, else ``sampler``).
        """
        rates = [float(fps)] * len(motions) if isinstance(fps, (int, float)) else [float(f) for f in fps]
        conds = [self.encode_motion(m, f) for m, f in zip(motions, rates)]
        return [self.decode_music(z) for z in self._cfg_sample("music", conds, seeds, guidance_scale)]

    @torch.no_grad()
    def joint(self, seconds: Sequence[float], seeds: Sequence[int]) -> list[tuple[np.ndarray, np.ndarray]]:
        """Joint generation by cross guidance (Alg. 2, T_c = γT): ``(waveform, motion)`` per length.

        Items of different lengths are generated in one padded batch with masks (MoMu §5.3).
        """
        if len(seconds) != len(seeds):
            raise ValueError(f"seeds: {len(seeds)} seeds for {len(seconds)} lengths")
        d = self.latent_channels
        lengths = [self.rates.latent_frames(float(s)) for s in seconds]
        music_noise, mask = _pad([_item_noise(n, d, 2 * s)[0] for n, s in zip(lengths, seeds)])
        motion_noise, _ = _pad([_item_noise(n, d, 2 * s + 1)[0] for n, s in zip(lengths, seeds)])
        z_a, z_m = self.joint_sampler.sample(
            self.music_backbone,
            self.motion_backbone,
            music_noise,
            motion_noise,
            music_mask=mask,
            motion_mask=mask,
        )
        return [
            (self.decode_music(z_a[i, :n]), self.decode_motion(z_m[i, :n])) for i, n in enumerate(lengths)
        ]

    # ---------------------------------------------------------------- save / load
    def save(self, folder: str | Path) -> Path:
        """Write ``momu.json``, a part folder per module (config.json + model.safetensors), JSON stats."""
        folder = Path(folder)
        folder.mkdir(parents=True, exist_ok=True)
        enc = dict(_plain(self.cfg.encoder))
        save_part(self.vae, "encoders", enc.pop("name"), enc, folder / "encoder")
        for sub, node, module in (
            ("music_backbone", self.backbone_nodes[0], self.music_backbone),
            ("motion_backbone", self.backbone_nodes[1], self.motion_backbone),
        ):
            params = dict(node)
            save_part(module, "backbones", params.pop("name"), params, folder / sub)
        self.norms.save(folder)
        self.latent_music.save(folder / "latent_music_normalizer.json")
        self.latent_motion.save(folder / "latent_motion_normalizer.json")
        from momu import __version__

        write_json(
            folder / "momu.json",
            {
                "format": FORMAT_VERSION,
                "method": "momu",
                "momu_version": __version__,
                "config": OmegaConf.to_container(OmegaConf.structured(self.cfg), resolve=True),
                "rates": dataclasses.asdict(self.rates),
                "skeleton": self.skeleton,
                "bone_lengths": self.bone_lengths.tolist(),
            },
        )
        return folder

    @classmethod
    def load(cls, folder: str | Path) -> MoMuModel:
        """Load a folder written by :meth:`save` (parts strictly; errors name the file)."""
        folder = Path(folder)
        meta_path = folder / "momu.json"
        if not meta_path.is_file():
            raise FileNotFoundError(f"{meta_path}: not a saved MoMu model (momu.json missing)")
        meta = read_json(meta_path)
        if not isinstance(meta, dict) or meta.get("method") != "momu":
            raise ValueError(f"{meta_path}: not a MoMu model record")
        if int(meta.get("format", 0)) > FORMAT_VERSION:
            raise ValueError(f"{meta_path}: format {meta['format']} is newer than this momu reads")
        cfg = OmegaConf.to_object(OmegaConf.merge(OmegaConf.structured(MoMuConfig), meta["config"]))
        assert isinstance(cfg, MoMuConfig)
        vae = load_part(folder / "encoder")
        if not isinstance(vae, BiCoRVAE):
            raise ValueError(f"{folder / 'encoder'}: not a BiCoR-VAE")
        music_bb = load_part(folder / "music_backbone")
        motion_bb = load_part(folder / "motion_backbone")
        from momu.parts_io import read_part_config

        nodes = tuple(
            {"name": rec["name"], **(rec["config"] or {})}
            for rec in (
                read_part_config(folder / "music_backbone"),
                read_part_config(folder / "motion_backbone"),
            )
        )
        return cls(
            cfg=cfg,
            vae=vae,
            music_backbone=music_bb,
            motion_backbone=motion_bb,
            norms=MoMuNormalizers.load(folder),
            latent_music=Normalizer.load(folder / "latent_music_normalizer.json"),
            latent_motion=Normalizer.load(folder / "latent_motion_normalizer.json"),
            rates=Rates(**meta["rates"]),
            skeleton=str(meta.get("skeleton", "")),
            bone_lengths=np.asarray(meta.get("bone_lengths", []), dtype=np.float64),
            backbone_nodes=(nodes[0], nodes[1]),
        )


@METHODS.register("momu", config=MoMuConfig)
def build_momu(cfg: MoMuConfig, **deps: Any) -> MoMu:
    """Registry factory: the MoMu-Diffusion method (``fit`` it through a run context)."""
    return MoMu(cfg)
