"""``bigvgan``: the BigVGAN generator (Lee et al., MoMu ref. [28]) loading a user-provided local checkpoint.

Architecture (BigVGAN §3, official implementation): ``conv_pre`` (k=7) -> for each upsampling rate
a transposed convolution followed by ``len(resblock_kernel_sizes)`` anti-aliased multi-periodicity
(AMP) blocks whose outputs are averaged -> anti-aliased Snake/SnakeBeta -> ``conv_post`` (k=7) ->
tanh. An AMP block is, for each dilation d, ``x + conv2(act(conv1_d(act(x))))`` where ``act`` is
Snake(Beta) applied at twice the sample rate between Kaiser-windowed sinc low-pass filters.

Parameter names follow the official generator, so its checkpoints load strictly: a torch file
(read with ``weights_only=True``, generator weights under ``"generator"`` or at the top level) or a
safetensors file. Weight-normalised tensors (``weight_g``/``weight_v`` or
``parametrizations.weight.original0/1``) are folded into plain weights (inference form). Nothing
is downloaded: without ``checkpoint`` the weights are random (for tests and training from scratch).

The checkpoint must match the mel features it is fed: BigVGAN expects ``ln(max(|mel|, 1e-5))`` of a
magnitude mel, which is :class:`momu.features.audio.MoMuMelConfig`'s compression (framing may
differ slightly from a given checkpoint's training front end).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import torch
import torch.nn.functional as F
from torch import Tensor, nn

from momu.features.audio import MelConfig, MoMuMelConfig
from momu.registry import VOCODERS
from momu.vocoders.griffin_lim import as_mel_batch

__all__ = ["BigVGANConfig", "BigVGAN", "build_bigvgan", "load_bigvgan_state", "kaiser_sinc_filter1d"]


def _default_dilations() -> list[list[int]]:
    return [[1, 3, 5], [1, 3, 5], [1, 3, 5]]


@dataclass
class BigVGANConfig:
    """BigVGAN generator hyperparameters (defaults: BigVGAN-base, 256× upsampling = MoMu's hop 256).

    Attributes:
        mel: the mel features the vocoder consumes (``n_mels``, ``sample_rate``, ``hop_length``).
        upsample_rates: transposed-conv strides; their product must equal ``mel.hop_length``.
        upsample_kernel_sizes: transposed-conv kernels (one per rate).
        upsample_initial_channel: channels after ``conv_pre`` (halved at every upsampling).
        resblock_kernel_sizes: kernels of the AMP blocks at each resolution.
        resblock_dilation_sizes: dilations of each AMP block.
        activation: ``snakebeta`` (BigVGAN) or ``snake``.
        snake_logscale: Snake parameters stored as logarithms (official default).
        use_tanh_at_final: tanh output (else clamp to [-1, 1]).
        use_bias_at_final: bias in ``conv_post``.
        checkpoint: local checkpoint path (``.safetensors`` or a torch file), or ``None``.
    """

    mel: MelConfig = field(default_factory=MoMuMelConfig)
    upsample_rates: list[int] = field(default_factory=lambda: [8, 8, 2, 2])
    upsample_kernel_sizes: list[int] = field(default_factory=lambda: [16, 16, 4, 4])
    upsample_initial_channel: int = 512
    resblock_kernel_sizes: list[int] = field(default_factory=lambda: [3, 7, 11])
    resblock_dilation_sizes: list[list[int]] = field(default_factory=_default_dilations)
    activation: str = "snakebeta"
    snake_logscale: bool = True
    use_tanh_at_final: bool = True
    use_bias_at_final: bool = True
    checkpoint: str | None = None


# ----------------------------------------------------------------------------- anti-aliasing
def kaiser_sinc_filter1d(cutoff: float, half_width: float, kernel_size: int) -> Tensor:
    """``(1, 1, K)`` Kaiser-windowed sinc low-pass filter (BigVGAN alias-free activation, after StyleGAN3).

    ``cutoff`` and ``half_width`` are in cycles per sample (Nyquist = 0.5); the taps sum to 1.
    """
    even = kernel_size % 2 == 0
    half_size = kernel_size // 2
    delta_f = 4 * half_width
    attenuation = 2.285 * (half_size - 1) * math.pi * delta_f + 7.95
    if attenuation > 50.0:
        beta = 0.1102 * (attenuation - 8.7)
    elif attenuation >= 21.0:
        beta = 0.5842 * (attenuation - 21) ** 0.4 + 0.07886 * (attenuation - 21.0)
    else:
        beta = 0.0
    window = torch.kaiser_window(kernel_size, beta=beta, periodic=False)
    time = torch.arange(-half_size, half_size) + 0.5 if even else torch.arange(kernel_size) - half_size
    if cutoff == 0:
        taps = torch.zeros_like(time, dtype=torch.float32)
    else:
        taps = 2 * cutoff * window * torch.sinc(2 * cutoff * time)
        taps = taps / taps.sum()
    return taps.view(1, 1, kernel_size).float()


class LowPassFilter1d(nn.Module):
    """Depthwise low-pass filtering with replicate padding (optionally strided)."""

    def __init__(self, cutoff: float, half_width: float, stride: int = 1, kernel_size: int = 12) -> None:
        super().__init__()
        even = kernel_size % 2 == 0
        self.pad_left = kernel_size // 2 - int(even)
        self.pad_right = kernel_size // 2
        self.stride = stride
        self.filter: Tensor
        self.register_buffer("filter", kaiser_sinc_filter1d(cutoff, half_width, kernel_size))

    def forward(self, x: Tensor) -> Tensor:
        c = x.shape[1]
        x = F.pad(x, (self.pad_left, self.pad_right), mode="replicate")
        return F.conv1d(x, self.filter.expand(c, -1, -1), stride=self.stride, groups=c)


class UpSample1d(nn.Module):
    """×ratio upsampling by zero-stuffing and Kaiser-sinc interpolation."""

    def __init__(self, ratio: int = 2, kernel_size: int | None = None) -> None:
        super().__init__()
        self.ratio = ratio
        self.kernel_size = int(6 * ratio // 2) * 2 if kernel_size is None else kernel_size
        self.pad = self.kernel_size // ratio - 1
        self.pad_left = self.pad * ratio + (self.kernel_size - ratio) // 2
        self.pad_right = self.pad * ratio + (self.kernel_size - ratio + 1) // 2
        self.filter: Tensor
        self.register_buffer("filter", kaiser_sinc_filter1d(0.5 / ratio, 0.6 / ratio, self.kernel_size))

    def forward(self, x: Tensor) -> Tensor:
        c = x.shape[1]
        x = F.pad(x, (self.pad, self.pad), mode="replicate")
        x = self.ratio * F.conv_transpose1d(x, self.filter.expand(c, -1, -1), stride=self.ratio, groups=c)
        return x[..., self.pad_left : -self.pad_right]


class DownSample1d(nn.Module):
    """÷ratio downsampling after Kaiser-sinc low-pass filtering."""

    def __init__(self, ratio: int = 2, kernel_size: int | None = None) -> None:
        super().__init__()
        k = int(6 * ratio // 2) * 2 if kernel_size is None else kernel_size
        self.lowpass = LowPassFilter1d(0.5 / ratio, 0.6 / ratio, stride=ratio, kernel_size=k)

    def forward(self, x: Tensor) -> Tensor:
        return self.lowpass(x)


class Snake(nn.Module):
    """Snake: x + (1/α)·sin²(αx), per-channel α (BigVGAN Eq. 1)."""

    def __init__(self, channels: int, logscale: bool = True) -> None:
        super().__init__()
        self.logscale = logscale
        self.alpha = nn.Parameter(torch.zeros(channels) if logscale else torch.ones(channels))

    def forward(self, x: Tensor) -> Tensor:
        alpha = self.alpha[None, :, None]
        if self.logscale:
            alpha = torch.exp(alpha)
        return x + (1.0 / (alpha + 1e-9)) * torch.sin(x * alpha).pow(2)


class SnakeBeta(nn.Module):
    """SnakeBeta: x + (1/β)·sin²(αx), separate per-channel frequency α and magnitude β (BigVGAN)."""

    def __init__(self, channels: int, logscale: bool = True) -> None:
        super().__init__()
        self.logscale = logscale
        init = torch.zeros(channels) if logscale else torch.ones(channels)
        self.alpha = nn.Parameter(init.clone())
        self.beta = nn.Parameter(init.clone())

    def forward(self, x: Tensor) -> Tensor:
        alpha = self.alpha[None, :, None]
        beta = self.beta[None, :, None]
        if self.logscale:
            alpha, beta = torch.exp(alpha), torch.exp(beta)
        return x + (1.0 / (beta + 1e-9)) * torch.sin(x * alpha).pow(2)


class Activation1d(nn.Module):
    """Anti-aliased activation: upsample ×2, Snake(Beta), downsample ×2."""

    def __init__(self, activation: nn.Module) -> None:
        super().__init__()
        self.act = activation
        self.upsample = UpSample1d(2, 12)
        self.downsample = DownSample1d(2, 12)

    def forward(self, x: Tensor) -> Tensor:
        return self.downsample(self.act(self.upsample(x)))


def _padding(kernel: int, dilation: int) -> int:
    return (kernel * dilation - dilation) // 2


class AMPBlock1(nn.Module):
    """Anti-aliased multi-periodicity residual block (BigVGAN §3, "AMP block", type 1)."""

    def __init__(
        self, channels: int, kernel: int, dilations: list[int], activation: str, logscale: bool
    ) -> None:
        super().__init__()
        self.convs1 = nn.ModuleList(
            [
                nn.Conv1d(channels, channels, kernel, 1, dilation=d, padding=_padding(kernel, d))
                for d in dilations
            ]
        )
        self.convs2 = nn.ModuleList(
            [
                nn.Conv1d(channels, channels, kernel, 1, dilation=1, padding=_padding(kernel, 1))
                for _ in dilations
            ]
        )
        act_cls = SnakeBeta if activation == "snakebeta" else Snake
        self.activations = nn.ModuleList(
            [Activation1d(act_cls(channels, logscale)) for _ in range(2 * len(dilations))]
        )

    def forward(self, x: Tensor) -> Tensor:
        acts1, acts2 = self.activations[::2], self.activations[1::2]
        for c1, c2, a1, a2 in zip(self.convs1, self.convs2, acts1, acts2):
            x = x + c2(a2(c1(a1(x))))
        return x


class BigVGAN(nn.Module):
    """BigVGAN generator: ``forward(mel (B, n_mels, T)) -> (B, 1, T·hop)``.

    :meth:`synthesize` follows the vocoder protocol (arrays in, float32 waveform out).
    """

    name = "bigvgan"

    def __init__(self, cfg: BigVGANConfig) -> None:
        super().__init__()
        cfg.mel.validate()
        if len(cfg.upsample_rates) != len(cfg.upsample_kernel_sizes) or not cfg.upsample_rates:
            raise ValueError(
                "bigvgan.upsample_rates and upsample_kernel_sizes must be non-empty and equally long"
            )
        if int(np.prod(cfg.upsample_rates)) != cfg.mel.hop_length:
            raise ValueError(
                f"bigvgan.upsample_rates multiply to {int(np.prod(cfg.upsample_rates))}, "
                f"but mel.hop_length is {cfg.mel.hop_length}"
            )
        if len(cfg.resblock_kernel_sizes) != len(cfg.resblock_dilation_sizes):
            raise ValueError("bigvgan.resblock_kernel_sizes and resblock_dilation_sizes must be equally long")
        if cfg.activation not in ("snake", "snakebeta"):
            raise ValueError(f"bigvgan.activation must be 'snake' or 'snakebeta', got {cfg.activation!r}")
        if cfg.upsample_initial_channel % (2 ** len(cfg.upsample_rates)):
            raise ValueError("bigvgan.upsample_initial_channel must be divisible by 2**len(upsample_rates)")
        self.cfg = cfg
        self.sample_rate = int(cfg.mel.sample_rate)
        self.hop_length = int(cfg.mel.hop_length)
        self.n_mels = int(cfg.mel.n_mels)
        ch = cfg.upsample_initial_channel
        self.num_kernels = len(cfg.resblock_kernel_sizes)
        self.conv_pre = nn.Conv1d(self.n_mels, ch, 7, 1, padding=3)
        self.ups = nn.ModuleList()
        self.resblocks = nn.ModuleList()
        for i, (u, k) in enumerate(zip(cfg.upsample_rates, cfg.upsample_kernel_sizes)):
            cin, cout = ch // 2**i, ch // 2 ** (i + 1)
            self.ups.append(nn.ModuleList([nn.ConvTranspose1d(cin, cout, k, u, padding=(k - u) // 2)]))
            for kr, dil in zip(cfg.resblock_kernel_sizes, cfg.resblock_dilation_sizes):
                self.resblocks.append(AMPBlock1(cout, kr, list(dil), cfg.activation, cfg.snake_logscale))
        last = ch // 2 ** len(cfg.upsample_rates)
        act_cls = SnakeBeta if cfg.activation == "snakebeta" else Snake
        self.activation_post = Activation1d(act_cls(last, cfg.snake_logscale))
        self.conv_post = nn.Conv1d(last, 1, 7, 1, padding=3, bias=cfg.use_bias_at_final)
        for m in self.modules():
            if isinstance(m, (nn.Conv1d, nn.ConvTranspose1d)):
                nn.init.normal_(m.weight, 0.0, 0.01)  # official init_weights
        if cfg.checkpoint:
            self.load_state_dict(load_bigvgan_state(cfg.checkpoint, self), strict=True)

    def forward(self, mel: Tensor) -> Tensor:
        """``(B, n_mels, T)`` log-mel -> ``(B, 1, T·hop_length)`` waveform in [-1, 1]."""
        if mel.ndim != 3 or mel.shape[1] != self.n_mels:
            raise ValueError(f"mel: expected (B, {self.n_mels}, T), got {tuple(mel.shape)}")
        x = self.conv_pre(mel)
        for i, ups in enumerate(self.ups):
            assert isinstance(ups, nn.ModuleList)
            for up in ups:
                x = up(x)
            blocks = self.resblocks[i * self.num_kernels : (i + 1) * self.num_kernels]
            x = sum(block(x) for block in blocks) / self.num_kernels
        x = self.conv_post(self.activation_post(x))
        return torch.tanh(x) if self.cfg.use_tanh_at_final else x.clamp(-1.0, 1.0)

    @torch.no_grad()
    def synthesize(self, mel: Any) -> np.ndarray:
        """Vocoder protocol: ``(n_mels, T)`` -> ``(S,)``, ``(B, n_mels, T)`` -> ``(B, S)`` float32."""
        batch, single = as_mel_batch(mel, self.n_mels)
        p = next(self.parameters())
        wav = self.forward(torch.from_numpy(batch).to(p.device, p.dtype))[:, 0].float().cpu().numpy()
        return wav[0] if single else wav


def _fold_weight_norm(state: dict[str, Tensor]) -> dict[str, Tensor]:
    """Replace weight-norm pairs (g, v) by the plain weight g·v/‖v‖ (norm over all dims but 0)."""
    out: dict[str, Tensor] = {}
    pairs = (
        ("weight_g", "weight_v"),
        ("parametrizations.weight.original0", "parametrizations.weight.original1"),
    )
    consumed: set[str] = set()
    for key in state:
        for g_name, v_name in pairs:
            if key.endswith(g_name):
                prefix = key[: -len(g_name)]
                v_key = prefix + v_name
                if v_key in state:
                    g, v = state[key].float(), state[v_key].float()
                    norm = v.flatten(1).norm(dim=1).view(-1, *([1] * (v.ndim - 1)))
                    out[prefix + "weight"] = g * v / norm
                    consumed.update({key, v_key})
    for key, value in state.items():
        if key not in consumed:
            out[key] = value
    return out


def load_bigvgan_state(path: str | Path, model: nn.Module | None = None) -> dict[str, Tensor]:
    """Read a local BigVGAN generator checkpoint as a plain state dict (no download, no pickles run).

    Args:
        path: ``.safetensors`` file, or a torch file read with ``weights_only=True`` whose generator
            weights are at the top level or under ``"generator"``.
        model: when given, mismatching keys or shapes raise an error listing them.

    Raises:
        FileNotFoundError: ``path`` does not exist. ValueError: unreadable or mismatching weights.
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"{path}: BigVGAN checkpoint not found")
    try:
        if path.suffix == ".safetensors":
            from safetensors.torch import load_file

            state: Any = load_file(str(path))
        else:
            state = torch.load(path, map_location="cpu", weights_only=True)
    except Exception as exc:
        raise ValueError(f"{path}: cannot read BigVGAN checkpoint: {type(exc).__name__}: {exc}") from None
    if isinstance(state, dict) and "generator" in state:
        state = state["generator"]
    if not isinstance(state, dict) or not all(isinstance(v, Tensor) for v in state.values()):
        raise ValueError(
            f"{path}: expected a mapping of tensor names to tensors (the generator's state dict)"
        )
    state = _fold_weight_norm(state)
    if model is not None:
        expected = model.state_dict()
        missing = sorted(set(expected) - set(state))
        unexpected = sorted(set(state) - set(expected))
        shapes = [k for k in expected if k in state and tuple(state[k].shape) != tuple(expected[k].shape)]
        if missing or unexpected or shapes:
            raise ValueError(
                f"{path}: checkpoint does not match the configured BigVGAN: missing {missing[:8]}, "
                f"unexpected {unexpected[:8]}, shape mismatches {shapes[:8]}"
            )
    return state


@VOCODERS.register("bigvgan", config=BigVGANConfig)
def build_bigvgan(cfg: BigVGANConfig, **deps: Any) -> BigVGAN:
    """Build the BigVGAN generator; loads ``cfg.checkpoint`` (local file) strictly when set."""
    return BigVGAN(cfg)
