"""HarmoGAN's two trainable stages as modules the shared engine trains (HarmoGAN §IV-C, §V-B).

The engine (:func:`momu.engine.train_stage`) owns one Adam optimiser over a module's parameters and
calls ``loss_fn(module, batch)``; each stage's ``forward`` returns ``(loss, logs)``.

* :class:`PretrainStage` — ``L_pretrain = 0.1 L_kl + L_mse`` on the generator alone (§V-B).
* :class:`AdversarialStage` — the generator with Eq. 20, ``λ_kl L_kl + λ_mse L_mse + λ_feat L_feat +
  λ_harmo L_harmo + λ_gan L_gan``, and both discriminators with Eq. 17–18, in ONE optimiser step whose
  gradients reach disjoint parameter sets: ``L_gan`` (Eq. 19, non-saturating) is evaluated through
  *detached copies* of the discriminators' parameters (it gives them no gradient) and the
  discriminator terms see detached generated motion (they give the generator none). Adam is
  per-parameter, so this is the alternating G/D update of a GAN step with both sides seeing the same
  pre-update networks. Weight decay is Adam's L2 form per network (``½ w ‖θ‖²``: 1e-4 for G, 1e-3 for
  the discriminators, §V-B).

Pose-domain losses (§IV-C):

* :func:`kl_loss` (Eq. 13) — ``KL(P(V_2d) ‖ P(V′_2d))`` of the sequence, with ``P`` a product over
  frames of the softmax of each frame's flattened 2D coordinates divided by ``τ`` (the paper leaves P
  undefined): the per-frame KLs summed over the frames, averaged over the batch;
* :func:`mse_loss` (Eq. 14) — ``‖V − G(A_f, V_f)‖₂``: the L2 norm of the difference of the whole
  sequence, as the equation is written (the text calls it the MSE loss component), averaged over the
  batch. As a norm it weighs against L_gan and L_harmo at the paper's λ_mse = λ_gan = 1e-3 the way
  Eq. 20 implies; a per-element mean would be ~10³ times smaller and leave the adversarial stage
  without a pose anchor (momu measured the generator's poses exploding in recurrent generation);
* :func:`feature_loss` (Eq. 15) — ``‖φ(V) − φ(V′)‖₂`` with a **stand-in for VGG**: ImageNet VGG on
  rendered poses cannot be loaded offline, so φ is kinematic (the per-frame velocities and
  accelerations of every joint). It is not VGG.
"""

from __future__ import annotations

from typing import Any

import torch
import torch.nn.functional as F
from torch import nn
from torch.func import functional_call

from momu.losses.gan import GANLoss
from momu.losses.harmony import HarmonyLoss
from momu.methods.harmogan.config import LossWeights

__all__ = ["kl_loss", "mse_loss", "feature_loss", "PretrainStage", "AdversarialStage", "stage_step"]


def kl_loss(pred_2d: torch.Tensor, true_2d: torch.Tensor, temperature: float) -> torch.Tensor:
    """HarmoGAN Eq. 13: ``KL(P(V_2d) ‖ P(V′_2d))`` of each sequence (frames' KLs summed), batch mean."""
    b, t = true_2d.shape[:2]
    p_log = F.log_softmax(true_2d.reshape(b, t, -1) / temperature, dim=-1)
    q_log = F.log_softmax(pred_2d.reshape(b, t, -1) / temperature, dim=-1)
    return (p_log.exp() * (p_log - q_log)).sum((-2, -1)).mean()


def _norm(x: torch.Tensor) -> torch.Tensor:
    """Per-item L2 norm over every axis but the batch (ε inside the root: a finite gradient at 0)."""
    return (x.reshape(x.shape[0], -1).pow(2).sum(-1) + 1e-12).sqrt()


def mse_loss(pred: torch.Tensor, true: torch.Tensor) -> torch.Tensor:
    """HarmoGAN Eq. 14 as written: ``‖V − G(A_f, V_f)‖₂`` per sequence, averaged over the batch."""
    return _norm(pred - true).mean()


def _kinematics(motion: torch.Tensor) -> torch.Tensor:
    velocity = motion[:, 1:] - motion[:, :-1]
    acceleration = velocity[:, 1:] - velocity[:, :-1]
    return torch.cat([velocity[:, 1:], acceleration], dim=-1)


def feature_loss(pred: torch.Tensor, true: torch.Tensor) -> torch.Tensor:
    """HarmoGAN Eq. 15 with a kinematic stand-in for VGG: ``‖φ(V) − φ(V′)‖₂`` per sequence, batch mean,
    φ = per-joint velocities and accelerations."""
    return _norm(_kinematics(pred) - _kinematics(true)).mean()


def _l2(module: nn.Module) -> torch.Tensor:
    return torch.stack([p.pow(2).sum() for p in module.parameters()]).sum()


def stage_step(model: nn.Module, batch: Any) -> tuple[torch.Tensor, dict[str, float]]:
    """The engine's ``loss_fn`` for both stages: the stage module computes its own loss."""
    loss, logs = model(batch)
    return loss, logs


class PretrainStage(nn.Module):
    """§V-B pretraining of G: ``kl · L_kl + mse · L_mse`` (0.1 and 1)."""

    def __init__(self, generator: nn.Module, weights: LossWeights, kl_temperature: float) -> None:
        super().__init__()
        self.generator = generator
        self.weights = weights
        self.kl_temperature = kl_temperature

    def forward(self, batch: dict[str, torch.Tensor]) -> tuple[torch.Tensor, dict[str, float]]:
        out = self.generator(batch["mfcc"], batch["initial_poses"], batch["transition"])
        kl = kl_loss(out.pose_2d, batch["pose_2d"], self.kl_temperature)
        mse = mse_loss(out.motion, batch["motion"])
        loss = self.weights.kl * kl + self.weights.mse * mse
        return loss, {"kl": float(kl.detach()), "mse": float(mse.detach())}


class AdversarialStage(nn.Module):
    """§IV-C / §V-B adversarial training; see the module docstring."""

    def __init__(
        self,
        generator: nn.Module,
        cross_modal: nn.Module,
        spatiotemporal: nn.Module,
        *,
        gan_loss: GANLoss,
        harmony_loss: HarmonyLoss,
        weights: LossWeights,
        kl_temperature: float,
        fps: float,
        generator_weight_decay: float,
        discriminator_weight_decay: float,
    ) -> None:
        super().__init__()
        self.generator = generator
        self.cross_modal = cross_modal
        self.spatiotemporal = spatiotemporal
        self.gan_loss = gan_loss
        self.harmony_loss = harmony_loss
        self.weights = weights
        self.kl_temperature = kl_temperature
        self.fps = fps
        self.wd_g = generator_weight_decay
        self.wd_d = discriminator_weight_decay

    @staticmethod
    def _frozen(module: nn.Module) -> dict[str, torch.Tensor]:
        state = {k: v.detach() for k, v in module.named_parameters()}
        state.update(dict(module.named_buffers()))
        return state

    def forward(self, batch: dict[str, torch.Tensor]) -> tuple[torch.Tensor, dict[str, float]]:
        w = self.weights
        mfcc, real = batch["mfcc"], batch["motion"]
        out = self.generator(mfcc, batch["initial_poses"], batch["transition"])
        fake = out.motion
        terms = {
            "kl": kl_loss(out.pose_2d, batch["pose_2d"], self.kl_temperature),
            "mse": mse_loss(fake, real),
            "feat": feature_loss(fake, real),
        }
        if w.harmo > 0:
            terms["harmo"] = self.harmony_loss(
                fake, self.fps, batch["audio_times"], batch["audio_saliency"], batch["audio_mask"]
            )
        cd_fake = functional_call(self.cross_modal, self._frozen(self.cross_modal), (mfcc, fake))
        st_fake = functional_call(self.spatiotemporal, self._frozen(self.spatiotemporal), (fake,))
        terms["gan"] = self.gan_loss.generator_loss(cd_fake) + self.gan_loss.generator_loss(st_fake)  # Eq. 19
        generator_loss = sum(getattr(w, k) * v for k, v in terms.items())
        detached = fake.detach()
        d_cd = self.gan_loss.discriminator_loss(
            self.cross_modal(mfcc, real), self.cross_modal(mfcc, detached)
        )
        d_st = self.gan_loss.discriminator_loss(self.spatiotemporal(real), self.spatiotemporal(detached))
        decay = 0.5 * self.wd_g * _l2(self.generator) + 0.5 * self.wd_d * (
            _l2(self.cross_modal) + _l2(self.spatiotemporal)
        )
        loss = generator_loss + d_cd + d_st + decay
        logs = {k: float(v.detach()) for k, v in terms.items()}
        logs.update(
            generator=float(generator_loss.detach()), d_cd=float(d_cd.detach()), d_st=float(d_st.detach())
        )
        return loss, logs
