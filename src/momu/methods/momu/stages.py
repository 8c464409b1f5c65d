"""The three trainable stages of MoMu-Diffusion as modules the shared engine trains.

The engine (:func:`momu.engine.train_stage`) owns one AdamW optimiser over a module's trainable
parameters and calls ``loss_fn(module, batch)``; each stage below is that module, its ``forward``
returning ``(loss, logs)``.

* :class:`MusicVAEStage` — stage 1 (MoMu App. A.2, Eq. 10): the music VAE with
  ``L_recon + λ1 L_KL + λ2 L_GAN`` and the mel discriminator. App. A.2's two-step update (VAE step,
  then discriminator step; :func:`momu.losses.gan.two_step_update`) is performed as ONE optimiser
  step over the sum ``L_stage1 + L_D`` whose gradients reach disjoint parameter sets: the generator
  term is evaluated through a *detached copy* of the discriminator's parameters (so it gives the
  discriminator no gradient) and ``L_D`` sees detached reconstructions (so it gives the VAE no
  gradient). Because AdamW is per-parameter and ``L_D`` in the two-step form also uses the
  reconstructions of the pre-update VAE, this is the same update as the two-step form, except
  that gradient-norm clipping (``max_grad_norm``) is applied to the union of both gradients.
  The waveform branch (Table 7 #2) has no mel to discriminate and trains with ``L_recon + λ1 L_KL``.
* :class:`MotionVAEStage` — stage 2 (Eq. 11): the motion VAE with ``L_recon + λ3 L_KL + λ4 L_contrast``
  (:func:`momu.encoders.bicor_vae.stage2_loss`), the music VAE frozen; without a contrastive loss
  (Table 7 #3, "w/o RCL") only ``L_recon + λ3 L_KL``.
* :class:`DiffusionStage` — the two cross-modal denoisers θ_a (motion→music) and θ_m
  (music→motion) trained together on the aligned, standardised latents with the ε-prediction loss
  and condition dropout (Eq. 6), optionally on masked windows of varying length (MoMu §5.3's
  pad-and-truncate, so variable-length generation samples lengths seen in training); the
  per-channel latent statistics are buffers, so they are saved and reloaded with the weights.
  With ``method.diffusion_losses`` θ_m's loss also gets other methods' pose losses on its decoded
  clean estimate (:mod:`momu.methods.momu.decoded_losses`).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from typing import Any

import numpy as np
import torch
from torch import nn
from torch.func import functional_call

from momu.encoders.bicor_vae import BiCoRVAE, stage2_loss
from momu.encoders.vae import SequenceVAE
from momu.engine.every_parameter import with_every_parameter
from momu.losses.diffusion import DiffusionLoss

__all__ = ["MusicVAEStage", "MotionVAEStage", "DiffusionStage", "stage_step", "train_music_vae_stage"]


def stage_step(model: nn.Module, batch: Any) -> tuple[torch.Tensor, dict[str, float]]:
    """The engine's ``loss_fn`` for every MoMu stage: the stage module computes its own loss."""
    loss, logs = model(batch)
    return loss, logs


def _music_input(vae: SequenceVAE, batch: dict[str, torch.Tensor]) -> torch.Tensor:
    key = "wave" if vae.input_kind == "waveform" else "mel"
    if key not in batch:
        raise KeyError(f"batch has no {key!r} entry for a {vae.input_kind} music VAE")
    return batch[key]


class MusicVAEStage(nn.Module):
    """Stage 1: music VAE + optional mel discriminator (MoMu Eq. 10, λ1 = 1e-5, λ2 = 0.5)."""

    def __init__(
        self, vae: SequenceVAE, discriminator: nn.Module | None, vae_loss: nn.Module, gan_loss: Any
    ) -> None:
        super().__init__()
        self.vae = vae
        self.discriminator = discriminator
        self.vae_loss = vae_loss
        self.gan_loss = gan_loss
        self.step: torch.Tensor
        self.register_buffer("step", torch.zeros((), dtype=torch.long))

    def forward(self, batch: dict[str, torch.Tensor]) -> tuple[torch.Tensor, dict[str, float]]:
        x = _music_input(self.vae, batch)
        out = self.vae(x)
        terms = self.vae_loss(out.reconstruction, out.target, out.posterior)
        total = terms["loss"]
        logs = {"reconstruction": float(terms["reconstruction"].detach()), "kl": float(terms["kl"].detach())}
        step = int(self.step)
        if self.training:
            self.step += 1
        if self.discriminator is not None and self.gan_loss is not None and self.gan_loss.active(step):
            frozen = {k: v.detach() for k, v in self.discriminator.named_parameters()}
            frozen.update(dict(self.discriminator.named_buffers()))
            fake_logits = functional_call(self.discriminator, frozen, (out.reconstruction,))
            g_loss = self.gan_loss.generator_loss(fake_logits)
            weight = self.gan_loss.generator_weight(terms["reconstruction"], g_loss, self.vae.last_layer)
            d_loss = self.gan_loss.discriminator_loss(
                self.discriminator(out.target.detach()), self.discriminator(out.reconstruction.detach())
            )
            total = total + weight * g_loss + d_loss
            logs.update(
                generator=float(g_loss.detach()),
                generator_weight=float(weight.detach()),
                discriminator=float(d_loss.detach()),
            )
        return with_every_parameter(self, total), logs


class MotionVAEStage(nn.Module):
    """Stage 2: motion VAE with the music VAE frozen (MoMu Eq. 11, λ3 = 1e-5, λ4 = 1)."""

    def __init__(self, vae: BiCoRVAE, vae_loss: nn.Module, contrastive: nn.Module | None) -> None:
        super().__init__()
        vae.freeze_music(True)
        self.vae = vae
        self.vae_loss = vae_loss
        self.contrastive = contrastive

    def forward(self, batch: dict[str, torch.Tensor]) -> tuple[torch.Tensor, dict[str, float]]:
        music = _music_input(self.vae.music_vae, batch)
        motion = batch["motion"]
        if self.contrastive is not None:
            terms = stage2_loss(self.vae, motion, music, vae_loss=self.vae_loss, contrastive=self.contrastive)
            logs = {k: float(v.detach()) for k, v in terms.items() if k != "loss"}
            return with_every_parameter(self, terms["loss"]), logs
        with torch.no_grad():
            length = self.vae.encode_music(music).shape[1]
        out = self.vae.motion_vae(self.vae.align_motion(motion, length))
        terms = self.vae_loss(out.reconstruction, out.target, out.posterior, time_dim=1)  # (B, T, ...)
        return with_every_parameter(self, terms["loss"]), {
            "reconstruction": float(terms["reconstruction"].detach()),
            "kl": float(terms["kl"].detach()),
        }


class DiffusionStage(nn.Module):
    """θ_a and θ_m trained jointly on standardised aligned latents (MoMu Eq. 6)."""

    def __init__(
        self,
        music_backbone: nn.Module,
        motion_backbone: nn.Module,
        loss: DiffusionLoss,
        latent: int,
        min_frames: int | None = None,
        per_batch: bool = False,
        condition_latents: bool = True,
        decoded: nn.Module | None = None,
    ) -> None:
        super().__init__()
        self.music_backbone = music_backbone
        self.motion_backbone = motion_backbone
        self.loss = loss
        self.decoded = decoded
        self.min_frames = min_frames
        self.per_batch = per_batch
        self.condition_latents = condition_latents
        for name in ("music_mean", "motion_mean"):
            self.register_buffer(name, torch.zeros(latent))
        for name in ("music_std", "motion_std"):
            self.register_buffer(name, torch.ones(latent))

    def set_statistics(self, z_music: torch.Tensor, z_motion: torch.Tensor) -> None:
        """Per-channel mean/std of ``(N, T, d)`` raw latents (the diffusion models see standardised ones)."""
        for name, z in (("music", z_music), ("motion", z_motion)):
            flat = z.reshape(-1, z.shape[-1]).double()
            getattr(self, f"{name}_mean").copy_(flat.mean(0).float())
            getattr(self, f"{name}_std").copy_(flat.std(0).clamp_min(1e-4).float())

    def statistic(self, name: str) -> np.ndarray:
        """A latent statistic buffer (``music_mean``, ``music_std``, ``motion_mean``, ``motion_std``)."""
        value = getattr(self, name)
        assert isinstance(value, torch.Tensor)
        return np.asarray(value.detach().cpu().numpy())

    def standardise(self, z: torch.Tensor, modality: str) -> torch.Tensor:
        return (z - getattr(self, f"{modality}_mean")) / getattr(self, f"{modality}_std")

    def unstandardise(self, z: torch.Tensor, modality: str) -> torch.Tensor:
        """The inverse of :meth:`standardise`."""
        return z * getattr(self, f"{modality}_std") + getattr(self, f"{modality}_mean")

    def _train_min_frames(self) -> int | None:
        """The shortest training length, or ``None`` (evaluation, or fixed-length training)."""
        return self.min_frames if self.training else None

    def length_mask(self, batch: int, frames: int, device: torch.device) -> torch.Tensor | None:
        """Variable-length training (MoMu §5.3): item ``i`` keeps its first ``L_i`` latent frames,
        ``L_i`` uniform in ``[min_frames, frames]`` (drawn from the global RNG, which the engine
        seeds per process and checkpoints); ``None`` when training at the window length only or
        when lengths are drawn per batch (:meth:`batch_length`)."""
        shortest = self._train_min_frames()
        if shortest is None or self.per_batch or shortest >= frames:
            return None
        lengths = torch.randint(shortest, frames + 1, (batch,))
        return (torch.arange(frames)[None, :] < lengths[:, None]).to(device)

    def batch_length(self, frames: int) -> int:
        """Per-batch variable length: one ``L`` uniform in ``[min_frames, frames]`` for the whole
        batch (the same distribution per item as :meth:`length_mask`, without padding)."""
        shortest = self._train_min_frames()
        if shortest is None or not self.per_batch or shortest >= frames:
            return frames
        return int(torch.randint(shortest, frames + 1, ()))

    def condition(self, latent: torch.Tensor, features: torch.Tensor | None) -> torch.Tensor:
        """A denoiser's condition ``(B, T, C)``: the other latent, its features, or both (features last)."""
        if features is None:
            return latent
        features = features[:, : latent.shape[1]].to(latent)
        return torch.cat([latent, features], dim=-1) if self.condition_latents else features

    def forward(self, batch: dict[str, torch.Tensor]) -> tuple[torch.Tensor, dict[str, torch.Tensor]]:
        """``(L_a + L_m, logs)``; the logs are detached tensors (read back only at logging steps)."""
        length = self.batch_length(batch["z_music"].shape[1])
        z_a = self.standardise(batch["z_music"][:, :length], "music")
        z_m = self.standardise(batch["z_motion"][:, :length], "motion")
        mask = self.length_mask(z_a.shape[0], z_a.shape[1], z_a.device)  # aligned latents: one length
        loss_a = self.loss(
            self.music_backbone, z_a, self.condition(z_m, batch.get("f_motion")), x_mask=mask, cond_mask=mask
        ).loss  # θ_a: motion → music
        out_m = self.loss(
            self.motion_backbone, z_m, self.condition(z_a, batch.get("f_music")), x_mask=mask, cond_mask=mask
        )  # θ_m: music → motion
        loss_m = out_m.loss
        logs = {"motion2music": loss_a.detach(), "music2motion": loss_m.detach()}
        total = loss_a + loss_m
        if self.decoded is not None:  # other methods' pose losses on θ_m's decoded x̂₀
            beats = None
            if all(k in batch for k in ("beat_times", "beat_saliency", "beat_mask")):
                beats = (batch["beat_times"], batch["beat_saliency"], batch["beat_mask"].bool())
            extra, extra_logs = self.decoded(
                out_m.x0_pred,
                self.unstandardise(z_m, "motion"),
                self.unstandardise(out_m.x0_pred, "motion"),
                out_m.t,
                self.loss.scheduler.alphas_cumprod,
                mask,
                beats,
            )
            total = total + extra
            logs.update(extra_logs)
        return with_every_parameter(self, total), logs


def train_music_vae_stage(
    ctx: Any, build_vae: Callable[[], Any], c: Any, key: Any, windows: Any, seed: int
) -> Any:
    """Train (or reuse) stage 1, MoMu App. A.2 Eq. 10: the music VAE with the GAN term.

    Shared by the ``momu`` method and the Table 3–4 learnable-motion model, which use the same
    stage key so a run that trains both trains stage 1 once. ``build_vae`` builds the BiCoR-VAE
    (called once, under the stage's seed, so its initial weights — the motion VAE's too — are a
    function of the run seed alone); ``c`` is the method config (``discriminator_encoder``,
    ``gan_loss``, ``vae_loss``, ``train_music_vae``), ``windows`` the training-window dataset (or a
    callable building it, called after ``build_vae``), ``ctx`` the run's
    :class:`~momu.engine.context.RunContext`. Returns the BiCoR-VAE with its music VAE trained.
    """
    from momu.config import build_component

    built: dict[str, Any] = {}

    def build() -> MusicVAEStage:
        vae = built["vae"] = build_vae()
        disc = None
        if vae.music_input == "mel" and c.discriminator_encoder is not None:
            disc = build_component(c.discriminator_encoder, "encoders")
        gan = build_component(c.gan_loss, "losses") if c.gan_loss is not None else None
        return MusicVAEStage(vae.music_vae, disc, build_component(c.vae_loss, "losses"), gan)

    ctx.stage("music_vae", key, build, windows, stage_step, dataclasses.replace(c.train_music_vae, seed=seed))
    return built["vae"]
