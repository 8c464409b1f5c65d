"""``momu``: the MoMu-Diffusion method (MoMu §3–4, App. A–B) assembled from registered parts.

Training (:meth:`MoMu.fit`, every stage through :meth:`momu.engine.context.RunContext.stage`):

1. **Stage 1 — music VAE** (App. A.2, Eq. 10): ``L_recon + λ1 L_KL + λ2 L_GAN`` with the mel
   discriminator (λ1 = 1e-5 in ``vae_loss``, λ2 = 0.5 in ``gan_loss``).
2. **Stage 2 — motion VAE** (Eq. 11): ``L_recon + λ3 L_KL + λ4 L_contrast`` with the music VAE
   frozen (λ3 = 1e-5, λ4 = 1 in ``contrastive_loss``; ``contrastive_loss: null`` is Table 7 #3).
3. **Diffusion** (Eq. 6): θ_a (motion→music) and θ_m (music→motion) on the aligned latents,
   ε-prediction with condition dropout for classifier-free guidance; with ``diffusion_losses``, θ_m
   also gets other methods' pose losses on its decoded x̂₀ (:mod:`.decoded_losses`).

Stage keys hold everything that determines a stage's weights — its part configs, its training
config, the dataset config and window, the seed, and the keys of the stages it builds on — so
rows of a table that share a stage train it once (Table 7 #1 and #3 reuse stage 1; #5–#7 share
everything and differ only in how they sample). Each stage builds its modules under its own seed,
``(seed, stage name)`` (:meth:`momu.engine.context.RunContext.stage`): the BiCoR-VAE — both VAEs —
is drawn by stage 1's builder, the contrastive heads by stage 2's, the two denoisers by the
diffusion stage's, so no stage's weights depend on whether an earlier one was trained or loaded.

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
from collections.abc import Mapping
from typing import Any

import numpy as np
import torch

from momu.config import build_component
from momu.encoders.bicor_vae import BiCoRVAE
from momu.engine.context import RunContext, stage_key_hash
from momu.features.bones import mean_bone_lengths
from momu.features.preprocess import Normalizer
from momu.features.skeletons import get_skeleton
from momu.methods.momu.conditions import Conditions
from momu.methods.momu.config import MoMuConfig, _plain, backbone_node, check_config
from momu.methods.momu.data import MoMuNormalizers, Rates, WindowDataset, select_split
from momu.methods.momu.decoded_losses import BEAT_KEYS, DecodedLosses, build_decoded_losses, loss_nodes
from momu.methods.momu.model import MoMuModel
from momu.methods.momu.stages import DiffusionStage, MotionVAEStage, stage_step, train_music_vae_stage
from momu.registry import METHODS

__all__ = ["MoMu", "LatentDataset", "encode_windows", "build_momu"]

log = logging.getLogger(__name__)


class MoMu:
    """The registered ``momu`` method: builds the parts and trains them through a run context."""

    def __init__(self, cfg: MoMuConfig) -> None:
        check_config(cfg)
        self.cfg = cfg

    # ---------------------------------------------------------------- parts
    def for_dataset(self, dataset: Any) -> MoMu:
        """This method with the BiCoR-VAE's ``num_joints`` / ``joint_dims`` taken from the data.

        The config's values describe the synthetic default skeleton; a real dataset (Dance with
        Melody's 21 3D joints, LORIS's COCO-17 keypoints, ...) brings its own, so the first training
        clip decides and the change is logged. Stage keys are computed from the effective node, so a
        cached stage is never reused across skeletons.
        """
        train = select_split(dataset, "train")
        if not train:
            raise ValueError("the dataset has no 'train' clips with motion and audio")
        motion = dataset[train[0]].motion
        if self.cfg.diffusion_losses:  # a pose loss that cannot take this skeleton fails before training
            build_decoded_losses(loss_nodes(self.cfg, str(dataset[train[0]].skeleton or "")))
        enc = dict(_plain(self.cfg.encoder))
        shape = {"num_joints": int(motion.shape[1]), "joint_dims": int(motion.shape[2])}
        changed = {k: v for k, v in shape.items() if k in enc and enc[k] != v}
        if not changed:
            return self
        for key, value in changed.items():
            log.info("method.encoder.%s: %d from the dataset (config: %s)", key, value, enc[key])
        return MoMu(dataclasses.replace(self.cfg, encoder={**enc, **changed}))

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

    def backbone_nodes(
        self, latent_channels: int, conditions: Conditions | None = None
    ) -> tuple[dict[str, Any], dict[str, Any]]:
        """θ_a's and θ_m's nodes, their condition widths from ``conditions`` (default: the latent width)."""
        widths: tuple[int | None, int | None] = (None, None)
        if conditions is not None:
            widths = (
                conditions.cond_width("music", latent_channels),
                conditions.cond_width("motion", latent_channels),
            )
        return (
            backbone_node(self.cfg.music_backbone, latent_channels, widths[0]),
            backbone_node(self.cfg.motion_backbone, latent_channels, widths[1]),
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
            **(
                {"motion_representation": c.motion_representation}
                if c.motion_representation != "positions"
                else {}
            ),
        }
        conditions = {
            key: value
            for key, value in (
                ("motion_condition", _plain(c.motion_condition)),
                ("music_condition", _plain(c.music_condition)),
                ("condition_latents", c.condition_latents),
            )
            if value is not None and value is not True
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
            **conditions,
            **({"train_min_seconds": c.train_min_seconds} if c.train_min_seconds is not None else {}),
            **({"train_lengths": c.train_lengths} if c.train_lengths != "item" else {}),
            **(
                {
                    "diffusion_losses": [_plain(n) for n in c.diffusion_losses],
                    "diffusion_loss_weights": list(c.diffusion_loss_weights),
                }
                if c.diffusion_losses
                else {}
            ),
            "train": dataclasses.asdict(c.train_diffusion),
            "seed": seed,
        }
        return {"music_vae": k1, "motion_vae": k2, "diffusion": k3}

    # ---------------------------------------------------------------- training
    def fit(self, ctx: RunContext, dataset: Any, data_key: Mapping[str, Any], seed: int) -> MoMuModel:
        """Train (or reuse) the three stages on the dataset's ``train`` split; returns the model."""
        c = self.cfg

        def clips_and_norms() -> tuple[list[Any], MoMuNormalizers]:
            train_idx = select_split(dataset, "train")
            if not train_idx:
                raise ValueError("the dataset has no 'train' clips with motion and audio")
            clips = [dataset[i] for i in train_idx]
            conds = Conditions.of(c, str(clips[0].skeleton or ""))
            motion_of = None if conds.representation == "positions" else conds.clip_motion
            return clips, MoMuNormalizers.fit(clips, c.sample_rate, motion_of)

        # every row and seed of a table trains on the same clips: built once per process
        train_clips, norms = ctx.remember(
            ("momu train clips", data_key, c.sample_rate, c.motion_representation), clips_and_norms
        )
        skeleton = str(train_clips[0].skeleton or "")
        conditions = Conditions.of(c, skeleton)
        decoded_nodes = loss_nodes(c, skeleton)
        music_beats = bool(decoded_nodes) and any(
            getattr(p, "needs_music_beats", False) for p in build_decoded_losses(decoded_nodes)
        )
        plain = not conditions.any_features and conditions.representation == "positions" and not music_beats
        keys = self.stage_keys(data_key, seed)
        # Each stage builds its modules under its own seed (RunContext.stage): the initial weights
        # never depend on whether an earlier stage was trained in this process or loaded.
        built: dict[str, Any] = {}

        def build_vae() -> BiCoRVAE:
            built["vae"] = self.build_encoder()
            return built["vae"]

        def windows() -> WindowDataset:
            if "windows" not in built:
                vae = built["vae"]
                built["windows"] = WindowDataset(
                    train_clips,
                    norms,
                    self.rates(vae),
                    c.window_seconds,
                    c.window_hop_seconds,
                    need_mel=vae.music_input == "mel",
                    need_wave=vae.music_input == "waveform",
                    conditions=None if plain else conditions,
                    music_beats=music_beats,
                )
                stretched = sum(1 for clip in train_clips if "tempo_factor" in clip.meta)
                log.info(
                    "momu: %d training windows of %.2f s from %d clips%s",
                    len(built["windows"]),
                    built["windows"].window_seconds,
                    len(train_clips),
                    f" ({stretched} of them time-stretched copies, tempo_factors)" if stretched else "",
                )
            data: WindowDataset = built["windows"]
            return data

        # Stage 1: music VAE (+ GAN), Eq. 10.
        vae: BiCoRVAE = train_music_vae_stage(ctx, build_vae, c, keys["music_vae"], windows, seed)
        rates = self.rates(vae)

        # Stage 2: motion VAE + rhythmic contrastive loss, music VAE frozen, Eq. 11.
        def build_stage2() -> MotionVAEStage:
            vae.freeze_music(True)
            contrastive = (
                build_component(c.contrastive_loss, "losses") if c.contrastive_loss is not None else None
            )
            return MotionVAEStage(vae, build_component(c.vae_loss, "losses"), contrastive)

        def stage2_data() -> WindowDataset:
            data = windows()
            fit_lengths = getattr(vae.motion_vae, "fit_bone_lengths", None)
            if callable(fit_lengths):  # directional vectors decode with the data's mean bone lengths
                fit_lengths(torch.stack([item["motion"] for item in data.items]))
            return data

        ctx.stage(
            "motion_vae",
            keys["motion_vae"],
            build_stage2,
            stage2_data,
            stage_step,
            dataclasses.replace(c.train_motion_vae, seed=seed),
        )
        vae = vae.to("cpu").eval()

        # Diffusion: θ_a and θ_m on the aligned latents, Eq. 6.
        music_node, motion_node = self.backbone_nodes(vae.latent_channels, conditions)
        min_frames = None if c.train_min_seconds is None else rates.latent_frames(c.train_min_seconds)

        def build_diffusion() -> DiffusionStage:
            scheduler = build_component(c.scheduler, "schedulers")
            decoded = None
            if decoded_nodes:
                weights = list(c.diffusion_loss_weights) or [1.0] * len(decoded_nodes)
                decoded = DecodedLosses(
                    build_decoded_losses(decoded_nodes, scheduler),
                    weights,
                    vae.motion_vae,
                    norms.motion.mean,
                    norms.motion.std,
                    skeleton,
                    rates.motion_fps,
                )
            built["diffusion"] = DiffusionStage(
                build_component(music_node, "backbones"),
                build_component(motion_node, "backbones"),
                build_component(c.diffusion_loss, "losses", scheduler=scheduler),
                vae.latent_channels,
                min_frames,
                per_batch=c.train_lengths == "batch",
                condition_latents=c.condition_latents,
                decoded=decoded,
            )
            return built["diffusion"]

        def latent_data() -> LatentDataset:
            data = windows()
            z_music, z_motion = encode_windows(vae, data)
            built["diffusion"].set_statistics(z_music, z_motion)
            features: dict[str, torch.Tensor] = {
                key: torch.stack([item[key] for item in data.items])
                for key in ("f_music", "f_motion", *BEAT_KEYS)
                if key in data.items[0]
            }
            return LatentDataset(z_music, z_motion, features)

        diffusion = ctx.stage(
            "diffusion",
            keys["diffusion"],
            build_diffusion,
            latent_data,
            stage_step,
            dataclasses.replace(c.train_diffusion, seed=seed),
        )
        assert isinstance(diffusion, DiffusionStage)
        diffusion = diffusion.to("cpu").eval()
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
    """Paired raw latents ``(T_z, d)`` of the training windows, with their condition features
    (``f_music``, ``f_motion``: ``(N, T_z, C)``) when the model has any."""

    def __init__(
        self,
        z_music: torch.Tensor,
        z_motion: torch.Tensor,
        features: Mapping[str, torch.Tensor] | None = None,
    ) -> None:
        self.z_music, self.z_motion = z_music, z_motion
        self.features = dict(features or {})

    def __len__(self) -> int:
        return int(self.z_music.shape[0])

    def __getitem__(self, index: int) -> dict[str, torch.Tensor]:
        item = {"z_music": self.z_music[index], "z_motion": self.z_motion[index]}
        item.update({key: value[index] for key, value in self.features.items()})
        return item


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


@METHODS.register("momu", config=MoMuConfig)
def build_momu(cfg: MoMuConfig, **deps: Any) -> MoMu:
    """Registry factory: the MoMu-Diffusion method (``fit`` it through a run context)."""
    return MoMu(cfg)
