"""HarmoGAN's generator G(A_f, V_f) = V′ (§IV-B, Fig. 8): ``harmogan_generator``.

"Our generator comprises an audio encoder, a pose decoder, and a depth lifting network ... our audio
encoder and pose decoder utilize dense blocks, each composed of a dense layer, layer normalization, and
a LeakyReLu layer. We also leverage ... GRUs ... we introduce random noise and dropout layers at the
beginning and end of the encoding and decoding phases, respectively ... our pose decoder first outputs
preliminary 2D human poses V′_2d. These are then combined with previously obtained latent features to
generate the final 3D poses V′." Layer sizes appear only in Fig. 8; momu's choices are the config
fields below (defaults: the cpu-preset sizes; ``recipes/configs/harmogan_paper.yaml`` pins its own).

Per frame ``t`` of a meter unit:

1. **Encoding**: ``[A_f,t ⊕ z]`` (MFCCs and ``noise_dim`` Gaussian noise: "noise at the beginning"; one
   noise vector per unit, repeated over its frames — i.i.d. noise per frame, ``noise_per_frame``, makes
   the generated joints jitter: about twice the acceleration per unit of speed of the real motion)
   → ``audio_blocks`` dense blocks; the pose input ``[V_f,t ⊕ e_t]`` (Eq. 12 poses, flattened, and the
   transition index TI) → ``pose_blocks`` dense blocks; both concatenated → a GRU (``gru_layers``,
   bidirectional by default: a unit's music is known in full) → latent ``L_t``; dropout ``p`` at the
   end of encoding.
2. **Decoding**: ``[L_t ⊕ z′]`` (a second noise vector at the beginning of decoding) → ``decoder_blocks``
   dense blocks → dropout → a linear layer to ``V′_2d,t`` (J × 2; with ``residual`` it is added to V_f's
   x, y: the decoder predicts the motion relative to the unit's initial poses).
3. **Depth lifting**: ``[V′_2d,t ⊕ L_t]`` → ``lifting_blocks`` dense blocks → a linear layer to the
   depth ``z′_t`` (J values; plus V_f's depth with ``residual``); ``V′_t = (x′, y′, z′)``, so V′_2d is
   exactly the orthographic projection of V′ (momu's 2D convention: drop z, DwM is Y-up).
"""

from __future__ import annotations

from dataclasses import dataclass

import torch
from torch import nn

from momu.registry import ENCODERS

__all__ = [
    "DenseBlock",
    "dense_stack",
    "HarmoGANGeneratorConfig",
    "GeneratorOutput",
    "HarmoGANGenerator",
    "build_harmogan_generator",
]


class DenseBlock(nn.Sequential):
    """HarmoGAN's dense block (§IV-B): ``Linear → LayerNorm → LeakyReLU``."""

    def __init__(self, dim_in: int, dim_out: int, slope: float = 0.2) -> None:
        super().__init__(nn.Linear(dim_in, dim_out), nn.LayerNorm(dim_out), nn.LeakyReLU(slope))


def dense_stack(dim_in: int, hidden: int, blocks: int, slope: float = 0.2) -> nn.Sequential:
    """``blocks`` dense blocks, the first from ``dim_in`` and the rest ``hidden → hidden``."""
    if blocks < 1:
        raise ValueError(f"a dense stack needs at least one block, got {blocks}")
    return nn.Sequential(*[DenseBlock(dim_in if i == 0 else hidden, hidden, slope) for i in range(blocks)])


@dataclass
class HarmoGANGeneratorConfig:
    """Sizes of the generator (HarmoGAN Fig. 8; the text gives none).

    Attributes:
        num_joints: J (21 for Dance with Melody; set from the data by the method).
        audio_channels: MFCC coefficients per frame (set from the method's MFCC config).
        hidden: width of every dense block and of the GRU.
        audio_blocks, pose_blocks: dense blocks of the audio and pose encoders.
        gru_layers: stacked GRU layers; bidirectional: a bidirectional GRU (output projected to ``hidden``).
        decoder_blocks: dense blocks of the pose decoder; lifting_blocks: of the depth-lifting network.
        noise_dim: Gaussian noise channels concatenated at the start of encoding and of decoding.
        noise_per_frame: draw the noise per frame (``False``: one vector per unit, repeated).
        dropout: dropout probability at the end of encoding and of decoding.
        slope: LeakyReLU negative slope.
        residual: predict poses relative to V_f (the unit's initial poses) instead of absolute.
    """

    num_joints: int = 21
    audio_channels: int = 20
    hidden: int = 128
    audio_blocks: int = 2
    pose_blocks: int = 1
    gru_layers: int = 1
    bidirectional: bool = True
    decoder_blocks: int = 2
    lifting_blocks: int = 2
    noise_dim: int = 16
    noise_per_frame: bool = False
    dropout: float = 0.1
    slope: float = 0.2
    residual: bool = True

    def __post_init__(self) -> None:
        if self.num_joints < 1 or self.audio_channels < 1 or self.hidden < 1 or self.gru_layers < 1:
            raise ValueError(
                "harmogan_generator: num_joints, audio_channels, hidden, gru_layers must be >= 1"
            )
        if self.noise_dim < 0 or not 0.0 <= self.dropout < 1.0:
            raise ValueError("harmogan_generator: noise_dim must be >= 0 and dropout in [0, 1)")


@dataclass
class GeneratorOutput:
    """``pose_2d`` V′_2d ``(B, T, J, 2)`` and ``motion`` V′ ``(B, T, J, 3)``."""

    pose_2d: torch.Tensor
    motion: torch.Tensor


class HarmoGANGenerator(nn.Module):
    """G(A_f, V_f) = V′ of HarmoGAN Fig. 8; see the module docstring."""

    def __init__(self, cfg: HarmoGANGeneratorConfig | None = None) -> None:
        super().__init__()
        self.cfg = c = cfg or HarmoGANGeneratorConfig()
        j = c.num_joints
        self.audio_encoder = dense_stack(c.audio_channels + c.noise_dim, c.hidden, c.audio_blocks, c.slope)
        self.pose_encoder = dense_stack(3 * j + 1, c.hidden, c.pose_blocks, c.slope)
        self.gru = nn.GRU(
            2 * c.hidden, c.hidden, c.gru_layers, batch_first=True, bidirectional=c.bidirectional
        )
        self.gru_out = nn.Linear(2 * c.hidden, c.hidden) if c.bidirectional else nn.Identity()
        self.encoder_dropout = nn.Dropout(c.dropout)
        self.pose_decoder = dense_stack(c.hidden + c.noise_dim, c.hidden, c.decoder_blocks, c.slope)
        self.decoder_dropout = nn.Dropout(c.dropout)
        self.to_2d = nn.Linear(c.hidden, 2 * j)
        self.lifting = dense_stack(2 * j + c.hidden, c.hidden, c.lifting_blocks, c.slope)
        self.to_depth = nn.Linear(c.hidden, j)

    def _noise(self, like: torch.Tensor, generator: torch.Generator | None) -> torch.Tensor:
        b, t = like.shape[:2]
        shape = (b, t if self.cfg.noise_per_frame else 1, self.cfg.noise_dim)
        if generator is None:
            z = torch.randn(shape, device=like.device, dtype=like.dtype)
        else:
            z = torch.randn(shape, generator=generator, dtype=like.dtype).to(like.device)
        return z.expand(b, t, self.cfg.noise_dim)

    def forward(
        self,
        mfcc: torch.Tensor,
        initial_poses: torch.Tensor,
        transition: torch.Tensor,
        generator: torch.Generator | None = None,
    ) -> GeneratorOutput:
        """Generate a unit's poses.

        Args:
            mfcc: ``(B, T, audio_channels)`` A_f, frame-aligned with the motion.
            initial_poses: ``(B, T, J, 3)`` V_f (Eq. 12).
            transition: ``(B, T)`` TI (1 on the preceding meter's transition frames).
            generator: draws the encoder/decoder noise (``None``: the global RNG).
        """
        b, t = mfcc.shape[:2]
        j = self.cfg.num_joints
        if initial_poses.shape != (b, t, j, 3) or transition.shape != (b, t):
            raise ValueError(
                f"harmogan_generator: expected V_f {(b, t, j, 3)} and TI {(b, t)}, got "
                f"{tuple(initial_poses.shape)} and {tuple(transition.shape)}"
            )
        vf = initial_poses.reshape(b, t, 3 * j)
        audio = self.audio_encoder(torch.cat([mfcc, self._noise(mfcc, generator)], dim=-1))
        pose = self.pose_encoder(torch.cat([vf, transition[..., None].to(vf.dtype)], dim=-1))
        latent, _ = self.gru(torch.cat([audio, pose], dim=-1))
        latent = self.encoder_dropout(self.gru_out(latent))  # (B, T, hidden)
        decoded = self.pose_decoder(torch.cat([latent, self._noise(latent, generator)], dim=-1))
        pose_2d = self.to_2d(self.decoder_dropout(decoded)).reshape(b, t, j, 2)
        if self.cfg.residual:
            pose_2d = pose_2d + initial_poses[..., :2]
        depth = self.to_depth(self.lifting(torch.cat([pose_2d.reshape(b, t, 2 * j), latent], dim=-1)))
        if self.cfg.residual:
            depth = depth + initial_poses[..., 2]
        return GeneratorOutput(pose_2d=pose_2d, motion=torch.cat([pose_2d, depth[..., None]], dim=-1))


@ENCODERS.register("harmogan_generator", config=HarmoGANGeneratorConfig)
def build_harmogan_generator(cfg: HarmoGANGeneratorConfig, **deps: object) -> HarmoGANGenerator:
    """Factory of HarmoGAN's generator (§IV-B, Fig. 8)."""
    return HarmoGANGenerator(cfg)
