"""Torch front ends that run batched on GPU and match :mod:`momu.features.audio` (librosa) to float tolerance.

* :class:`MelSpectrogram` — :func:`momu.features.audio.log_mel` for ``(B, S)`` waveforms.
* :class:`Mfcc` — :func:`momu.features.audio.mfcc` (DCT-II ortho of the dB mel power).

Both take waveforms already at the config's ``sample_rate`` (resampling is a data-loading step).
The mel filterbank is librosa's (built once with ``librosa.filters.mel``, stored as a buffer) and the
window is the periodic Hann window librosa uses, so the only differences are float32 FFT rounding.
"""

from __future__ import annotations

import math

import numpy as np
import torch
from torch import nn

from momu.features.audio import MelConfig, MfccConfig, MoMuMelConfig, mel_filterbank

__all__ = ["MelSpectrogram", "Mfcc", "power_to_db", "dct_matrix"]


def _as_batch(waveform: torch.Tensor, name: str) -> tuple[torch.Tensor, bool]:
    if not isinstance(waveform, torch.Tensor):
        raise TypeError(f"{name}: expected a torch.Tensor waveform, got {type(waveform).__name__}")
    if waveform.ndim == 1:
        return waveform.unsqueeze(0), True
    if waveform.ndim == 3 and waveform.shape[1] == 1:
        return waveform[:, 0], False
    if waveform.ndim != 2:
        raise ValueError(
            f"{name}: expected a waveform of shape (S,), (B, S) or (B, 1, S), got {tuple(waveform.shape)}"
        )
    return waveform, False


def power_to_db(x: torch.Tensor, amin: float = 1e-10, top_db: float | None = 80.0) -> torch.Tensor:
    """``10·log10(max(x, amin))`` with ``top_db`` clipping per batch item (``librosa.power_to_db``, ref 1).

    ``x``: ``(B, ...)``; the maximum for ``top_db`` is taken over everything but the batch axis.
    """
    db = 10.0 * torch.log10(torch.clamp(x, min=amin))
    if top_db is not None:
        peak = db.flatten(1).amax(dim=1).view(-1, *([1] * (db.ndim - 1)))
        db = torch.maximum(db, peak - top_db)
    return db


def dct_matrix(n_in: int, n_out: int) -> torch.Tensor:
    """Orthonormal DCT-II basis ``(n_out, n_in)`` (``scipy.fft.dct(type=2, norm='ortho')`` rows)."""
    k = torch.arange(n_out, dtype=torch.float64)[:, None]
    n = torch.arange(n_in, dtype=torch.float64)[None, :]
    basis = torch.cos(math.pi / n_in * (n + 0.5) * k) * math.sqrt(2.0 / n_in)
    basis[0] /= math.sqrt(2.0)
    return basis.float()


class MelSpectrogram(nn.Module):
    """Batched log-mel spectrogram matching :func:`momu.features.audio.log_mel` (librosa).

    Args:
        cfg: a :class:`~momu.features.audio.MelConfig` (default: MoMu's, App. B.2).

    Input ``(B, S)`` (or ``(S,)``, ``(B, 1, S)``) float waveform at ``cfg.sample_rate``; output
    ``(B, n_mels, 1 + S // hop)`` float32 (``(n_mels, frames)`` for 1-D input), channel-first like
    librosa. Differentiable w.r.t. the waveform; runs on the module's device.
    """

    window: torch.Tensor
    mel_basis: torch.Tensor

    def __init__(self, cfg: MelConfig | None = None) -> None:
        super().__init__()
        self.cfg = cfg or MoMuMelConfig()
        self.cfg.validate()
        win_length = self.cfg.win_length or self.cfg.n_fft
        if self.cfg.window != "hann":
            import librosa

            win = torch.from_numpy(
                np.asarray(librosa.filters.get_window(self.cfg.window, win_length, fftbins=True))
            )
        else:
            win = torch.hann_window(win_length, periodic=True, dtype=torch.float64)
        self.register_buffer("window", win.float(), persistent=False)
        self.register_buffer("mel_basis", torch.from_numpy(mel_filterbank(self.cfg)), persistent=False)

    @property
    def n_mels(self) -> int:
        return self.cfg.n_mels

    @property
    def frame_rate(self) -> float:
        """Output frames per second."""
        return self.cfg.sample_rate / self.cfg.hop_length

    def mel_power(self, waveform: torch.Tensor) -> torch.Tensor:
        """Mel-filtered ``|STFT|**power`` before compression: ``(B, n_mels, frames)``."""
        x, _ = _as_batch(waveform, "MelSpectrogram")
        cfg = self.cfg
        x = x.to(self.window.dtype)
        if cfg.center:
            pad = cfg.n_fft // 2
            if x.shape[-1] <= pad and cfg.pad_mode == "reflect":
                raise ValueError(f"MelSpectrogram: {x.shape[-1]} samples are too short for reflect padding")
            x = nn.functional.pad(x.unsqueeze(1), (pad, pad), mode=cfg.pad_mode).squeeze(1)
        if x.shape[-1] < cfg.n_fft:
            raise ValueError(
                f"MelSpectrogram: waveform of {x.shape[-1]} samples is shorter than n_fft={cfg.n_fft}"
            )
        spec = torch.stft(
            x,
            n_fft=cfg.n_fft,
            hop_length=cfg.hop_length,
            win_length=self.window.shape[0],
            window=self.window,
            center=False,
            return_complex=True,
        ).abs()  # (B, 1 + n_fft // 2, frames)
        if cfg.power != 1.0:
            spec = spec**cfg.power
        return torch.matmul(self.mel_basis, spec)

    def forward(self, waveform: torch.Tensor) -> torch.Tensor:
        _, squeeze = _as_batch(waveform, "MelSpectrogram")
        mel = self.mel_power(waveform)
        cfg = self.cfg
        if cfg.log == "ln":
            out = torch.log(torch.clamp(mel, min=cfg.log_floor))
        elif cfg.log == "db":
            out = power_to_db(mel, amin=cfg.log_floor, top_db=cfg.top_db)
        else:
            out = mel
        return out[0] if squeeze else out


class Mfcc(nn.Module):
    """Batched MFCCs matching :func:`momu.features.audio.mfcc` (librosa ``feature.mfcc``).

    Input ``(B, S)`` waveform at ``cfg.sample_rate``; output ``(B, n_mfcc, frames)`` float32
    (``channels_last=True``: ``(B, frames, n_mfcc)``).
    """

    dct: torch.Tensor
    lift: torch.Tensor

    def __init__(self, cfg: MfccConfig | None = None, *, channels_last: bool = False) -> None:
        super().__init__()
        self.cfg = cfg or MfccConfig()
        self.channels_last = channels_last
        self.mel = MelSpectrogram(self.cfg.mel_config())
        self.register_buffer("dct", dct_matrix(self.cfg.n_mels, self.cfg.n_mfcc), persistent=False)
        n = torch.arange(1, self.cfg.n_mfcc + 1, dtype=torch.float64)
        lift = (
            1 + (self.cfg.lifter / 2) * torch.sin(math.pi * n / self.cfg.lifter)
            if self.cfg.lifter > 0
            else n * 0 + 1
        )
        self.register_buffer("lift", lift.float()[:, None], persistent=False)

    @property
    def out_channels(self) -> int:
        return self.cfg.n_mfcc

    @property
    def frame_rate(self) -> float:
        """Output frames per second (the mel front end's: ``sample_rate / hop``)."""
        return self.mel.frame_rate

    def forward(self, waveform: torch.Tensor) -> torch.Tensor:
        _, squeeze = _as_batch(waveform, "Mfcc")
        db = self.mel(waveform.unsqueeze(0) if squeeze else waveform)  # (B, n_mels, T)
        out = torch.matmul(self.dct, db) * self.lift  # (B, n_mfcc, T)
        if self.channels_last:
            out = out.transpose(1, 2)
        return out[0] if squeeze else out
