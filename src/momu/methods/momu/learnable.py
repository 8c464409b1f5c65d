"""MoMu-Diffusion motion→music with a learnable motion encoder (MoMu §5.1, Tables 3–4).

On Floor Exercise and Figure Skating the paper does not use the motion VAE: "since the quality of
the Floor Exercise and the Figure Skating datasets are poor, we only conduct motion-to-music
generation on them with a learnable motion encoder, whose architecture is derived from [51]"
(MotionBERT). This module is that variant, built from the same parts as the ``momu`` method:

1. **Stage 1 — music VAE** (App. A.2, Eq. 10): exactly the ``momu`` method's stage 1
   (:class:`~momu.methods.momu.stages.MusicVAEStage`, the same stage key, so a run that also
   trains the full method reuses it).
2. **Learnable motion→music diffusion** (:class:`LearnableMotionStage`): θ_a (the
   ``music_backbone``) on the standardised music latents ``z_a`` (Eq. 6), conditioned on
   ``learnable_motion(m)`` — the registered DSTformer encoder, its inputs standardised with the
   training motion's per-feature statistics — trained end to end with the ε-prediction loss and
   condition dropout (Eq. 7's null embedding). The motion is aligned to
   ``k`` frames per latent frame (§3.2's even frame dropping; ``frames_per_latent``, default 1)
   and the encoder pools ``k`` frames into one, so its output has one condition frame per latent
   frame; its width is the latent width ``d``.

Generation (:class:`LearnableMotionToMusic`) samples with the method's motion→music sampler
(``music_sampler``, else ``sampler``; CFG, Eq. 7),
decodes the mel with the stage-1 VAE and vocodes it with the method's ``vocoder``.

Shapes: motion ``(T, J, D)`` at the clip's fps → aligned to ``n_z · k`` frames
(``n_z`` latent frames of the clip's duration, ``k`` = ``frames_per_latent``) →
condition ``(n_z, d)``; music latent ``(n_z, d)`` at ``rates.latent_rate`` (31.25 Hz at MoMu's
settings) → waveform at ``rates.sample_rate`` (16 kHz).
"""

from __future__ import annotations

import dataclasses
import logging
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import torch
from torch import nn
from torch.utils.data import Dataset

from momu.config import build_component, instantiate_config, to_container
from momu.encoders.bicor_vae import BiCoRVAE, align_frames
from momu.encoders.learnable_motion import LearnableMotionEncoder
from momu.engine.context import RunContext, stage_key_hash
from momu.engine.trainer import TrainConfig
from momu.features.preprocess import Normalizer
from momu.losses.diffusion import DiffusionLoss
from momu.methods.momu.config import vocoder_node
from momu.methods.momu.data import MoMuNormalizers, Rates, WindowDataset, select_split
from momu.methods.momu.method import MoMu
from momu.methods.momu.model import sample_items
from momu.methods.momu.stages import stage_step, train_music_vae_stage
from momu.registry import registry_for

__all__ = [
    "learnable_encoder_node",
    "LearnableMotionStage",
    "MotionLatentDataset",
    "LearnableMotionToMusic",
    "fit_learnable_motion_to_music",
]

log = logging.getLogger(__name__)


def learnable_encoder_node(
    node: Any, *, num_joints: int, joint_dims: int, latent_channels: int, downsample: int
) -> dict[str, Any]:
    """The ``learnable_motion`` node with its data-derived fields set.

    ``num_joints``/``dim_in`` come from the data, ``out_channels`` is the latent width ``d`` (the
    backbone's ``cond_channels``) and ``downsample`` the motion frames per latent frame.
    """
    plain = dict(to_container(node) if not isinstance(node, dict) else node)
    if plain.get("name") != "learnable_motion":
        raise ValueError(
            f"learnable_encoder: expected the 'learnable_motion' encoder, got {plain.get('name')!r}"
        )
    plain.update(
        num_joints=int(num_joints),
        dim_in=int(joint_dims),
        out_channels=int(latent_channels),
        downsample=int(downsample),
    )
    return plain


class LearnableMotionStage(nn.Module):
    """θ_a conditioned on the learnable motion encoder, trained end to end (MoMu §5.1, Eq. 6).

    Batch: ``{"z_music": (B, n_z, d) raw music latents, "motion": (B, n_z·k, J, D) normalised
    aligned motion}``. The per-channel music-latent statistics are buffers (saved with the weights).
    """

    def __init__(
        self, encoder: LearnableMotionEncoder, backbone: nn.Module, loss: DiffusionLoss, latent: int
    ) -> None:
        super().__init__()
        self.encoder = encoder
        self.backbone = backbone
        self.loss = loss
        self.music_mean: torch.Tensor
        self.music_std: torch.Tensor
        self.register_buffer("music_mean", torch.zeros(latent))
        self.register_buffer("music_std", torch.ones(latent))

    def set_statistics(self, z_music: torch.Tensor) -> None:
        """Per-channel mean/std of ``(N, T, d)`` raw music latents."""
        flat = z_music.reshape(-1, z_music.shape[-1]).double()
        self.music_mean.copy_(flat.mean(0).float())
        self.music_std.copy_(flat.std(0).clamp_min(1e-4).float())

    def condition(self, motion: torch.Tensor, mask: torch.Tensor | None = None) -> torch.Tensor:
        """``(B, n_z·k, J, D)`` motion → ``(B, n_z, d)`` condition."""
        return self.encoder(motion, mask)

    def forward(self, batch: dict[str, torch.Tensor]) -> tuple[torch.Tensor, dict[str, float]]:
        z_a = (batch["z_music"] - self.music_mean) / self.music_std
        cond = self.condition(batch["motion"])
        out = self.loss(self.backbone, z_a, cond)
        return out.loss, {"motion2music": float(out.loss.detach())}


class MotionLatentDataset(Dataset[dict[str, torch.Tensor]]):
    """Training pairs: raw music latents ``(n_z, d)`` and the window's aligned motion ``(n_z·k, J, D)``."""

    def __init__(self, z_music: torch.Tensor, motion: torch.Tensor) -> None:
        if z_music.shape[0] != motion.shape[0]:
            raise ValueError(f"{z_music.shape[0]} music latents but {motion.shape[0]} motion windows")
        self.z_music, self.motion = z_music, motion

    def __len__(self) -> int:
        return int(self.z_music.shape[0])

    def __getitem__(self, index: int) -> dict[str, torch.Tensor]:
        return {"z_music": self.z_music[index], "motion": self.motion[index]}


@torch.no_grad()
def _encode_music_windows(vae: BiCoRVAE, data: WindowDataset, batch_size: int = 32) -> torch.Tensor:
    key = "wave" if vae.music_input == "waveform" else "mel"
    vae = vae.eval()
    out = []
    for start in range(0, len(data), batch_size):
        music = torch.stack([it[key] for it in data.items[start : start + batch_size]])
        out.append(vae.encode_music(music).mode().cpu())
    return torch.cat(out)


@dataclasses.dataclass
class LearnableMotionToMusic:
    """A trained motion→music model with the learnable motion encoder (see the module docstring)."""

    vae: BiCoRVAE
    stage: LearnableMotionStage
    norms: MoMuNormalizers
    rates: Rates
    sampler: Any
    vocoder: Any
    frames_per_latent: int = 1

    def __post_init__(self) -> None:
        self.vae.eval()
        self.stage.eval()
        self.latent = Normalizer(self.stage.music_mean.numpy(), self.stage.music_std.numpy())

    @torch.no_grad()
    def condition(self, motion: np.ndarray, fps: float) -> torch.Tensor:
        """Condition ``(n_z, d)`` of a motion ``(T, J, D)`` at ``fps`` (n_z latent frames of its length)."""
        m = np.asarray(motion, dtype=np.float32)
        if m.ndim != 3:
            raise ValueError(f"motion must be (T, J, D), got shape {m.shape}")
        n = self.rates.latent_frames(m.shape[0] / float(fps))
        x = torch.from_numpy(self.norms.motion.transform(m))
        x = align_frames(x, n * self.frames_per_latent, dim=0)
        return self.stage.condition(x[None].float())[0]

    @torch.no_grad()
    def decode_music(self, z: torch.Tensor) -> np.ndarray:
        """Standardised latent ``(n_z, d)`` → waveform at ``rates.sample_rate`` (mel decoded, vocoded)."""
        raw = self.latent.inverse(z.float())[None]
        mel = self.vae.decode_music(raw)[0].cpu().numpy()
        if self.rates.music_input == "waveform":
            return np.clip(mel, -1.0, 1.0).astype(np.float32)
        return np.asarray(self.vocoder.synthesize(self.norms.mel_inverse(mel)), dtype=np.float32)

    @torch.no_grad()
    def motion_to_music(
        self,
        motions: Sequence[np.ndarray],
        fps: Sequence[float],
        seeds: Sequence[int],
        *,
        guidance_scale: float | None = None,
    ) -> list[np.ndarray]:
        """One waveform per motion (CFG, MoMu Eq. 7); an item's noise depends only on its seed."""
        if not len(motions) == len(fps) == len(seeds):
            raise ValueError(
                f"motion_to_music: {len(motions)} motions, {len(fps)} frame rates, {len(seeds)} seeds"
            )
        conds = [self.condition(m, f) for m, f in zip(motions, fps)]
        zs = sample_items(
            self.sampler, self.stage.backbone, conds, seeds, int(self.vae.latent_channels), guidance_scale
        )
        return [self.decode_music(z) for z in zs]


def fit_learnable_motion_to_music(
    ctx: RunContext,
    method: MoMu,
    encoder_node: Any,
    train: TrainConfig,
    dataset: Any,
    data_key: Mapping[str, Any],
    seed: int,
    *,
    frames_per_latent: int = 1,
) -> LearnableMotionToMusic:
    """Train (or reuse) stage 1 and the learnable motion→music stage on the ``train`` split.

    Args:
        ctx: the run context (stages cached under ``ctx.parts_dir``).
        method: the ``momu`` method (its music VAE, discriminator, losses, ``music_backbone``,
            scheduler, diffusion loss, sampler and vocoder are used; its motion VAE is not).
        encoder_node: the ``learnable_motion`` node (data-derived fields are filled in).
        train: engine settings of the learnable stage.
        dataset: the clips (``Clip.meta["split"]``).
        data_key: the dataset config (part of every stage key).
        seed: seeds the weights and the training.
        frames_per_latent: motion frames the encoder sees per latent frame (1: the motion at the
            latent rate, 31.25 fps at MoMu's settings; attention cost grows with its square).
    """
    if frames_per_latent < 1:
        raise ValueError(f"learnable_frames_per_latent must be >= 1, got {frames_per_latent}")
    c = method.cfg
    train_idx = select_split(dataset, "train")
    if not train_idx:
        raise ValueError("the dataset has no 'train' clips with motion and audio")
    clips = [dataset[i] for i in train_idx]
    norms = MoMuNormalizers.fit(clips, c.sample_rate)
    keys = method.stage_keys(data_key, seed)
    cache: dict[str, Any] = {}

    def build_vae() -> Any:
        cache["vae"] = method.build_encoder()
        return cache["vae"]

    def windows() -> WindowDataset:
        if "w" not in cache:
            vae = cache["vae"]
            cache["w"] = WindowDataset(
                clips, norms, method.rates(vae), c.window_seconds, c.window_hop_seconds,
                need_mel=vae.music_input == "mel", need_wave=vae.music_input == "waveform",
            )  # fmt: skip
        data: WindowDataset = cache["w"]
        return data

    # Stage 1 (Eq. 10): the momu method's music VAE stage, same key (and the same seeded builder).
    vae = train_music_vae_stage(ctx, build_vae, c, keys["music_vae"], windows, seed)
    rates = method.rates(vae)
    vae = vae.to("cpu").eval()
    vae.freeze_music(True)

    # The learnable motion encoder + θ_a, trained end to end (Eq. 6 with the encoder's condition).
    sample = clips[0].motion
    assert sample is not None
    enc_node = learnable_encoder_node(
        encoder_node,
        num_joints=sample.shape[1],
        joint_dims=sample.shape[2],
        latent_channels=vae.latent_channels,
        downsample=frames_per_latent,
    )
    music_node, _ = method.backbone_nodes(vae.latent_channels)
    enc_params = {k: v for k, v in enc_node.items() if k != "name"}
    enc_cfg = instantiate_config(registry_for("encoders").get(enc_node["name"]), enc_params)
    key = {
        "stage": "learnable_motion2music",
        "after": stage_key_hash(keys["music_vae"]),
        "data": keys["music_vae"]["data"],
        "encoder": {"name": enc_node["name"], **dataclasses.asdict(enc_cfg)},  # every field, defaults too
        "music_backbone": music_node,
        "scheduler": to_container(c.scheduler),
        "diffusion_loss": to_container(c.diffusion_loss),
        "train": dataclasses.asdict(train),
        "seed": seed,
    }

    def build() -> LearnableMotionStage:  # under the stage's own seed (RunContext.stage)
        encoder = build_component(enc_node, "encoders")
        if not isinstance(encoder, LearnableMotionEncoder):
            raise ValueError(
                f"learnable_encoder: built a {type(encoder).__name__}, expected LearnableMotionEncoder"
            )
        scheduler = build_component(c.scheduler, "schedulers")
        loss = build_component(c.diffusion_loss, "losses", scheduler=scheduler)
        cache["stage"] = LearnableMotionStage(
            encoder, build_component(music_node, "backbones"), loss, vae.latent_channels
        )
        return cache["stage"]

    def pairs() -> MotionLatentDataset:
        data = windows()
        stage = cache["stage"]
        z_music = _encode_music_windows(vae, data)
        stage.set_statistics(z_music)
        motion = torch.stack([it["motion"] for it in data.items])  # (N, n_z · rates' k, J, D)
        motion = align_frames(motion, z_music.shape[1] * frames_per_latent, dim=1)
        stage.encoder.set_statistics(motion)  # the encoder's input standardisation (``standardize``)
        log.info("learnable motion→music: %d windows of %.2f s", len(data), data.window_seconds)
        return MotionLatentDataset(z_music, motion)

    trained = ctx.stage(
        "learnable_motion2music", key, build, pairs, stage_step, dataclasses.replace(train, seed=seed)
    )
    assert isinstance(trained, LearnableMotionStage)
    return LearnableMotionToMusic(
        vae=vae,
        stage=trained.to("cpu").eval(),
        norms=norms,
        rates=rates,
        sampler=build_component(c.sampler_node("music"), "samplers"),  # motion→music, like θ_a
        vocoder=build_component(vocoder_node(c.vocoder), "vocoders"),
        frames_per_latent=frames_per_latent,
    )
