"""Raw-waveform music VAE: MoMu's "w/o Mel-spectrogram" ablation (Table 7 #2, §5.3 "Music Encoding").

The mel VAE sees one mel frame per ``hop_length`` = 256 samples (16 kHz, MoMu App. B.2) and
downsamples by 2, so a music latent covers 512 samples (31.25 latent frames/s). To "land on the
same latent rate", this VAE first folds the waveform into non-overlapping frames of
``hop_length`` samples — a lossless space-to-depth downsampling by 256, ``(B, S) -> (B, 256, S/256)``
— and then applies the same Table 8 network, whose Conv1d downsampling gives the remaining factor 2.
The decoder unfolds its ``(B, 256, T)`` output back into samples.

Latent counts: ``ceil(S / 512)`` for ``S`` samples; a mel VAE on the centred STFT of the same audio
has ``ceil((1 + S // 256) / 2)`` latents, one more when ``S`` is a multiple of 512. Same rate; the
frame alignment of :class:`momu.encoders.bicor_vae.BiCoRVAE` works from the actual counts.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import torch
import torch.nn.functional as F
from einops import rearrange

from momu.encoders.vae import SequenceVAE, VAE1dConfig
from momu.registry import ENCODERS

__all__ = ["WaveformVAEConfig", "WaveformVAE", "build_waveform_vae"]


@dataclass
class WaveformVAEConfig:
    """Attributes:
    sample_rate: waveform sample rate in Hz (MoMu App. B.2: 16 kHz; recorded, inputs must match).
    hop_length: samples folded into one step; 256 = the mel hop, so the latent rate equals the mel VAE's.
    vae: the Table 8 network after the folding.
    """

    sample_rate: int = 16000
    hop_length: int = 256
    vae: VAE1dConfig = field(default_factory=VAE1dConfig)


class WaveformVAE(SequenceVAE):
    """Music VAE on mono waveforms ``(B, S)`` in [-1, 1] -> latents ``(B, ceil(S / (hop * ds)), d)``."""

    modality = "music"
    input_kind = "waveform"

    def __init__(self, cfg: WaveformVAEConfig | None = None) -> None:
        cfg = cfg or WaveformVAEConfig()
        if cfg.hop_length < 1 or cfg.sample_rate < 1:
            raise ValueError(
                f"waveform: hop_length and sample_rate must be >= 1, got {cfg.hop_length}, {cfg.sample_rate}"
            )
        super().__init__(cfg.hop_length, cfg.vae, frames_per_step=cfg.hop_length)
        self.hop_length = cfg.hop_length
        self.sample_rate = cfg.sample_rate

    @property
    def latent_rate(self) -> float:
        """Latent frames per second."""
        return self.sample_rate / self.frames_per_latent

    def input_length(self, x: torch.Tensor) -> int:
        if x.ndim != 2:
            raise ValueError(f"waveform must be (B, S), got {tuple(x.shape)}")
        return int(x.shape[-1])

    def to_channels(self, rep: torch.Tensor) -> torch.Tensor:
        self.input_length(rep)
        extra = (-rep.shape[-1]) % self.hop_length
        if extra:
            rep = F.pad(rep, (0, extra))  # silence after the end
        return rearrange(rep, "b (t h) -> b h t", h=self.hop_length)

    def from_channels(self, y: torch.Tensor, length: int) -> torch.Tensor:
        return rearrange(y, "b h t -> b (t h)")[:, :length]


@ENCODERS.register("waveform", config=WaveformVAEConfig)
def build_waveform_vae(cfg: WaveformVAEConfig) -> WaveformVAE:
    """Registry factory: the raw-waveform music VAE of MoMu Table 7 #2."""
    return WaveformVAE(cfg)
