"""HarmoGAN's two discriminators (§IV-B, Fig. 8): ``harmogan_cross_modal_discriminator`` (D_cd) and
``harmogan_spatiotemporal_discriminator`` (D_st).

* **Cross-modal D_cd(A_f, V)**: "a two-branch classification network ... Each branch owns 3 sets of
  dense blocks to extract auditory and visual features independently. These features are subsequently
  concatenated together to estimate cross-modal stylistic consistency." momu: per frame, an audio
  branch over the MFCCs and a motion branch over the flattened poses and their frame differences
  (``blocks`` dense blocks each, HarmoGAN's 3); the two features are concatenated, passed through one
  more dense block, averaged over the frames and mapped to one real/fake logit.
* **Spatio-temporal D_st(V)**: "the input motion sequence V is evenly segmented into four parts based on
  the time duration ... the temporally related movement features, extracted from each motion segment,
  are analyzed and combined in a local-to-global way ... progressively extracting spatial features and
  concatenating them temporally in chronological order." momu: per frame, spatial dense blocks over the
  pose and its frame difference; the frames cut evenly into ``parts`` (4) segments in time; each
  segment's feature is the mean and standard deviation of its frames' features through a dense block;
  neighbouring segments are then concatenated in chronological order and merged pairwise by dense
  blocks (4 → 2 → 1: local to global) before a linear real/fake logit.

Both return raw logits ``(B,)``; the objective is :class:`momu.losses.gan.GANLoss` (``vanilla`` = the
log-likelihood terms of Eq. 17–19).
"""

from __future__ import annotations

from dataclasses import dataclass

import torch
from torch import nn

from momu.encoders.harmogan_generator import DenseBlock, dense_stack
from momu.registry import ENCODERS

__all__ = [
    "CrossModalDiscriminatorConfig",
    "CrossModalDiscriminator",
    "SpatioTemporalDiscriminatorConfig",
    "SpatioTemporalDiscriminator",
    "motion_frame_features",
]


def motion_frame_features(motion: torch.Tensor) -> torch.Tensor:
    """``(B, T, J, 3)`` poses → ``(B, T, 6J)``: flattened poses and their frame differences (0 at t = 0)."""
    b, t = motion.shape[:2]
    flat = motion.reshape(b, t, -1)
    diff = torch.cat([torch.zeros_like(flat[:, :1]), flat[:, 1:] - flat[:, :-1]], dim=1)
    return torch.cat([flat, diff], dim=-1)


@dataclass
class CrossModalDiscriminatorConfig:
    """Attributes: num_joints, audio_channels (set by the method); hidden width; blocks per branch
    (HarmoGAN: 3); slope of the LeakyReLU."""

    num_joints: int = 21
    audio_channels: int = 20
    hidden: int = 64
    blocks: int = 3
    slope: float = 0.2


class CrossModalDiscriminator(nn.Module):
    """D_cd(A_f, V) → logits ``(B,)``: does the motion's style match the music?"""

    def __init__(self, cfg: CrossModalDiscriminatorConfig | None = None) -> None:
        super().__init__()
        self.cfg = c = cfg or CrossModalDiscriminatorConfig()
        self.audio_branch = dense_stack(c.audio_channels, c.hidden, c.blocks, c.slope)
        self.motion_branch = dense_stack(6 * c.num_joints, c.hidden, c.blocks, c.slope)
        self.joint = DenseBlock(2 * c.hidden, c.hidden, c.slope)
        self.head = nn.Linear(c.hidden, 1)

    def forward(self, mfcc: torch.Tensor, motion: torch.Tensor) -> torch.Tensor:
        if mfcc.shape[:2] != motion.shape[:2]:
            raise ValueError(
                f"harmogan_cross_modal_discriminator: A_f {tuple(mfcc.shape)} and V {tuple(motion.shape)} "
                "must share (B, T)"
            )
        feats = torch.cat(
            [self.audio_branch(mfcc), self.motion_branch(motion_frame_features(motion))], dim=-1
        )
        return self.head(self.joint(feats).mean(dim=1)).squeeze(-1)


@dataclass
class SpatioTemporalDiscriminatorConfig:
    """Attributes: num_joints (set by the method); hidden width; spatial dense blocks per frame; parts
    (HarmoGAN: 4, a power of two for the pairwise local-to-global merge); slope of the LeakyReLU."""

    num_joints: int = 21
    hidden: int = 64
    spatial_blocks: int = 2
    parts: int = 4
    slope: float = 0.2

    def __post_init__(self) -> None:
        if self.parts < 1 or self.parts & (self.parts - 1):
            raise ValueError(
                f"harmogan_spatiotemporal_discriminator: parts must be a power of 2, got {self.parts}"
            )


class SpatioTemporalDiscriminator(nn.Module):
    """D_st(V) → logits ``(B,)``: are the poses and their temporal flow realistic?"""

    def __init__(self, cfg: SpatioTemporalDiscriminatorConfig | None = None) -> None:
        super().__init__()
        self.cfg = c = cfg or SpatioTemporalDiscriminatorConfig()
        self.spatial = dense_stack(6 * c.num_joints, c.hidden, c.spatial_blocks, c.slope)
        self.local = DenseBlock(2 * c.hidden, c.hidden, c.slope)
        levels = max(0, c.parts.bit_length() - 1)
        self.merges = nn.ModuleList([DenseBlock(2 * c.hidden, c.hidden, c.slope) for _ in range(levels)])
        self.head = nn.Linear(c.hidden, 1)

    def forward(self, motion: torch.Tensor) -> torch.Tensor:
        if motion.shape[1] < self.cfg.parts:
            raise ValueError(
                f"harmogan_spatiotemporal_discriminator: {motion.shape[1]} frames cannot be cut into "
                f"{self.cfg.parts} parts"
            )
        frames = self.spatial(motion_frame_features(motion))  # (B, T, H)
        parts = [
            self.local(torch.cat([p.mean(dim=1), p.std(dim=1, unbiased=False)], dim=-1))
            for p in torch.tensor_split(frames, self.cfg.parts, dim=1)
        ]
        for merge in self.merges:  # local to global, neighbours in chronological order
            parts = [merge(torch.cat([parts[i], parts[i + 1]], dim=-1)) for i in range(0, len(parts), 2)]
        return self.head(parts[0]).squeeze(-1)


@ENCODERS.register("harmogan_cross_modal_discriminator", config=CrossModalDiscriminatorConfig)
def build_cross_modal_discriminator(
    cfg: CrossModalDiscriminatorConfig, **deps: object
) -> CrossModalDiscriminator:
    """Factory of HarmoGAN's cross-modal discriminator D_cd (§IV-B)."""
    return CrossModalDiscriminator(cfg)


@ENCODERS.register("harmogan_spatiotemporal_discriminator", config=SpatioTemporalDiscriminatorConfig)
def build_spatiotemporal_discriminator(
    cfg: SpatioTemporalDiscriminatorConfig, **deps: object
) -> SpatioTemporalDiscriminator:
    """Factory of HarmoGAN's spatio-temporal discriminator D_st (§IV-B)."""
    return SpatioTemporalDiscriminator(cfg)
