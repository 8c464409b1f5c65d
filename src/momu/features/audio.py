"""Audio features of the three papers: log-mel spectrograms, MFCC, onsets and waveform framing.

Every extractor takes a mono waveform ``(S,)`` (float, in [-1, 1]) and its sample rate in Hz,
resamples it to the config's ``sample_rate`` when they differ (``librosa.resample``, soxr HQ),
and returns ``float32`` arrays laid out like librosa: ``(channels, frames)``.

* :func:`momu_mel` — MoMu-Diffusion App. B.2: 16 kHz, 80 mel filters, ``n_fft`` 1024, hop 256,
  Hann window of 1024 → 62.5 frames/s. Log compression follows the BigVGAN/HiFi-GAN convention
  (``ln(max(|STFT|·M, 1e-5))``, magnitude not power, Slaney mel), because MoMu decodes its mels with
  BigVGAN (App. A); the paper does not state it.
* :func:`mofusion_mel` — MoFusion §4 ("Music-to-Dance Synthesis"): 16 kHz, 80 mel bands, hop 512,
  fmin 0, fmax 8 kHz. The paper says *m = 32 frames for one second*; 16000 / 512 = 31.25 frames/s,
  and a centred STFT of exactly one second has ``1 + 16000 // 512 = 32`` frames — that is where the 32
  comes from. We keep hop 512 (31.25 frames/s, ``1 + S // 512`` frames for ``S`` samples) and do not
  resample the time axis. ``n_fft`` is not given; we use librosa's default 2048. Log-mel is
  ``10·log10(max(power, 1e-10))`` (``librosa.power_to_db``, ref 1, no ``top_db``).
* :func:`mfcc` — MFCCs (HarmoGAN §IV-B audio input, Dancing2Music/BHS audio features), librosa's
  definition: DCT-II (orthonormal) of ``power_to_db(mel power, top_db=80)``.
* :func:`onset_envelope`, :func:`onset_times`, :func:`onset_beats` — librosa onset strength and peak
  picking with the parameters MoMu quotes (App. B.4, from LORIS):
  ``onset_detect(y, sr=22050, wait=1, delta=0.2, pre_avg=3, post_avg=3, pre_max=3, post_max=3,
  units='time')``; :func:`onset_beats` adds the strength at each onset (HarmoGAN §III-C audio saliency).
* :func:`frame_waveform` — raw-waveform framing for the waveform-VAE ablation (MoMu Table 7 #2).

:class:`MelSpectrogram` (in :mod:`momu.features.audio_torch`) is the batched torch version of
:func:`log_mel` that runs on GPU and matches it to float tolerance.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import librosa
import numpy as np
import torch

__all__ = [
    "MelConfig",
    "MoMuMelConfig",
    "MoFusionMelConfig",
    "MfccConfig",
    "OnsetConfig",
    "check_waveform",
    "resample",
    "mel_filterbank",
    "log_mel",
    "momu_mel",
    "mofusion_mel",
    "mel_to_power",
    "num_frames",
    "frame_rate",
    "mfcc",
    "onset_envelope",
    "onset_times",
    "onset_beats",
    "frame_waveform",
]

_LOG_MODES = ("ln", "db", "none")


@dataclass
class MelConfig:
    """Parameters of a (log-)mel spectrogram; every field is a config field.

    Attributes:
        sample_rate: rate (Hz) the waveform is resampled to before analysis.
        n_fft: FFT size in samples.
        hop_length: hop between frames in samples (frame rate = ``sample_rate / hop_length``).
        win_length: analysis window length in samples (``None``: ``n_fft``).
        window: window name for ``scipy.signal.get_window`` (periodic); ``"hann"`` in every paper.
        n_mels: number of mel filters (output channels).
        fmin: lowest filter edge in Hz.
        fmax: highest filter edge in Hz (``None``: ``sample_rate / 2``).
        power: exponent of the STFT magnitude before the filterbank (1 = magnitude, 2 = power).
        center: pad the signal by ``n_fft // 2`` on both sides so frame ``t`` is centred on sample
            ``t·hop_length`` (librosa's default); frames = ``1 + S // hop_length``.
        pad_mode: padding mode when ``center`` (librosa ≥ 0.10 default ``"constant"`` = zeros).
        mel_norm: ``"slaney"`` (area-normalised filters, librosa default) or ``"none"``.
        htk: HTK mel scale instead of Slaney's.
        log: ``"ln"``: ``ln(max(x, log_floor))``; ``"db"``: ``10·log10(max(x, log_floor))``
            (``librosa.power_to_db`` with ref 1); ``"none"``: no compression.
        log_floor: the clamp before the log (``1e-5`` BigVGAN convention; ``1e-10`` librosa's amin).
        top_db: with ``log="db"``, clip values below ``max − top_db`` (``None``: no clipping).
    """

    sample_rate: int = 16000
    n_fft: int = 1024
    hop_length: int = 256
    win_length: int | None = None
    window: str = "hann"
    n_mels: int = 80
    fmin: float = 0.0
    fmax: float | None = None
    power: float = 1.0
    center: bool = True
    pad_mode: str = "constant"
    mel_norm: str = "slaney"
    htk: bool = False
    log: str = "ln"
    log_floor: float = 1e-5
    top_db: float | None = None

    def __post_init__(self) -> None:
        self.validate()

    def validate(self) -> None:
        """Raise ``ValueError`` naming the first inconsistent field."""
        if self.sample_rate <= 0:
            raise ValueError(f"MelConfig.sample_rate must be positive, got {self.sample_rate}")
        if self.n_fft <= 0 or self.hop_length <= 0 or self.n_mels <= 0:
            raise ValueError(
                f"MelConfig: n_fft, hop_length and n_mels must be positive, got "
                f"{self.n_fft}, {self.hop_length}, {self.n_mels}"
            )
        if self.win_length is not None and not 0 < self.win_length <= self.n_fft:
            raise ValueError(
                f"MelConfig.win_length must be in (0, n_fft={self.n_fft}], got {self.win_length}"
            )
        top = self.sample_rate / 2 if self.fmax is None else self.fmax
        if not 0 <= self.fmin < top <= self.sample_rate / 2:
            raise ValueError(
                f"MelConfig: need 0 <= fmin < fmax <= sample_rate/2, got fmin={self.fmin}, fmax={self.fmax} "
                f"at sample_rate={self.sample_rate}"
            )
        if self.power <= 0:
            raise ValueError(f"MelConfig.power must be positive, got {self.power}")
        if self.log not in _LOG_MODES:
            raise ValueError(f"MelConfig.log must be one of {_LOG_MODES}, got {self.log!r}")
        if self.log_floor <= 0:
            raise ValueError(f"MelConfig.log_floor must be positive, got {self.log_floor}")
        if self.mel_norm not in ("slaney", "none"):
            raise ValueError(f"MelConfig.mel_norm must be 'slaney' or 'none', got {self.mel_norm!r}")
        if self.top_db is not None and self.top_db < 0:
            raise ValueError(f"MelConfig.top_db must be non-negative, got {self.top_db}")

    @property
    def frame_rate(self) -> float:
        """Frames per second (``sample_rate / hop_length``)."""
        return self.sample_rate / self.hop_length


@dataclass
class MoMuMelConfig(MelConfig):
    """MoMu-Diffusion App. B.2: 16 kHz, 80 filters, n_fft 1024, hop 256, Hann 1024; 62.5 frames/s."""


@dataclass
class MoFusionMelConfig(MelConfig):
    """MoFusion §4: 16 kHz, 80 bands, hop 512, fmin 0, fmax 8 kHz (31.25 frames/s; 32 frames per second
    of audio with a centred STFT), log-mel in dB of the power spectrogram; n_fft (unstated) = 2048."""

    n_fft: int = 2048
    hop_length: int = 512
    fmax: float | None = 8000.0
    power: float = 2.0
    log: str = "db"
    log_floor: float = 1e-10


@dataclass
class MfccConfig:
    """MFCC parameters (librosa's ``feature.mfcc`` definition).

    Attributes:
        sample_rate: analysis rate in Hz (waveforms are resampled to it).
        n_mfcc: number of coefficients (output channels).
        n_mels: mel filters before the DCT.
        n_fft: FFT size in samples.
        hop_length: hop in samples; ignored when ``frame_rate`` is set.
        frame_rate: if set, ``hop_length = round(sample_rate / frame_rate)`` so MFCC frames line up
            with motion frames (e.g. 25 fps for Dance with Melody → hop 640 at 16 kHz).
        fmin / fmax: filterbank range in Hz (``fmax=None``: Nyquist).
        top_db: dynamic range of the dB mel before the DCT (librosa's 80).
        lifter: cepstral liftering coefficient (0 = none).
    """

    sample_rate: int = 16000
    n_mfcc: int = 20
    n_mels: int = 128
    n_fft: int = 2048
    hop_length: int = 512
    frame_rate: float | None = None
    fmin: float = 0.0
    fmax: float | None = None
    top_db: float | None = 80.0
    lifter: float = 0.0

    def __post_init__(self) -> None:
        if self.sample_rate <= 0 or self.n_mfcc <= 0 or self.n_mels <= 0 or self.n_fft <= 0:
            raise ValueError(
                "MfccConfig: sample_rate, n_mfcc, n_mels and n_fft must be positive, got "
                f"{self.sample_rate}, {self.n_mfcc}, {self.n_mels}, {self.n_fft}"
            )
        if self.n_mfcc > self.n_mels:
            raise ValueError(f"MfccConfig.n_mfcc ({self.n_mfcc}) cannot exceed n_mels ({self.n_mels})")
        if self.frame_rate is not None and not 0 < self.frame_rate <= self.sample_rate:
            raise ValueError(f"MfccConfig.frame_rate must be in (0, sample_rate], got {self.frame_rate}")
        if self.hop_length <= 0:
            raise ValueError(f"MfccConfig.hop_length must be positive, got {self.hop_length}")
        if self.lifter < 0:
            raise ValueError(f"MfccConfig.lifter must be non-negative, got {self.lifter}")

    @property
    def hop(self) -> int:
        """The hop actually used, in samples."""
        if self.frame_rate is not None:
            return max(1, int(round(self.sample_rate / self.frame_rate)))
        return self.hop_length

    def mel_config(self) -> MelConfig:
        """The power-mel front end of these MFCCs (dB, ``top_db``) as a :class:`MelConfig`."""
        return MelConfig(
            sample_rate=self.sample_rate,
            n_fft=self.n_fft,
            hop_length=self.hop,
            n_mels=self.n_mels,
            fmin=self.fmin,
            fmax=self.fmax,
            power=2.0,
            log="db",
            log_floor=1e-10,
            top_db=self.top_db,
        )


@dataclass
class OnsetConfig:
    """Onset strength and peak picking; defaults are the call MoMu App. B.4 quotes (LORIS' metric):
    ``onset_detect(y, sr=22050, wait=1, delta=0.2, pre_avg=3, post_avg=3, pre_max=3, post_max=3)``.

    Window sizes are in onset-envelope frames (``hop_length / sample_rate`` s each, 23.2 ms by default).
    ``normalize``: librosa min-max normalises the envelope before peak picking (its default).
    """

    sample_rate: int = 22050
    hop_length: int = 512
    wait: int = 1
    delta: float = 0.2
    pre_avg: int = 3
    post_avg: int = 3
    pre_max: int = 3
    post_max: int = 3
    normalize: bool = True
    backtrack: bool = False

    def __post_init__(self) -> None:
        if self.sample_rate <= 0 or self.hop_length <= 0:
            raise ValueError(
                f"OnsetConfig: sample_rate and hop_length must be positive, got {self.sample_rate}, "
                f"{self.hop_length}"
            )
        for name in ("wait", "pre_avg", "post_avg", "pre_max", "post_max"):
            if getattr(self, name) < 0:
                raise ValueError(f"OnsetConfig.{name} must be non-negative, got {getattr(self, name)}")

    @property
    def frame_rate(self) -> float:
        """Onset-envelope frames per second."""
        return self.sample_rate / self.hop_length


# ---------------------------------------------------------------------------------------- helpers
def check_waveform(audio: Any, sr: int | float, *, name: str = "audio") -> np.ndarray:
    """Validate a mono waveform and return it as contiguous float32 ``(S,)``.

    Raises:
        ValueError: not 1-D (a ``(1, S)`` or ``(S, 1)`` array is squeezed), empty, non-finite values,
            or a non-positive sample rate.
    """
    if isinstance(audio, torch.Tensor):
        audio = audio.detach().cpu().numpy()
    x = np.asarray(audio)
    if x.ndim == 2 and 1 in x.shape:
        x = x.reshape(-1)
    if x.ndim != 1:
        raise ValueError(f"{name}: expected a mono waveform of shape (S,), got shape {x.shape}")
    if x.size == 0:
        raise ValueError(f"{name}: the waveform is empty")
    if not np.issubdtype(x.dtype, np.number):
        raise ValueError(f"{name}: expected numeric samples, got dtype {x.dtype}")
    if not np.all(np.isfinite(x)):
        bad = int(np.count_nonzero(~np.isfinite(x)))
        raise ValueError(f"{name}: {bad} non-finite sample(s) (NaN/inf) in the waveform")
    if not sr or sr <= 0:
        raise ValueError(f"{name}: sample rate must be positive, got {sr}")
    return np.ascontiguousarray(x, dtype=np.float32)


def resample(audio: np.ndarray, sr: int | float, target_sr: int | float) -> np.ndarray:
    """``audio`` at ``target_sr`` (soxr HQ through librosa); returned unchanged when rates match."""
    x = check_waveform(audio, sr)
    if int(sr) == int(target_sr):
        return x
    return librosa.resample(x, orig_sr=float(sr), target_sr=float(target_sr)).astype(np.float32)


def mel_filterbank(cfg: MelConfig) -> np.ndarray:
    """The ``(n_mels, 1 + n_fft // 2)`` float32 filterbank of ``cfg`` (``librosa.filters.mel``)."""
    return librosa.filters.mel(
        sr=cfg.sample_rate,
        n_fft=cfg.n_fft,
        n_mels=cfg.n_mels,
        fmin=cfg.fmin,
        fmax=cfg.fmax,
        htk=cfg.htk,
        norm="slaney" if cfg.mel_norm == "slaney" else None,
    ).astype(np.float32)


def num_frames(num_samples: int, cfg: MelConfig) -> int:
    """Frames :func:`log_mel` returns for ``num_samples`` samples at ``cfg.sample_rate``."""
    if cfg.center:
        return 1 + num_samples // cfg.hop_length
    return max(0, 1 + (num_samples - cfg.n_fft) // cfg.hop_length)


def frame_rate(cfg: MelConfig | MfccConfig | OnsetConfig) -> float:
    """Frames per second of a feature config."""
    if isinstance(cfg, MfccConfig):
        return cfg.sample_rate / cfg.hop
    return cfg.sample_rate / cfg.hop_length


def _compress(mel: np.ndarray, cfg: MelConfig) -> np.ndarray:
    if cfg.log == "ln":
        return np.log(np.maximum(mel, cfg.log_floor))
    if cfg.log == "db":
        out = 10.0 * np.log10(np.maximum(mel, cfg.log_floor))
        if cfg.top_db is not None:
            out = np.maximum(out, out.max() - cfg.top_db)
        return out
    return mel


def mel_to_power(logmel: np.ndarray, cfg: MelConfig) -> np.ndarray:
    """Undo the log compression of :func:`log_mel`: the mel-filtered ``|STFT|**cfg.power``.

    Values at the floor come back as ``log_floor`` (the clamp is not invertible below it).
    Vocoders (Griffin-Lim) use this before ``librosa.feature.inverse.mel_to_audio``.
    """
    x = np.asarray(logmel, dtype=np.float64)
    if cfg.log == "ln":
        return np.exp(x).astype(np.float32)
    if cfg.log == "db":
        return np.power(10.0, x / 10.0).astype(np.float32)
    return x.astype(np.float32)


# ---------------------------------------------------------------------------------------- mels
def log_mel(audio: np.ndarray, sr: int | float, cfg: MelConfig | None = None) -> np.ndarray:
    """Log-mel spectrogram ``(n_mels, frames)`` float32 of a mono waveform.

    ``audio`` is resampled from ``sr`` to ``cfg.sample_rate`` first. Frames are ``1 + S // hop``
    with ``cfg.center`` (``S`` = samples after resampling); frame ``t`` is centred at ``t·hop / sr`` s.
    """
    cfg = cfg or MoMuMelConfig()
    x = resample(audio, sr, cfg.sample_rate)
    spec = np.abs(
        librosa.stft(
            x,
            n_fft=cfg.n_fft,
            hop_length=cfg.hop_length,
            win_length=cfg.win_length,
            window=cfg.window,
            center=cfg.center,
            pad_mode=cfg.pad_mode,  # type: ignore[arg-type]
        )
    )
    if cfg.power != 1.0:
        spec = spec**cfg.power
    mel = mel_filterbank(cfg) @ spec
    return _compress(mel, cfg).astype(np.float32)


def momu_mel(audio: np.ndarray, sr: int | float, cfg: MelConfig | None = None) -> np.ndarray:
    """MoMu-Diffusion's mel (App. B.2): ``(80, 1 + S16k // 256)`` float32 log-mel at 62.5 frames/s."""
    return log_mel(audio, sr, cfg or MoMuMelConfig())


def mofusion_mel(audio: np.ndarray, sr: int | float, cfg: MelConfig | None = None) -> np.ndarray:
    """MoFusion's mel (§4): ``(80, 1 + S16k // 512)`` float32 dB log-mel, 31.25 frames/s (32 per 1 s)."""
    return log_mel(audio, sr, cfg or MoFusionMelConfig())


def mfcc(audio: np.ndarray, sr: int | float, cfg: MfccConfig | None = None) -> np.ndarray:
    """MFCCs ``(n_mfcc, frames)`` float32 (librosa ``feature.mfcc``: DCT-II ortho of the dB mel power).

    Used as HarmoGAN's audio input A_f (§IV-B) and as BHS/Dancing2Music-style audio features.
    """
    cfg = cfg or MfccConfig()
    db = log_mel(audio, sr, cfg.mel_config())  # dB mel power at cfg.sample_rate, top_db-clipped
    out = librosa.feature.mfcc(S=db, n_mfcc=cfg.n_mfcc, lifter=cfg.lifter)
    return out.astype(np.float32)


# ---------------------------------------------------------------------------------------- onsets
def onset_envelope(audio: np.ndarray, sr: int | float, cfg: OnsetConfig | None = None) -> np.ndarray:
    """librosa's onset strength ``(frames,)`` float32 at ``cfg.frame_rate`` frames/s (not normalised).

    Frame ``t`` is at ``t·hop_length / sample_rate`` s (``librosa.frames_to_time``).
    """
    cfg = cfg or OnsetConfig()
    x = resample(audio, sr, cfg.sample_rate)
    env = librosa.onset.onset_strength(y=x, sr=cfg.sample_rate, hop_length=cfg.hop_length)
    return env.astype(np.float32)


def _onset_frames(env: np.ndarray, cfg: OnsetConfig, audio: np.ndarray | None = None) -> np.ndarray:
    return np.asarray(
        librosa.onset.onset_detect(
            onset_envelope=env,
            sr=cfg.sample_rate,
            hop_length=cfg.hop_length,
            wait=cfg.wait,
            delta=cfg.delta,
            pre_avg=cfg.pre_avg,
            post_avg=cfg.post_avg,
            pre_max=cfg.pre_max,
            post_max=cfg.post_max,
            normalize=cfg.normalize,
            backtrack=False,
            units="frames",
        ),
        dtype=np.int64,
    )


def onset_times(audio: np.ndarray, sr: int | float, cfg: OnsetConfig | None = None) -> np.ndarray:
    """Onset times in seconds ``(N,)`` float64, ascending (MoMu App. B.4 / LORIS peak picking).

    Equivalent to ``librosa.onset.onset_detect(y, sr=cfg.sample_rate, ..., units='time')`` on the
    waveform resampled to ``cfg.sample_rate``.
    """
    return onset_beats(audio, sr, cfg)[0]


def onset_beats(
    audio: np.ndarray, sr: int | float, cfg: OnsetConfig | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Audio beats and their saliency (HarmoGAN §III-B/C): ``(times_s (N,), strength (N,))``.

    ``times_s`` are the onset times of :func:`onset_times`; ``strength`` is the (un-normalised)
    onset strength at each onset frame — HarmoGAN's audio beat saliency ``S_a``.
    """
    cfg = cfg or OnsetConfig()
    env = onset_envelope(audio, sr, cfg)
    frames = _onset_frames(env, cfg)
    if cfg.backtrack and frames.size:
        frames = np.asarray(librosa.onset.onset_backtrack(frames, env), dtype=np.int64)
    times = librosa.frames_to_time(frames, sr=cfg.sample_rate, hop_length=cfg.hop_length)
    return np.asarray(times, dtype=np.float64), env[frames].astype(np.float32)


# ---------------------------------------------------------------------------------------- waveform
def frame_waveform(
    audio: np.ndarray | torch.Tensor,
    frame_length: int = 256,
    hop_length: int | None = None,
    *,
    pad: bool = True,
) -> np.ndarray | torch.Tensor:
    """Cut a raw waveform into frames for the waveform-VAE ablation (MoMu Table 7 #2, "w/o mel").

    Args:
        audio: ``(S,)`` numpy/torch, or ``(B, S)`` torch waveform.
        frame_length: samples per frame (default 256 = MoMu's mel hop, so frame ``t`` covers the same
            16 ms as mel frame ``t`` at 16 kHz and the two representations have the same frame rate).
        hop_length: samples between frame starts (``None``: ``frame_length``, non-overlapping).
        pad: zero-pad the end so the last partial frame is kept (frames = ``ceil(S / hop)`` when
            ``hop == frame_length``); ``False`` drops it (frames = ``1 + (S - frame_length) // hop``).

    Returns:
        ``(frames, frame_length)`` (or ``(B, frames, frame_length)``), channels-last, same type as input.
    """
    hop = frame_length if hop_length is None else hop_length
    if frame_length <= 0 or hop <= 0:
        raise ValueError(
            f"frame_waveform: frame_length and hop_length must be positive, got {frame_length}, {hop}"
        )
    is_torch = isinstance(audio, torch.Tensor)
    x = audio if is_torch else torch.from_numpy(check_waveform(audio, 1))
    assert isinstance(x, torch.Tensor)
    if x.ndim not in (1, 2) or x.shape[-1] == 0:
        raise ValueError(f"frame_waveform: expected (S,) or (B, S) with S > 0, got shape {tuple(x.shape)}")
    length = x.shape[-1]
    if pad:
        n = max(1, -(-max(length - frame_length, 0) // hop) + 1)
        total = (n - 1) * hop + frame_length
        if total > length:
            x = torch.nn.functional.pad(x, (0, total - length))
    elif length < frame_length:
        raise ValueError(
            f"frame_waveform: waveform of {length} samples is shorter than one frame ({frame_length})"
        )
    frames = x.unfold(-1, frame_length, hop)
    if is_torch:
        return frames
    return frames.numpy().copy()
