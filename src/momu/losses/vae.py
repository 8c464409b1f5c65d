"""VAE loss: reconstruction + lambda * KL (MoMu App. A.2, Eq. 10-11; lambda1 = lambda3 = 1e-5).

``L = L_recon(x_hat, x) + kl_weight * KL(q(z|x) || N(0, I))``. The reconstruction term is L1 by
default (the latent-diffusion / Make-An-Audio autoencoder losses that MoMu's BiCoR-VAE follows use
an L1 pixel term) or MSE.

Reductions (``reduction``):

* ``"mean"`` (default): reconstruction averaged over every element, KL averaged over every latent
  element. Term magnitudes do not grow with sequence length, which keeps MoMu's fixed weights
  (lambda4 = 1 for the contrastive term, Eq. 11) meaningful on sequences of any length.
* ``"sum"``: both summed over an item's elements and averaged over the batch (the latent-diffusion
  autoencoder convention).

Velocity term (``velocity_weight``, momu's option, 0 in the paper preset): the same error on first
differences along the time axis, for branches whose caller names that axis (the motion VAE, stage 2).
Position errors barely grow when a decoder smooths a sharp start of a movement over a few frames,
but that smoothing erases the kinematic beats (MoMu Eq. 2 fires on sudden changes of velocity);
the velocity error does grow. (MoFusion's kinematic losses, §3.2, constrain bone lengths and
x̂₀, not velocities.)
"""

from __future__ import annotations

from dataclasses import dataclass

import torch
from torch import nn

from momu.encoders.vae import DiagonalGaussian
from momu.registry import LOSSES

__all__ = ["VAELossConfig", "VAELoss", "build_vae_loss", "reconstruction_error"]

_KINDS = ("l1", "mse")
_REDUCTIONS = ("mean", "sum")


@dataclass
class VAELossConfig:
    """Attributes:
    kl_weight: lambda1 (stage 1, Eq. 10) = lambda3 (stage 2, Eq. 11) = 1e-5 (MoMu App. A.2).
    reconstruction: ``"l1"`` or ``"mse"``.
    reduction: ``"mean"`` or ``"sum"`` (see the module docstring).
    velocity_weight: weight of the velocity term (see the module docstring; 0 = MoMu's loss).
    """

    kl_weight: float = 1e-5
    reconstruction: str = "l1"
    reduction: str = "mean"
    velocity_weight: float = 0.0


def reconstruction_error(
    reconstruction: torch.Tensor,
    target: torch.Tensor,
    kind: str = "l1",
    reduction: str = "mean",
    mask: torch.Tensor | None = None,
) -> torch.Tensor:
    """Scalar L1 / squared error between ``reconstruction`` and ``target`` (same shape ``(B, ...)``).

    ``mask``: optional, broadcastable to the shape, 1/True = counted. ``"mean"`` divides by the
    counted elements, ``"sum"`` sums per item and averages over the batch.
    """
    if kind not in _KINDS:
        raise ValueError(f"reconstruction must be one of {_KINDS}, got {kind!r}")
    if reduction not in _REDUCTIONS:
        raise ValueError(f"reduction must be one of {_REDUCTIONS}, got {reduction!r}")
    if reconstruction.shape != target.shape:
        raise ValueError(
            f"reconstruction {tuple(reconstruction.shape)} and target {tuple(target.shape)} shapes differ"
        )
    diff = reconstruction - target
    err = diff.abs() if kind == "l1" else diff.pow(2)
    if mask is not None:
        weights = torch.broadcast_to(mask.to(err.dtype), err.shape)
        err = err * weights
        if reduction == "mean":
            return err.sum() / weights.sum().clamp_min(1.0)
    if reduction == "mean":
        return err.mean()
    return err.sum() / err.shape[0]


class VAELoss(nn.Module):
    """``L_recon + kl_weight * L_KL`` (MoMu Eq. 10-11 without the GAN / contrastive terms)."""

    def __init__(self, cfg: VAELossConfig | None = None) -> None:
        super().__init__()
        cfg = cfg or VAELossConfig()
        if cfg.kl_weight < 0:
            raise ValueError(f"vae loss kl_weight must be >= 0, got {cfg.kl_weight}")
        if cfg.reconstruction not in _KINDS:
            raise ValueError(f"vae loss reconstruction must be one of {_KINDS}, got {cfg.reconstruction!r}")
        if cfg.reduction not in _REDUCTIONS:
            raise ValueError(f"vae loss reduction must be one of {_REDUCTIONS}, got {cfg.reduction!r}")
        if cfg.velocity_weight < 0:
            raise ValueError(f"vae loss velocity_weight must be >= 0, got {cfg.velocity_weight}")
        self.cfg = cfg

    def kl(self, posterior: DiagonalGaussian, mask: torch.Tensor | None = None) -> torch.Tensor:
        """The reduced KL term (before weighting)."""
        per_item = posterior.kl(mask)  # (B,) summed over (T_z, d)
        if self.cfg.reduction == "sum":
            return per_item.mean()
        if mask is None:
            count = float(posterior.mean[0].numel())
            return per_item.mean() / count
        counted = mask.to(per_item.dtype).sum(dim=1).clamp_min(1.0) * posterior.mean.shape[-1]
        return (per_item / counted).mean()

    def forward(
        self,
        reconstruction: torch.Tensor,
        target: torch.Tensor,
        posterior: DiagonalGaussian,
        *,
        mask: torch.Tensor | None = None,
        latent_mask: torch.Tensor | None = None,
        time_dim: int | None = None,
    ) -> dict[str, torch.Tensor]:
        """``{"loss", "reconstruction", "kl"}`` (``kl`` unweighted; ``loss`` = recon + kl_weight * kl).

        With ``velocity_weight > 0`` and a ``time_dim``, also ``"velocity"`` (unweighted) and
        ``loss`` += velocity_weight * velocity.

        Args:
            reconstruction, target: the VAE output and its target (:class:`momu.encoders.vae.VAEOutput`).
            posterior: ``q(z|x)``.
            mask: optional reconstruction mask broadcastable to ``target`` (True = valid).
            latent_mask: optional ``(B, T_z)`` mask of valid latent frames for the KL.
            time_dim: the time axis of ``target`` (the velocity term needs it; without it there is none).
        """
        cfg = self.cfg
        rec = reconstruction_error(reconstruction, target, cfg.reconstruction, cfg.reduction, mask)
        kl = self.kl(posterior, latent_mask)
        out = {"loss": rec + cfg.kl_weight * kl, "reconstruction": rec, "kl": kl}
        if cfg.velocity_weight > 0 and time_dim is not None:
            vel_mask = None
            if mask is not None:
                valid = torch.broadcast_to(mask.bool(), target.shape)
                vel_mask = valid.narrow(time_dim, 1, valid.shape[time_dim] - 1) & valid.narrow(
                    time_dim, 0, valid.shape[time_dim] - 1
                )
            velocity = reconstruction_error(
                reconstruction.diff(dim=time_dim),
                target.diff(dim=time_dim),
                cfg.reconstruction,
                cfg.reduction,
                vel_mask,
            )
            out["velocity"] = velocity
            out["loss"] = out["loss"] + cfg.velocity_weight * velocity
        return out


@LOSSES.register("vae", config=VAELossConfig)
def build_vae_loss(cfg: VAELossConfig) -> VAELoss:
    """Registry factory: reconstruction + lambda * KL (MoMu Eq. 10-11)."""
    return VAELoss(cfg)
