"""Other methods' pose losses on MoMu's music→motion denoiser: ``method.diffusion_losses``.

MoMu's θ_m denoises motion *latents*; MoFusion's scheduled kinematic loss and HarmoGAN's harmony loss
are written for joint positions. :class:`DecodedLosses` takes θ_m's clean estimate x̂₀ of each
training item (the diffusion loss's ``x0_pred``, :meth:`NoiseScheduler.x0_of`), de-standardises it,
decodes it through the frozen motion VAE decoder and the motion normaliser to joint positions at the
model's motion rate, and adds ``Σ_i w_i · mean_b λ_i(t_b) L_i(b)`` to the diffusion loss, each
``L_i`` a registered loss implementing :class:`~momu.losses.decoded.DecodedMotionLoss` (its math in
its own module). ``λ_i(t) = ᾱ_t`` for a loss that does not schedule itself (MoFusion's schedule);
the scheduled kinematic loss applies its own Eq. 4 weight. The clean latent is decoded too (no
gradient) as the target of MoFusion's L_m; the harmony loss gets each window's salient music beats
(:class:`~momu.losses.harmony.AudioTargets` of its clip, cut to the window).

Only θ_m (music→motion) gets these terms; θ_a trains as before. The decoder's weights are frozen
(they are the trained motion VAE's; the stage optimises only the denoisers) and kept in eval mode.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import torch
from torch import nn

from momu.losses.decoded import DecodedMotion, DecodedMotionLoss, alpha_bar_weight, frame_mask

__all__ = ["DecodedLosses", "build_decoded_losses", "loss_nodes", "BEAT_KEYS"]

BEAT_KEYS = ("beat_times", "beat_saliency", "beat_mask")
"""Keys of a training item's salient music beats (times from the window start, saliency, mask)."""


def loss_nodes(cfg: Any, skeleton: str | None = None) -> list[dict[str, Any]]:
    """The ``diffusion_losses`` nodes of a :class:`~momu.methods.momu.config.MoMuConfig`, each with its
    ``skeleton`` set to ``skeleton`` when its config has that field (the data decides the joints)."""
    from momu.methods.mofusion.method import node_with
    from momu.methods.momu.config import _plain
    from momu.registry import LOSSES

    nodes = [dict(_plain(n)) for n in (cfg.diffusion_losses or [])]
    if skeleton is None:
        return nodes
    return [node_with(n, LOSSES, skeleton=skeleton) for n in nodes]


def build_decoded_losses(nodes: Sequence[Mapping[str, Any]], scheduler: Any = None) -> list[Any]:
    """Build each loss node; raise ``ValueError`` naming ``method.diffusion_losses[i]`` for a loss that
    cannot be applied to decoded poses."""
    from momu.config import build_component

    built = []
    for i, node in enumerate(nodes):
        kinematic = node["name"] == "scheduled_kinematic"
        deps = {"scheduler": scheduler} if scheduler is not None and kinematic else {}
        part = build_component(dict(node), "losses", **deps)
        if not isinstance(part, DecodedMotionLoss):
            raise ValueError(
                f"method.diffusion_losses[{i}]: loss {node['name']!r} cannot be applied to decoded poses "
                "(it has no decoded_loss; see momu.losses.decoded)"
            )
        built.append(part)
    return built


class DecodedLosses(nn.Module):
    """``Σ_i w_i · mean_b λ_i(t_b) L_i(b)`` on θ_m's decoded x̂₀ (module docstring).

    Args:
        losses: built losses (:func:`build_decoded_losses`).
        weights: ``w_i``, one per loss.
        decoder: the motion VAE (``decode(z, frames)`` → normalised motion ``(B, T, J, D)``); frozen.
        motion_mean, motion_std: the motion normaliser's statistics ``(J, D)``.
        skeleton: the data's joint layout. fps: the decoded motion's rate (``rates.motion_fps``).
    """

    def __init__(
        self,
        losses: Sequence[Any],
        weights: Sequence[float],
        decoder: nn.Module,
        motion_mean: np.ndarray,
        motion_std: np.ndarray,
        skeleton: str,
        fps: float,
    ) -> None:
        super().__init__()
        if len(weights) != len(losses):
            raise ValueError(
                f"method.diffusion_loss_weights: {len(weights)} weights for {len(losses)} losses"
            )
        self.losses = nn.ModuleList([m for m in losses if isinstance(m, nn.Module)])
        self._parts = list(losses)  # in config order (a plugin's loss need not be a module)
        self.weights = [float(w) for w in weights]
        self.decoder = decoder
        for p in self.decoder.parameters():
            p.requires_grad_(False)
        self.decoder.eval()
        self.skeleton = skeleton
        self.fps = float(fps)
        self.motion_mean: torch.Tensor
        self.motion_std: torch.Tensor
        self.register_buffer("motion_mean", torch.as_tensor(np.asarray(motion_mean), dtype=torch.float32))
        self.register_buffer("motion_std", torch.as_tensor(np.asarray(motion_std), dtype=torch.float32))

    def train(self, mode: bool = True) -> DecodedLosses:
        super().train(mode)
        self.decoder.eval()  # a frozen part: never in training mode
        return self

    @property
    def needs_music_beats(self) -> bool:
        return any(bool(getattr(p, "needs_music_beats", False)) for p in self._parts)

    def positions(self, z_raw: torch.Tensor) -> torch.Tensor:
        """Raw motion latents ``(B, T_z, d)`` → joint positions ``(B, T_z · frames_per_latent, J, D)``."""
        normalised: torch.Tensor = self.decoder.decode(z_raw)  # type: ignore[operator]
        return normalised * self.motion_std.to(normalised.dtype) + self.motion_mean.to(normalised.dtype)

    def forward(
        self,
        x0_pred: torch.Tensor,
        x0_raw: torch.Tensor,
        x0_pred_raw: torch.Tensor,
        t: torch.Tensor,
        alphas_cumprod: torch.Tensor,
        latent_mask: torch.Tensor | None,
        music_beats: tuple[torch.Tensor, torch.Tensor, torch.Tensor] | None,
    ) -> tuple[torch.Tensor, dict[str, torch.Tensor]]:
        """The weighted sum and its logs for θ_m's batch.

        Args:
            x0_pred: θ_m's standardised x̂₀ (only its batch size is read).
            x0_raw, x0_pred_raw: the clean latent and x̂₀ de-standardised, ``(B, T_z, d)``.
            t: the batch's time steps; alphas_cumprod: the training scheduler's ᾱ.
            latent_mask: ``(B, T_z)`` valid latent frames or ``None``.
            music_beats: ``(times, saliency, mask)`` ``(B, K)`` each, or ``None``.
        """
        pred = self.positions(x0_pred_raw)
        with torch.no_grad():
            target = self.positions(x0_raw)
        frames_per_latent = pred.shape[1] // max(1, x0_pred.shape[1])
        mask = frame_mask(latent_mask, frames_per_latent)
        if music_beats is not None:  # beats past the (possibly shortened) window are not its music
            times, saliency, beat_mask = music_beats
            music_beats = (times, saliency, beat_mask & (times < pred.shape[1] / self.fps))
        d = DecodedMotion(pred, target, self.fps, t, alphas_cumprod, self.skeleton, mask, music_beats)
        total = pred.new_zeros(())
        logs: dict[str, torch.Tensor] = {}
        for i, (part, weight) in enumerate(zip(self._parts, self.weights)):
            value, part_logs = part.decoded_loss(d)  # (B,)
            if not part.schedules_itself:
                value = alpha_bar_weight(t, alphas_cumprod, value) * value
            term = weight * value.mean()
            total = total + term
            name = type(part).__name__
            logs[f"decoded{i}_{name}"] = term.detach()
            logs.update({f"decoded{i}_{k}": v for k, v in part_logs.items()})
        return total, logs
