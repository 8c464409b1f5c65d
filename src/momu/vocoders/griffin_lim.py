"""``griffin_lim``: the default vocoder — librosa's mel inversion with Griffin-Lim phase recovery.

The log-mel is decompressed with :func:`momu.features.audio.mel_to_power` and inverted with
:func:`librosa.feature.inverse.mel_to_audio` using exactly the STFT/filterbank parameters of the
:class:`~momu.features.audio.MelConfig` it was computed with (MoMu App. B.2 by default: 16 kHz,
80 bands, n_fft 1024, hop 256, Hann 1024), so no constant is repeated here. The mel inversion is
librosa's NNLS bit for bit, without SciPy's per-variable bound handling (:mod:`momu.vocoders.nnls`:
0.02 s instead of 0.7 s for a 4-s mel).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import librosa
import numpy as np

from momu.features.audio import MelConfig, MoMuMelConfig, mel_filterbank, mel_to_power
from momu.registry import VOCODERS
from momu.vocoders.nnls import nnls

__all__ = ["GriffinLimConfig", "GriffinLimVocoder", "build_griffin_lim", "as_mel_batch"]


@dataclass
class GriffinLimConfig:
    """Griffin-Lim vocoder.

    Attributes:
        mel: the mel-spectrogram parameters the input was computed with (default MoMu's).
        n_iter: Griffin-Lim iterations (librosa default 32).
        momentum: fast Griffin-Lim momentum (librosa default 0.99).
        random_phase: start from random phases (seeded by ``seed``) instead of zeros.
        seed: RNG seed for the random initial phase; item ``i`` of a batch uses ``seed + i`` (a
            batch of one item is the item alone).
        mel_inversion: how the mel power is mapped back to a linear-frequency magnitude, both
            solving ``min ‖M x − p‖², x ≥ 0`` per frame (``M`` the mel filterbank): ``librosa``
            (:func:`librosa.feature.inverse.mel_to_stft`, L-BFGS-B, run by
            :func:`momu.vocoders.nnls.nnls`) or ``multiplicative`` (Lee–Seung multiplicative
            updates from the clipped pseudo-inverse, all frames at once: a lower residual and the
            same onsets on synth_dance music, ``benchmarks/bench_mel_inversion.py``).
        inversion_iters: multiplicative updates (``mel_inversion: multiplicative``).
    """

    mel: MelConfig = field(default_factory=MoMuMelConfig)
    n_iter: int = 32
    momentum: float = 0.99
    random_phase: bool = True
    seed: int = 0
    mel_inversion: str = "librosa"
    inversion_iters: int = 10


def as_mel_batch(mel: Any, n_mels: int) -> tuple[np.ndarray, bool]:
    """``(B, n_mels, T)`` float32 array from a ``(n_mels, T)`` or ``(B, n_mels, T)`` array/tensor.

    Returns the batch and whether the input was a single spectrogram.
    """
    if hasattr(mel, "detach"):
        mel = mel.detach().cpu().numpy()
    arr = np.asarray(mel, dtype=np.float32)
    single = arr.ndim == 2
    if single:
        arr = arr[None]
    if arr.ndim != 3 or arr.shape[1] != n_mels or arr.shape[2] == 0:
        raise ValueError(f"mel: expected ({n_mels}, T) or (B, {n_mels}, T), got {tuple(np.shape(mel))}")
    if not np.isfinite(arr).all():
        raise ValueError("mel: contains NaN or infinite values")
    return arr, single


class GriffinLimVocoder:
    """Log-mel -> waveform by Griffin-Lim (vocoder protocol, docs/protocols.md).

    Attributes:
        sample_rate: output rate in Hz; ``hop_length``: samples per mel frame; ``n_mels``.
    """

    name = "griffin_lim"

    def __init__(self, cfg: GriffinLimConfig) -> None:
        if cfg.n_iter <= 0:
            raise ValueError(f"griffin_lim.n_iter must be positive, got {cfg.n_iter}")
        if not 0.0 <= cfg.momentum < 1.0 + 1e-9:
            raise ValueError(f"griffin_lim.momentum must be in [0, 1], got {cfg.momentum}")
        if cfg.mel_inversion not in ("librosa", "multiplicative"):
            raise ValueError(
                f"griffin_lim.mel_inversion must be 'librosa' or 'multiplicative', got {cfg.mel_inversion!r}"
            )
        if cfg.inversion_iters < 0:
            raise ValueError(f"griffin_lim.inversion_iters must be >= 0, got {cfg.inversion_iters}")
        cfg.mel.validate()
        self.cfg = cfg
        self.mel_cfg = cfg.mel
        self.sample_rate = int(cfg.mel.sample_rate)
        self.hop_length = int(cfg.mel.hop_length)
        self.n_mels = int(cfg.mel.n_mels)

    def num_samples(self, frames: int) -> int:
        """Waveform length for ``frames`` mel frames (the inverse of the STFT framing)."""
        if self.mel_cfg.center:  # frames = 1 + S // hop
            return (frames - 1) * self.hop_length
        return (frames - 1) * self.hop_length + self.mel_cfg.n_fft

    def synthesize(self, mel: Any) -> np.ndarray:
        """``(n_mels, T)`` -> ``(S,)`` or ``(B, n_mels, T)`` -> ``(B, S)`` float32 waveform in [-1, 1]."""
        batch, single = as_mel_batch(mel, self.n_mels)
        m = self.mel_cfg
        out = []
        for i, logmel in enumerate(batch):
            rng = np.random.default_rng(self.cfg.seed + i)
            power = mel_to_power(logmel, m)
            stft_mag = self.magnitude(power)
            wav = librosa.griffinlim(
                stft_mag,
                n_iter=self.cfg.n_iter,
                hop_length=m.hop_length,
                win_length=m.win_length,
                n_fft=m.n_fft,
                window=m.window,
                center=m.center,
                pad_mode=m.pad_mode,  # type: ignore[arg-type]
                momentum=self.cfg.momentum,
                init="random" if self.cfg.random_phase else None,
                random_state=rng,
                length=self.num_samples(logmel.shape[-1]),
            )
            out.append(np.clip(wav, -1.0, 1.0).astype(np.float32))
        stacked = np.stack(out)
        return stacked[0] if single else stacked

    __call__ = synthesize

    def magnitude(self, power: np.ndarray) -> np.ndarray:
        """``(n_mels, T)`` mel power -> ``(1 + n_fft // 2, T)`` STFT magnitude (non-negative lstsq)."""
        m = self.mel_cfg
        if self.cfg.mel_inversion == "librosa":  # librosa.feature.inverse.mel_to_stft on momu's filterbank
            inverse = nnls(mel_filterbank(m).astype(power.dtype), power)
            return np.power(inverse, 1.0 / m.power)
        basis = mel_filterbank(m).astype(np.float64)
        target = np.asarray(power, dtype=np.float64)
        # start: the pseudo-inverse clipped to a small positive floor (a zero never moves under
        # multiplicative updates), then x <- x * Mᵀp / MᵀMx, which never increases ‖Mx − p‖²
        floor = 1e-10 * max(float(target.max()), 1e-30)
        x = np.maximum(np.linalg.pinv(basis) @ target, floor)
        numerator, gram = basis.T @ target, basis.T @ basis
        for _ in range(self.cfg.inversion_iters):
            x *= numerator / np.maximum(gram @ x, 1e-30)
        return np.power(x, 1.0 / m.power).astype(np.float32)


@VOCODERS.register("griffin_lim", config=GriffinLimConfig)
def build_griffin_lim(cfg: GriffinLimConfig, **deps: Any) -> GriffinLimVocoder:
    """Build the Griffin-Lim vocoder for ``cfg.mel`` (default MoMu's mel)."""
    return GriffinLimVocoder(cfg)
