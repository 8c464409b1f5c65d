"""VGGish (Hershey et al., ICASSP 2017): the audio embedding behind FAD, with user-provided weights.

MoMu-Diffusion computes FAD and music Diversity with "the pre-trained VGGish model from
https://github.com/gudgud96/frechet-audio-distance" (MoMu App. B.4). That package loads
``torch.hub.load('harritaylor/torchvggish', 'vggish')``, disables the PCA post-processing
(``use_pca=False``) and drops the final ReLU of the embedding MLP (``use_activation=False``); it then
concatenates the 128-d embeddings of every 0.96 s example of every file. This module rebuilds that
network and its input pipeline without any download:

* :func:`vggish_examples` — the VGGish front end (``vggish_input.waveform_to_examples`` /
  ``mel_features.log_mel_spectrogram``): mono, resampled to 16 kHz, 25 ms periodic-Hann frames with a
  10 ms hop (no centring/padding), magnitude ``|rfft|`` with 512 points, 64 HTK-mel bands from
  125 Hz to 7500 Hz built the VGGish way (triangles in mel space over the FFT bins' mel values, DC
  bin zeroed), ``log(mel + 0.01)``, framed into non-overlapping ``96 × 64`` examples (0.96 s);
  a trailing partial example is dropped. Resampling uses soxr HQ (``momu.features.audio.resample``)
  where the original uses resampy — the only deviation, audible only at the resampler's edge band.
* :class:`VGGish` — the VGG-style network with the exact module names of ``torchvggish`` (``features.*``,
  ``embeddings.*``), so that the released ``vggish-10086976.pth`` state dict loads strictly.
* :func:`load_vggish` — weights from a LOCAL file only: a safetensors state dict, or a torch ``.pt``/
  ``.pth`` read with ``torch.load(weights_only=True)`` (no arbitrary unpickling). ``pproc.*`` PCA
  parameters found in a whole-model state dict are ignored (PCA is off in FAD).
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import torch
from torch import nn

from momu.features.audio import check_waveform, resample

__all__ = [
    "VGGISH_SAMPLE_RATE",
    "VGGishConfig",
    "VGGish",
    "vggish_mel_matrix",
    "vggish_log_mel",
    "vggish_examples",
    "load_state_dict_file",
    "load_vggish",
]

logger = logging.getLogger(__name__)

# vggish_params.py
VGGISH_SAMPLE_RATE = 16000
_WINDOW_SECONDS = 0.025
_HOP_SECONDS = 0.010
_NUM_BANDS = 64
_MEL_MIN_HZ = 125.0
_MEL_MAX_HZ = 7500.0
_LOG_OFFSET = 0.01
_EXAMPLE_SECONDS = 0.96
_EMBEDDING_SIZE = 128


@dataclass
class VGGishConfig:
    """Options of the VGGish embedding.

    Attributes:
        use_activation: keep the ReLU after the last embedding layer (FAD's default drops it:
            gudgud96 ``use_activation=False``).
    """

    use_activation: bool = False


def _hertz_to_mel(hz: np.ndarray | float) -> np.ndarray:
    """HTK mel scale as in ``mel_features.hertz_to_mel``: ``1127 ln(1 + f / 700)``."""
    return 1127.0 * np.log(1.0 + np.asarray(hz, dtype=np.float64) / 700.0)


def vggish_mel_matrix(num_spectrogram_bins: int = 257, sample_rate: int = VGGISH_SAMPLE_RATE) -> np.ndarray:
    """``(num_spectrogram_bins, 64)`` mel weights of ``mel_features.spectrogram_to_mel_matrix``."""
    nyquist = sample_rate / 2.0
    bins_mel = _hertz_to_mel(np.linspace(0.0, nyquist, num_spectrogram_bins))
    edges = np.linspace(_hertz_to_mel(_MEL_MIN_HZ), _hertz_to_mel(_MEL_MAX_HZ), _NUM_BANDS + 2)
    lower, center, upper = edges[:-2], edges[1:-1], edges[2:]  # (64,) each
    lower_slope = (bins_mel[:, None] - lower) / (center - lower)
    upper_slope = (upper - bins_mel[:, None]) / (upper - center)
    weights = np.maximum(0.0, np.minimum(lower_slope, upper_slope))
    weights[0, :] = 0.0  # the DC bin carries no mel energy
    return weights


def vggish_log_mel(audio: np.ndarray, sample_rate: int | float) -> np.ndarray:
    """VGGish log-mel spectrogram ``(frames, 64)`` float64 at 100 frames/s (see module docstring)."""
    x = resample(check_waveform(audio, sample_rate), sample_rate, VGGISH_SAMPLE_RATE).astype(np.float64)
    window = int(round(VGGISH_SAMPLE_RATE * _WINDOW_SECONDS))  # 400
    hop = int(round(VGGISH_SAMPLE_RATE * _HOP_SECONDS))  # 160
    fft_length = 2 ** int(np.ceil(np.log(window) / np.log(2.0)))  # 512
    if x.shape[0] < window:
        return np.zeros((0, _NUM_BANDS))
    num_frames = 1 + (x.shape[0] - window) // hop
    frames = np.lib.stride_tricks.as_strided(
        x, shape=(num_frames, window), strides=(x.strides[0] * hop, x.strides[0]), writeable=False
    )
    periodic_hann = 0.5 - 0.5 * np.cos(2 * np.pi / window * np.arange(window))
    magnitude = np.abs(np.fft.rfft(frames * periodic_hann, fft_length))  # (frames, 257)
    mel = magnitude @ vggish_mel_matrix(magnitude.shape[1])
    return np.log(mel + _LOG_OFFSET)


def vggish_examples(audio: np.ndarray, sample_rate: int | float) -> np.ndarray:
    """Waveform → VGGish input examples ``(N, 96, 64)`` float32 (non-overlapping 0.96 s patches).

    ``N = floor((frames − 96) / 96) + 1`` (0 when the audio is shorter than 0.985 s).
    """
    log_mel = vggish_log_mel(audio, sample_rate)
    length = int(round(_EXAMPLE_SECONDS / _HOP_SECONDS))  # 96 frames
    n = 0 if log_mel.shape[0] < length else 1 + (log_mel.shape[0] - length) // length
    return log_mel[: n * length].reshape(n, length, _NUM_BANDS).astype(np.float32)


def _make_layers() -> nn.Sequential:
    layers: list[nn.Module] = []
    in_channels = 1
    for v in (64, "M", 128, "M", 256, 256, "M", 512, 512, "M"):
        if v == "M":
            layers.append(nn.MaxPool2d(kernel_size=2, stride=2))
        else:
            assert isinstance(v, int)
            layers += [nn.Conv2d(in_channels, v, kernel_size=3, padding=1), nn.ReLU(inplace=True)]
            in_channels = v
    return nn.Sequential(*layers)


class VGGish(nn.Module):
    """The VGGish network: ``(N, 1, 96, 64)`` log-mel examples → ``(N, 128)`` embeddings.

    Module names match ``torchvggish.vggish.VGG`` so its released weights load strictly.
    """

    def __init__(self, cfg: VGGishConfig | None = None) -> None:
        super().__init__()
        self.cfg = cfg or VGGishConfig()
        self.features = _make_layers()
        self.embeddings = nn.Sequential(
            nn.Linear(512 * 4 * 6, 4096),
            nn.ReLU(True),
            nn.Linear(4096, 4096),
            nn.ReLU(True),
            nn.Linear(4096, _EMBEDDING_SIZE),
            nn.ReLU(True),
        )

    @property
    def out_channels(self) -> int:
        return _EMBEDDING_SIZE

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        if x.ndim == 3:
            x = x[:, None]
        if x.ndim != 4 or tuple(x.shape[1:]) != (1, 96, 64):
            raise ValueError(f"VGGish input must be (N, 1, 96, 64) log-mel examples, got {tuple(x.shape)}")
        h = self.features(x)  # (N, 512, 6, 4)
        h = h.permute(0, 2, 3, 1).reshape(h.shape[0], -1)  # TF (NHWC) flattening order, as torchvggish
        layers = list(self.embeddings) if self.cfg.use_activation else list(self.embeddings)[:-1]
        for layer in layers:
            h = layer(h)
        return h


def load_state_dict_file(path: str | Path) -> dict[str, torch.Tensor]:
    """Read a state dict from a local ``.safetensors`` file or a ``.pt``/``.pth``/``.bin`` torch file.

    Torch files are read with ``weights_only=True``; a ``{"state_dict": {...}}`` or ``{"model": {...}}``
    wrapper is unwrapped.

    Raises:
        FileNotFoundError: no such file.
        ValueError: the file cannot be read as a state dict of tensors.
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"{path}: weights file not found")
    try:
        if path.suffix == ".safetensors":
            from safetensors.torch import load_file

            state: Any = load_file(str(path), device="cpu")
        else:
            state = torch.load(str(path), map_location="cpu", weights_only=True)
    except Exception as exc:
        raise ValueError(f"{path}: cannot read weights: {type(exc).__name__}: {exc}") from None
    if isinstance(state, dict):
        for key in ("state_dict", "model"):
            if key in state and isinstance(state[key], dict):
                state = state[key]
                break
    if not isinstance(state, dict) or not all(isinstance(v, torch.Tensor) for v in state.values()):
        raise ValueError(f"{path}: expected a state dict mapping names to tensors")
    return dict(state)


def load_vggish(path: str | Path, cfg: VGGishConfig | None = None) -> VGGish:
    """A :class:`VGGish` with the weights of the local file ``path`` (strict: every key must match).

    Raises:
        FileNotFoundError / ValueError: missing file, unreadable file, or keys/shapes that do not fit
            (the message lists the missing and unexpected names).
    """
    state = load_state_dict_file(path)
    ignored = [k for k in state if k.startswith("pproc.")]
    if ignored:
        logger.info("%s: ignoring PCA post-processing parameters %s (FAD uses raw embeddings)", path, ignored)
        state = {k: v for k, v in state.items() if not k.startswith("pproc.")}
    model = VGGish(cfg)
    try:
        model.load_state_dict(state, strict=True)
    except RuntimeError as exc:
        raise ValueError(f"{path}: not a VGGish state dict: {exc}") from None
    return model.eval()
