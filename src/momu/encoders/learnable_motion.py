"""``learnable_motion``: a DSTformer motion encoder trained end-to-end with the denoiser.

MoMu §5.1 (Tables 3–4): on Floor Exercise and Figure Skating the 2D keypoints are too noisy for
the motion VAE, so motion→music generation conditions on "a learnable motion encoder, whose
architecture is derived from [51]" (MotionBERT). This part is that encoder: the shared
:class:`~momu.encoders.dstformer.DSTformer` (also the metrics' motion classifier) followed by a
per-frame projection of the joint representations to the condition width and an optional
temporal average pooling to the latent frame rate.

Shapes: ``motion (B, T, J, D)`` (``mask (B, T)`` bool, True = valid frame) →
``cond (B, T', out_channels)`` with ``T' = ceil(T / downsample)``, channels-last as in the
backbone call protocol (docs/protocols.md), plus the matching ``(B, T')`` mask from
:meth:`LearnableMotionEncoder.output_mask`. Its parameters receive gradients from the diffusion
loss; there is no separate pre-training.
"""

from __future__ import annotations

from dataclasses import dataclass

import torch
import torch.nn.functional as F
from torch import nn

from momu.encoders.dstformer import DSTformer, DSTformerConfig
from momu.registry import ENCODERS

__all__ = ["LearnableMotionConfig", "LearnableMotionEncoder", "build_learnable_motion"]


@dataclass
class LearnableMotionConfig:
    """Config of the ``learnable_motion`` encoder.

    Attributes:
        num_joints: J of the input keypoints (14 = MoMu's OpenPose subset, App. B.2).
        dim_in: D, 2 for image-plane keypoints, 3 for 3D joints.
        dim_feat: DSTformer width.
        dim_rep: DSTformer per-joint output width.
        depth: DSTformer dual-stream layers.
        num_heads: attention heads.
        mlp_ratio: MLP width multiple.
        dropout: dropout inside the DSTformer.
        out_channels: width of the condition sequence (MoMu's latent width is 20, Table 9
            "input channels", so the encoder is a drop-in for the motion VAE latent).
        downsample: temporal average-pooling factor from motion frames to condition frames
            (1 = one condition frame per motion frame).
        velocity: also feed each joint's frame-to-frame displacement (the first difference, 0 at the
            first frame) beside its position, doubling the DSTformer's input width (not in the
            paper: MoMu's motion→music signal is where movements start and stop — its kinematic
            amplitude, Eq. 1–2, is built from first differences — and a shallow encoder trained
            from scratch finds it more easily given the differences than from positions alone).
        standardize: standardise every input feature (each joint's coordinates and, with
            ``velocity``, their differences) with the per-feature mean and standard deviation of the
            training motion (:meth:`LearnableMotionEncoder.set_statistics`; saved with the weights).
            Not in the paper, which does not say how the encoder's input is scaled. Without it a
            globally normalised skeleton's fixed joint offsets and the DSTformer's unit-amplitude
            sinusoidal positions dwarf the movement (frame-to-frame differences of std ≈ 0.08), and
            the trained encoder's output varies over time but hardly across clips (issue 12, item 7:
            std across clips 0.016 against 0.194 over time, and the denoiser's loss was the same
            with another clip's motion).
    """

    num_joints: int = 14
    dim_in: int = 2
    dim_feat: int = 64
    dim_rep: int = 32
    depth: int = 2
    num_heads: int = 4
    mlp_ratio: float = 2.0
    dropout: float = 0.0
    out_channels: int = 20
    downsample: int = 1
    velocity: bool = False
    standardize: bool = True

    def __post_init__(self) -> None:
        if self.out_channels < 1:
            raise ValueError(f"LearnableMotionConfig.out_channels must be >= 1, got {self.out_channels}")
        if self.downsample < 1:
            raise ValueError(f"LearnableMotionConfig.downsample must be >= 1, got {self.downsample}")

    @property
    def input_channels(self) -> int:
        """Features per joint the DSTformer sees: ``dim_in``, doubled with ``velocity``."""
        return self.dim_in * (2 if self.velocity else 1)

    def dstformer(self) -> DSTformerConfig:
        """The :class:`DSTformerConfig` these fields describe."""
        return DSTformerConfig(
            num_joints=self.num_joints,
            dim_in=self.input_channels,
            dim_feat=self.dim_feat,
            dim_rep=self.dim_rep,
            depth=self.depth,
            num_heads=self.num_heads,
            mlp_ratio=self.mlp_ratio,
            dropout=self.dropout,
        )


class LearnableMotionEncoder(nn.Module):
    """Input features → DSTformer → per-frame projection → masked temporal average pooling (MoMu §5.1)."""

    def __init__(self, cfg: LearnableMotionConfig | None = None) -> None:
        super().__init__()
        self.cfg = cfg = cfg or LearnableMotionConfig()
        self.backbone = DSTformer(cfg.dstformer())
        self.proj = nn.Linear(cfg.num_joints * cfg.dim_rep, cfg.out_channels)
        shape = (cfg.num_joints, cfg.input_channels)
        self.input_mean: torch.Tensor
        self.input_std: torch.Tensor
        self.register_buffer("input_mean", torch.zeros(shape))
        self.register_buffer("input_std", torch.ones(shape))

    def features(self, motion: torch.Tensor, mask: torch.Tensor | None = None) -> torch.Tensor:
        """``(B, T, J, D)`` motion → the ``(B, T, J, input_channels)`` features, before standardising.

        With ``velocity`` each joint's first difference (0 at the first frame) is appended; a
        padded frame's difference never reaches a valid frame's input.
        """
        if not self.cfg.velocity:
            return motion
        step = torch.diff(motion, dim=1, prepend=motion[:, :1])
        if mask is not None:
            step = step * mask[:, :, None, None].to(step.dtype)
        return torch.cat([motion, step], dim=-1)

    @torch.no_grad()
    def set_statistics(self, motion: torch.Tensor) -> None:
        """Fit the input standardisation on the training motion ``(N, T, J, D)`` (if ``standardize``)."""
        if not self.cfg.standardize:
            return
        flat = self.features(motion).reshape(-1, *self.input_mean.shape).double()
        self.input_mean.copy_(flat.mean(0).float())
        self.input_std.copy_(flat.std(0).clamp_min(1e-6).float())

    @property
    def out_channels(self) -> int:
        """Width of the condition sequence (the backbone's ``cond_channels``)."""
        return self.cfg.out_channels

    def output_length(self, num_frames: int) -> int:
        """Condition frames produced for ``num_frames`` motion frames: ``ceil(T / downsample)``."""
        return -(-num_frames // self.cfg.downsample)

    def output_mask(self, mask: torch.Tensor) -> torch.Tensor:
        """``(B, T)`` frame mask → ``(B, T')`` condition mask (a window is valid if any frame is)."""
        k = self.cfg.downsample
        if k == 1:
            return mask
        pad = (-mask.shape[1]) % k
        padded = F.pad(mask, (0, pad), value=False)
        return padded.reshape(mask.shape[0], -1, k).any(dim=-1)

    def forward(self, motion: torch.Tensor, mask: torch.Tensor | None = None) -> torch.Tensor:
        """Encode ``motion (B, T, J, D)`` to the condition sequence ``(B, ceil(T/downsample), out_channels)``.

        Padded frames (``mask`` False) never influence valid condition frames.
        """
        x = (self.features(motion, mask) - self.input_mean) / self.input_std
        rep = self.backbone(x, mask)  # (B, T, J, dim_rep)
        b, t, j, c = rep.shape
        h = self.proj(rep.reshape(b, t, j * c))  # (B, T, out_channels)
        k = self.cfg.downsample
        if k == 1:
            return h
        weights = (
            torch.ones(b, t, device=h.device, dtype=h.dtype) if mask is None else mask.to(h.dtype)
        )  # (B, T)
        pad = (-t) % k
        h = F.pad(h * weights[..., None], (0, 0, 0, pad)).reshape(b, -1, k, h.shape[-1])
        counts = F.pad(weights, (0, pad)).reshape(b, -1, k).sum(dim=-1, keepdim=True)  # (B, T', 1)
        return h.sum(dim=2) / counts.clamp(min=1.0)


@ENCODERS.register("learnable_motion", config=LearnableMotionConfig)
def build_learnable_motion(cfg: LearnableMotionConfig, **deps: object) -> LearnableMotionEncoder:
    """Factory of the ``learnable_motion`` encoder (MoMu §5.1, Tables 3–4)."""
    return LearnableMotionEncoder(cfg)
