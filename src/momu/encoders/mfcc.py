"""The ``mfcc`` encoder: MFCC audio features from waveforms (HarmoGAN §IV-B, BHS/Dancing2Music).

HarmoGAN feeds MFCCs of the audio ``A`` to its audio encoder ("We derive the Mel Frequency Cepstral
Coefficients (MFCCs) from A as the auditory feature input A_f"); the BHS Dance data MoMu uses ships
only MFCC-style audio features. This encoder is fixed (no learned parameters): it maps a batch of
waveforms at ``sample_rate`` to channels-last MFCC sequences, on the input's device, matching
librosa's ``feature.mfcc`` (:func:`momu.features.audio.mfcc`) to float tolerance.

Set ``frame_rate`` to the motion frame rate (e.g. 25 fps for Dance with Melody) so that MFCC frame
``t`` lines up with motion frame ``t``.

As another method's condition features (docs/protocols.md, "Condition features"):
:meth:`MfccEncoder.track` computes the MFCCs of a whole song once (numpy, librosa), and
:meth:`MfccTrack.features` cuts any span of it at any frame rate (each output frame the mean of the
MFCC frames it covers) — so MoMu can condition its music→motion denoiser on HarmoGAN's audio features
(``method.motion_condition: {name: mfcc, normalize: true}``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch
from torch import nn

from momu.features.audio import MfccConfig, mfcc
from momu.features.audio_torch import Mfcc
from momu.registry import ENCODERS

__all__ = ["MfccEncoderConfig", "MfccEncoder", "MfccTrack", "build_mfcc"]


@dataclass
class MfccEncoderConfig(MfccConfig):
    """:class:`~momu.features.audio.MfccConfig` plus ``normalize`` (per-coefficient standardisation
    over each clip's frames, off by default).

    Defaults: 16 kHz, 20 coefficients, 128 mel filters, n_fft 2048, hop 512 (31.25 frames/s)
    unless ``frame_rate`` is set. HarmoGAN gives no MFCC parameters; these are librosa's defaults at 16 kHz.
    """

    normalize: bool = False


class MfccEncoder(nn.Module):
    """Waveforms ``(B, S)`` (or ``(B, 1, S)``) → MFCCs ``(B, T, n_mfcc)``, ``T = 1 + S // hop``.

    Attributes:
        out_channels: ``n_mfcc``. frame_rate: output frames per second. sample_rate: expected input rate.
    """

    def __init__(self, cfg: MfccEncoderConfig | None = None) -> None:
        super().__init__()
        self.cfg = cfg or MfccEncoderConfig()
        self.mfcc = Mfcc(self.cfg, channels_last=True)

    @property
    def out_channels(self) -> int:
        return self.mfcc.out_channels

    @property
    def frame_rate(self) -> float:
        return self.mfcc.frame_rate

    @property
    def sample_rate(self) -> int:
        return self.cfg.sample_rate

    def num_frames(self, num_samples: int) -> int:
        """Output frames for ``num_samples`` input samples."""
        return 1 + num_samples // self.cfg.hop

    def forward(self, waveform: torch.Tensor) -> torch.Tensor:
        if waveform.ndim == 1:
            raise ValueError("MfccEncoder: expected a batch of waveforms (B, S) or (B, 1, S), got shape (S,)")
        out = self.mfcc(waveform)  # (B, T, n_mfcc)
        if self.cfg.normalize:
            mean = out.mean(dim=1, keepdim=True)
            std = out.std(dim=1, keepdim=True, unbiased=False).clamp_min(1e-5)
            out = (out - mean) / std
        return out

    def encode(self, waveform: torch.Tensor) -> torch.Tensor:
        """Alias of :meth:`forward`."""
        return self(waveform)

    def track(self, audio: np.ndarray, sample_rate: float) -> MfccTrack:
        """The MFCCs of a whole mono waveform (standardised per coefficient over it with ``normalize``)."""
        coeffs = mfcc(np.asarray(audio, dtype=np.float32).reshape(-1), sample_rate, self.cfg).T  # (T, C)
        coeffs = coeffs.astype(np.float64)
        if self.cfg.normalize:
            coeffs = (coeffs - coeffs.mean(axis=0)) / np.maximum(coeffs.std(axis=0), 1e-5)
        return MfccTrack(coeffs, float(self.frame_rate))


@dataclass(frozen=True)
class MfccTrack:
    """A song's MFCCs ``(T, n_mfcc)`` at ``rate`` frames/s; :meth:`features` cuts any span."""

    coeffs: np.ndarray
    rate: float

    def features(self, frames: int, frame_rate: float, start: float = 0.0) -> np.ndarray:
        """``(frames, n_mfcc)``: each output frame from ``start`` seconds the mean of the MFCC frames it
        covers (at least one; frames past the song's end repeat its last frame)."""
        n = self.coeffs.shape[0]
        out = np.zeros((frames, self.coeffs.shape[1]), dtype=np.float32)
        if n == 0:
            return out
        edges = np.round((start + np.arange(frames + 1) / frame_rate) * self.rate).astype(int)
        edges = np.clip(edges, 0, n - 1)
        for k in range(frames):
            a, b = edges[k], max(edges[k + 1], edges[k] + 1)
            out[k] = self.coeffs[a:b].mean(axis=0)
        return out


@ENCODERS.register("mfcc", config=MfccEncoderConfig)
def build_mfcc(cfg: MfccEncoderConfig, **deps: object) -> MfccEncoder:
    """Factory of the ``mfcc`` encoder."""
    return MfccEncoder(cfg)
