"""``scheduled_kinematic``: MoFusion's training objective with scheduled kinematic losses (§3.2).

MoFusion Eq. 4: ``L_t = L_da + λ_k^(t) L_k`` with ``λ_k^(t) = ᾱ_t`` per sample, and
``L_k = L_s + λ_a L_a + λ_m L_m``:

* ``L_da`` — the ε-prediction L2 (the registered ``diffusion`` loss, wrapped here, not copied);
* ``L_s`` (Eq. 6) — skeleton consistency: the temporal variance of every bone length
  ``Σ_n (l_n − l̄)² / (n − 1)`` (unbiased, over the valid frames), **averaged over bones**;
* ``L_a`` — left/right symmetry ``‖BL(j1, j2) − BL(δ(j1), δ(j2))‖`` over the skeleton's mirror
  bone pairs (:func:`momu.features.mofusion_pose.mirror_bone_pairs`): the absolute difference,
  averaged over pairs and valid frames (the paper's norm of a scalar difference is its absolute
  value);
* ``L_m`` (Eq. 7) — x₀ supervision ``‖M̂⁽⁰⁾ − M⁽⁰⁾‖`` on the pose vectors M (§3: root
  translation + root-relative joints, de-standardised, metres), M̂⁽⁰⁾ from Eq. 5 (the scheduler's
  ``predict_x0``, :attr:`DiffusionLossOutput.x0_pred`): the squared error, averaged over valid
  frames and the 3J channels (metres²). In the model's standardised space
  ``ᾱ_t ‖x̂₀ − x₀‖² = (1 − ᾱ_t) ‖ε̂ − ε‖²`` holds exactly, but ``L_m`` is computed after
  de-standardising, so the scheduled ``ᾱ_t L_m`` is ``(1 − ᾱ_t)`` times the ε error with each
  channel weighted by its data variance ``σ_c²`` (metres²), whereas ``L_da`` weighs every
  standardised channel alike: a reweighted data term, reweighted per time step *and* per channel
  (a plain ``1 − ᾱ_t`` reweighting only if every channel had the same σ). ``λ_m`` is therefore a
  free choice (the paper does not give λ_a or λ_m; both default to 1).

The model sees a standardised pose vector; :meth:`ScheduledKinematicLoss.set_statistics` stores the
per-channel mean/std (buffers), and x̂₀ is de-standardised and decoded to positions
(:func:`momu.features.mofusion_pose.decode_pose`) before the kinematic terms, so they are in metres
whatever the model's normalisation. Any backbone that predicts ε over a ``(B, T, 3J)`` pose
sequence works (``unet1d``, ``dit``, plugins).

Switches: ``use_s`` / ``use_a`` / ``use_m`` (MoFusion supp. Table 1's rows), and ``schedule``:
``alpha_bar`` (Eq. 4), ``constant`` (``λ_k = constant_weight`` at every t: the naïve variant the
paper calls unstable) or ``none`` (no kinematic term: ``L_t = L_da``).

On another model's poses (:meth:`ScheduledKinematicLoss.decoded_loss`, :mod:`momu.losses.decoded`):
a latent diffusion model (MoMu) decodes its x̂₀ to joint positions and adds ``λ_k^(t) L_k`` of them,
the same terms and schedule (``L_m`` between the pose vectors of the decoded x̂₀ and of the decoded
clean latent).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import torch
from torch import Tensor, nn

from momu.features.bones import bone_lengths
from momu.features.mofusion_pose import decode_pose, encode_pose, mirror_bone_pairs, pose_channels
from momu.features.skeletons import get_skeleton
from momu.losses.decoded import DecodedMotion
from momu.losses.diffusion import DiffusionLoss, DiffusionLossOutput
from momu.registry import LOSSES
from momu.samplers.base import Backbone, resolve_scheduler

__all__ = [
    "SCHEDULES",
    "ScheduledKinematicConfig",
    "ScheduledKinematicLoss",
    "KinematicTerms",
    "skeleton_consistency",
    "symmetry",
    "build_scheduled_kinematic",
]

SCHEDULES = ("alpha_bar", "constant", "none")


def _default_data_loss() -> dict[str, Any]:
    return {"name": "diffusion", "cond_drop_prob": 0.0}


@dataclass
class ScheduledKinematicConfig:
    """MoFusion Eq. 4–7.

    Attributes:
        data_loss: the ``diffusion`` loss node giving L_da (MoFusion uses no classifier-free
            guidance, so its condition dropout defaults to 0).
        skeleton: joint layout of the pose vector (``smpl24``: 72-d; ``humanml22``: 66-d).
        use_s, use_a, use_m: include L_s, L_a, L_m in L_k (supp. Table 1 rows).
        lambda_a, lambda_m: weights of L_a and L_m in L_k (not given by the paper; 1).
        schedule: ``alpha_bar`` (λ_k^(t) = ᾱ_t, Eq. 4), ``constant`` or ``none`` (no L_k).
        constant_weight: λ_k with ``schedule: constant``.
    """

    data_loss: Any = field(default_factory=_default_data_loss)
    skeleton: str = "smpl24"
    use_s: bool = True
    use_a: bool = True
    use_m: bool = True
    lambda_a: float = 1.0
    lambda_m: float = 1.0
    schedule: str = "alpha_bar"
    constant_weight: float = 1.0


@dataclass
class KinematicTerms:
    """Per-sample terms ``(B,)`` of one batch (before the weight) and the weight ``λ_k^(t)``."""

    skeleton: Tensor
    symmetry: Tensor
    x0: Tensor
    weight: Tensor


def _valid(mask: Tensor | None, b: int, t: int, device: torch.device) -> Tensor:
    if mask is None:
        return torch.ones(b, t, dtype=torch.bool, device=device)
    return mask


def skeleton_consistency(positions: Tensor, bones: Any, mask: Tensor | None = None) -> Tensor:
    """MoFusion Eq. 6 per sample ``(B,)``: unbiased temporal variance of each bone length, mean over bones.

    ``positions (B, T, J, 3)``; ``mask (B, T)`` valid frames (an item with one valid frame gives 0).
    """
    lengths = bone_lengths(positions, bones)  # (B, T, n_bones)
    m = _valid(mask, lengths.shape[0], lengths.shape[1], lengths.device)[..., None].to(lengths.dtype)
    n = m.sum(dim=1)  # (B, 1)
    mean = (lengths * m).sum(dim=1) / n.clamp_min(1.0)  # (B, n_bones)
    var = (((lengths - mean[:, None]) ** 2) * m).sum(dim=1) / (n - 1.0).clamp_min(1.0)
    return var.mean(dim=-1)


def symmetry(
    positions: Tensor, bones: Any, pairs: tuple[tuple[int, int], ...], mask: Tensor | None = None
) -> Tensor:
    """MoFusion L_a per sample ``(B,)``: mean over valid frames and mirror pairs of ``|l_b − l_δ(b)|``."""
    if not pairs:
        return positions.new_zeros(positions.shape[0])
    lengths = bone_lengths(positions, bones)  # (B, T, n_bones)
    left = torch.tensor([p[0] for p in pairs], device=lengths.device)
    right = torch.tensor([p[1] for p in pairs], device=lengths.device)
    diff = (lengths[..., left] - lengths[..., right]).abs().mean(dim=-1)  # (B, T)
    m = _valid(mask, diff.shape[0], diff.shape[1], diff.device).to(diff.dtype)
    return (diff * m).sum(dim=1) / m.sum(dim=1).clamp_min(1.0)


class ScheduledKinematicLoss(nn.Module):
    """MoFusion Eq. 4; call ``loss(backbone, x0, cond, ...)`` like ``diffusion``.

    Returns ``(total, logs)`` via :meth:`forward`; :meth:`terms` exposes the per-sample terms.
    """

    def __init__(self, cfg: ScheduledKinematicConfig, data_loss: DiffusionLoss) -> None:
        super().__init__()
        if cfg.schedule not in SCHEDULES:
            raise ValueError(f"scheduled_kinematic.schedule {cfg.schedule!r} not one of {SCHEDULES}")
        for name in ("lambda_a", "lambda_m", "constant_weight"):
            if getattr(cfg, name) < 0:
                raise ValueError(f"scheduled_kinematic.{name} must be >= 0, got {getattr(cfg, name)}")
        self.cfg = cfg
        self.data_loss = data_loss
        self.skeleton = get_skeleton(cfg.skeleton)
        if self.skeleton.dims != 3:
            raise ValueError(f"scheduled_kinematic.skeleton {cfg.skeleton!r} is 2D; MoFusion poses are 3D")
        self.channels = pose_channels(self.skeleton.num_joints)
        self.pairs = mirror_bone_pairs(self.skeleton)
        self.x_mean: Tensor
        self.x_std: Tensor
        self.register_buffer("x_mean", torch.zeros(self.channels))
        self.register_buffer("x_std", torch.ones(self.channels))

    @property
    def scheduler(self) -> Any:
        return self.data_loss.scheduler

    @property
    def active(self) -> bool:
        """Whether any kinematic term is added (``schedule != none`` and a term switched on)."""
        c = self.cfg
        return c.schedule != "none" and (c.use_s or c.use_a or c.use_m)

    def set_statistics(self, mean: Any, std: Any) -> None:
        """Per-channel mean/std of the standardised pose vector the model sees (``(3J,)`` each)."""
        self.x_mean.copy_(torch.as_tensor(mean, dtype=torch.float32).reshape(self.channels))
        self.x_std.copy_(torch.as_tensor(std, dtype=torch.float32).reshape(self.channels))

    def raw(self, x: Tensor) -> Tensor:
        """Standardised pose vectors ``(B, T, 3J)`` -> pose vectors in metres (MoFusion §3's M)."""
        return x * self.x_std.to(x.dtype) + self.x_mean.to(x.dtype)

    def positions(self, x: Tensor) -> Tensor:
        """Standardised pose vectors ``(B, T, 3J)`` -> joint positions ``(B, T, J, 3)`` in metres."""
        return decode_pose(self.raw(x), self.skeleton.num_joints, self.skeleton.root)

    def weight(self, t: Tensor, ref: Tensor) -> Tensor:
        """λ_k^(t) per sample ``(B,)`` (Eq. 4: ᾱ_t)."""
        if self.cfg.schedule == "alpha_bar":
            abar = self.scheduler.alphas_cumprod.to(ref.device)[t.long()]
            return abar.to(ref.dtype)
        value = self.cfg.constant_weight if self.cfg.schedule == "constant" else 0.0
        return torch.full(t.shape, value, dtype=ref.dtype, device=ref.device)

    def terms(self, out: DiffusionLossOutput, x0: Tensor, x_mask: Tensor | None) -> KinematicTerms:
        """L_s, L_a, L_m per sample for the data term's output ``out`` and the clean ``x0``."""
        pred = self.positions(out.x0_pred)
        return self.pose_terms(pred, self.raw(out.x0_pred), self.raw(x0), out.t, x_mask)

    def pose_terms(
        self, pred: Tensor, pred_pose: Tensor, target_pose: Tensor, t: Tensor, mask: Tensor | None
    ) -> KinematicTerms:
        """L_s, L_a (on ``pred (B, T, J, 3)`` positions), L_m (``pred_pose`` against ``target_pose``,
        ``(B, T, 3J)`` pose vectors in metres) per sample, and λ_k^(t) of ``t``."""
        zero = pred.new_zeros(pred.shape[0])
        ls = skeleton_consistency(pred, self.skeleton.bones, mask) if self.cfg.use_s else zero
        la = symmetry(pred, self.skeleton.bones, self.pairs, mask) if self.cfg.use_a else zero
        if self.cfg.use_m:
            err = ((pred_pose - target_pose) ** 2).mean(dim=-1)  # (B, T)
            m = _valid(mask, err.shape[0], err.shape[1], err.device).to(err.dtype)
            lm = (err * m).sum(dim=1) / m.sum(dim=1).clamp_min(1.0)
        else:
            lm = zero
        return KinematicTerms(ls, la, lm, self.weight(t, pred))

    def combined(self, k: KinematicTerms) -> Tensor:
        """``λ_k^(t) L_k`` per sample ``(B,)`` with ``L_k = L_s + λ_a L_a + λ_m L_m`` (Eq. 4)."""
        return k.weight * (k.skeleton + self.cfg.lambda_a * k.symmetry + self.cfg.lambda_m * k.x0)

    # ------------------------------------------------------------ on another model's decoded x̂₀
    schedules_itself = True
    """:class:`~momu.losses.decoded.DecodedMotionLoss`: λ_k^(t) is part of the value (Eq. 4)."""
    needs_music_beats = False

    def decoded_loss(self, d: DecodedMotion) -> tuple[Tensor, dict[str, Tensor]]:
        """``λ_k^(t) L_k`` per sample on decoded joint positions (:mod:`momu.losses.decoded`).

        L_s and L_a are taken on ``d.pred``, L_m between the MoFusion pose vectors (§3: root
        translation + root-relative joints) of ``d.pred`` and ``d.target``; the positions are used
        as they are (no pose-vector standardisation: :meth:`set_statistics` does not apply).
        """
        if d.pred.shape[-2:] != (self.skeleton.num_joints, 3):
            raise ValueError(
                f"scheduled_kinematic: decoded motion has {tuple(d.pred.shape[-2:])} joints x dims, "
                f"skeleton {self.cfg.skeleton!r} needs ({self.skeleton.num_joints}, 3)"
            )
        if not self.active:
            return d.pred.new_zeros(d.pred.shape[0]), {}
        root = self.skeleton.root
        k = self.pose_terms(
            d.pred, encode_pose(d.pred, root), encode_pose(d.target, root).detach(), d.t, d.mask
        )
        value = self.combined(k)
        logs = {
            "l_s": k.skeleton.detach().mean(),
            "l_a": k.symmetry.detach().mean(),
            "l_m": k.x0.detach().mean(),
        }
        return value, logs

    def forward(
        self,
        backbone: Backbone,
        x0: Tensor,
        cond: Tensor | None = None,
        *,
        x_mask: Tensor | None = None,
        cond_mask: Tensor | None = None,
        t: Tensor | None = None,
        noise: Tensor | None = None,
        generator: torch.Generator | None = None,
    ) -> tuple[Tensor, dict[str, Tensor]]:
        """``L_t`` of Eq. 4 for a batch of standardised pose vectors ``x0 (B, T, 3J)``; and its logs.

        The logs are detached 0-d tensors, so a training step never waits for the device to read
        them (the engine reads them back at logging steps only).
        """
        if x0.shape[-1] != self.channels:
            raise ValueError(
                f"x0: {x0.shape[-1]} channels, skeleton {self.cfg.skeleton!r} needs {self.channels}"
            )
        out = self.data_loss(
            backbone, x0, cond, x_mask=x_mask, cond_mask=cond_mask, t=t, noise=noise, generator=generator
        )
        logs = {"l_da": out.loss.detach()}
        if not self.active:
            return out.loss, logs
        k = self.terms(out, x0, x_mask)
        weighted = self.combined(k)  # (B,)
        total = out.loss + weighted.mean()
        logs.update(
            l_s=k.skeleton.detach().mean(),
            l_a=k.symmetry.detach().mean(),
            l_m=k.x0.detach().mean(),
            l_k_weighted=weighted.detach().mean(),
        )
        return total, logs


@LOSSES.register("scheduled_kinematic", config=ScheduledKinematicConfig)
def build_scheduled_kinematic(
    cfg: ScheduledKinematicConfig, scheduler: object = None, **deps: object
) -> ScheduledKinematicLoss:
    """MoFusion Eq. 4 over ``scheduler`` (a NoiseScheduler or node; default ``ddpm``)."""
    from momu.config import build_component

    sched = resolve_scheduler(scheduler if scheduler is not None else "ddpm")
    data = build_component(cfg.data_loss, "losses", scheduler=sched)
    if not isinstance(data, DiffusionLoss):
        raise ValueError(
            f"scheduled_kinematic.data_loss: expected the 'diffusion' loss, got {type(data).__name__}"
        )
    return ScheduledKinematicLoss(cfg, data)
