"""The feature-extractor networks (motion and audio style classifiers) and their input preparation.

See :mod:`momu.metrics.extractors`.
"""

from __future__ import annotations

import logging
import math
from dataclasses import dataclass, field
from typing import Any, Literal

import numpy as np
import torch
from torch import nn

from momu.encoders.dstformer import DSTformer, DSTformerConfig
from momu.features.audio import MoMuMelConfig, check_waveform, momu_mel

logger = logging.getLogger(__name__)


ExtractorKind = Literal["motion_classifier", "audio_classifier"]
KINDS: tuple[str, ...] = ("motion_classifier", "audio_classifier")


# ============================================================================ configs
@dataclass
class MotionClassifierConfig:
    """Motion style classifier (MoMu App. B.5: MotionBERT encoder + classification head).

    Attributes:
        class_names: the style labels, in logit order.
        fps: frame rate (Hz) the classifier works at; clips are resampled to it.
        window: frames per window at ``fps`` (30 = 2 s at 15 fps).
        hidden: width of the head's hidden layer (MotionBERT ``ActionHeadClassification``).
        dropout: dropout before the head's layers (training only).
        dstformer: the encoder (``num_joints``/``dim_in`` must match the data's skeleton).
        embed_dim: 0 keeps MotionBERT's feature (the pooled ``J · dim_rep`` representation); ``> 0``
            adds a linear projection to that width, trained with the head, whose output is the
            feature (momu's choice for small evaluation sets: a Fréchet distance needs more clips
            than feature dimensions for a full-rank covariance, DESIGN.md "Statistics").
    """

    class_names: list[str] = field(default_factory=list)
    fps: float = 15.0
    window: int = 30
    hidden: int = 128
    dropout: float = 0.1
    dstformer: DSTformerConfig = field(default_factory=lambda: DSTformerConfig(dim_feat=32, dim_rep=16))
    embed_dim: int = 0

    def __post_init__(self) -> None:
        if self.embed_dim < 0:
            raise ValueError(f"MotionClassifierConfig.embed_dim must be >= 0, got {self.embed_dim}")
        if self.fps <= 0:
            raise ValueError(f"MotionClassifierConfig.fps must be positive, got {self.fps}")
        if self.window < 2:
            raise ValueError(f"MotionClassifierConfig.window must be >= 2 frames, got {self.window}")
        if isinstance(self.dstformer, dict):
            self.dstformer = DSTformerConfig(**self.dstformer)

    @property
    def pooled_dim(self) -> int:
        """Width of the pooled encoder representation: ``num_joints · dim_rep``."""
        return self.dstformer.num_joints * self.dstformer.dim_rep

    @property
    def feature_dim(self) -> int:
        """Width of the clip feature: ``embed_dim`` if set, else :attr:`pooled_dim`."""
        return self.embed_dim or self.pooled_dim


@dataclass
class AudioClassifierConfig:
    """Log-mel CNN audio classifier (momu's default audio embedding; stands in for VGGish).

    Attributes:
        class_names: the style labels, in logit order.
        segment_frames: mel frames per embedded segment (60 frames of MoMu's 62.5 frames/s mel = 0.96 s,
            VGGish's example length).
        channels: output channels of the three conv blocks (each: 3×3 conv, ReLU, 2×2 max-pool).
        embed_dim: width of the embedding (the FAD / diversity feature).
        dropout: dropout before the classification layer (training only).
        mel: the log-mel front end (MoMu App. B.2: 16 kHz, 80 bins, n_fft 1024, hop 256).
    """

    class_names: list[str] = field(default_factory=list)
    segment_frames: int = 60
    channels: list[int] = field(default_factory=lambda: [16, 32, 64])
    embed_dim: int = 128
    dropout: float = 0.1
    mel: MoMuMelConfig = field(default_factory=MoMuMelConfig)

    def __post_init__(self) -> None:
        if self.segment_frames < 8:
            raise ValueError(f"AudioClassifierConfig.segment_frames must be >= 8, got {self.segment_frames}")
        if not self.channels or any(c < 1 for c in self.channels):
            raise ValueError(f"AudioClassifierConfig.channels must be positive ints, got {self.channels}")
        if isinstance(self.mel, dict):
            self.mel = MoMuMelConfig(**self.mel)


def _resample_time(x: np.ndarray, src_fps: float, dst_fps: float) -> np.ndarray:
    """Linear interpolation of ``x (T, ...)`` from ``src_fps`` to ``dst_fps`` (same duration)."""
    if math.isclose(src_fps, dst_fps, rel_tol=1e-9):
        return x
    t = x.shape[0]
    n = max(1, int(round((t - 1) * dst_fps / src_fps)) + 1)
    pos = np.arange(n) * (src_fps / dst_fps)
    pos = np.minimum(pos, t - 1)
    lo = np.floor(pos).astype(int)
    hi = np.minimum(lo + 1, t - 1)
    w = (pos - lo).reshape(-1, *([1] * (x.ndim - 1)))
    return (1 - w) * x[lo] + w * x[hi]


def prepare_motion(motion: Any, fps: float, cfg: MotionClassifierConfig, name: str = "motion") -> np.ndarray:
    """Validate, resample to ``cfg.fps`` and scale-normalise one clip's positions ``(T, J, D)``.

    Returns float32 ``(T', J, D)``: positions divided by the clip's body scale (mean distance of the
    joints from their per-frame centroid). Translation is removed per window by :func:`motion_windows`.

    Raises:
        ValueError: wrong shape / joint count / coordinate count, non-finite values, bad fps, or a
            motion whose joints all coincide (no body scale).
    """
    arr = np.asarray(motion, dtype=np.float64)
    d = cfg.dstformer
    if arr.ndim != 3 or arr.shape[1] != d.num_joints or arr.shape[2] != d.dim_in:
        raise ValueError(
            f"{name}: expected positions of shape (T, {d.num_joints}, {d.dim_in}) for this classifier "
            f"(trained on {d.num_joints} joints × {d.dim_in} coords), got {arr.shape}"
        )
    if arr.shape[0] < 1:
        raise ValueError(f"{name}: has no frames")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name}: contains NaN or infinite positions")
    if not fps or fps <= 0:
        raise ValueError(f"{name}: fps must be positive, got {fps}")
    arr = _resample_time(arr, float(fps), cfg.fps)
    centroid = arr.mean(axis=1, keepdims=True)  # (T, 1, D)
    scale = float(np.linalg.norm(arr - centroid, axis=-1).mean())
    if not scale > 1e-12:
        raise ValueError(f"{name}: all joints coincide in every frame (no body scale to normalise by)")
    return (arr / scale).astype(np.float32)


def motion_windows(prepared: np.ndarray, window: int) -> tuple[np.ndarray, np.ndarray]:
    """Cut a prepared clip into non-overlapping windows, each translated to its first frame's centroid.

    Returns:
        ``windows (W, window, J, D)`` float32 (the last one zero-padded) and ``mask (W, window)`` bool
        (True = real frame); ``W = ceil(T / window)``.
    """
    t = prepared.shape[0]
    w = -(-t // window)
    padded = np.zeros((w * window, *prepared.shape[1:]), dtype=np.float32)
    padded[:t] = prepared
    mask = np.zeros(w * window, dtype=bool)
    mask[:t] = True
    windows = padded.reshape(w, window, *prepared.shape[1:])
    origin = windows[:, :1].mean(axis=2, keepdims=True)  # (W, 1, 1, D): first frame's centroid
    windows = (windows - origin) * mask.reshape(w, window, 1, 1)
    return windows.astype(np.float32), mask.reshape(w, window)


class MotionClassifier(nn.Module):
    """DSTformer encoder + MotionBERT classification head (MoMu App. B.5).

    ``forward(x (B, T, J, D), mask (B, T)) -> logits (B, num_classes)``;
    :meth:`pooled` gives the ``(B, J·dim_rep)`` clip feature and :meth:`head_logits` maps features to logits.
    """

    def __init__(self, cfg: MotionClassifierConfig) -> None:
        super().__init__()
        if len(cfg.class_names) < 2:
            raise ValueError(f"a classifier needs at least 2 classes, got {cfg.class_names}")
        self.cfg = cfg
        self.encoder = DSTformer(cfg.dstformer)
        self.embed = nn.Linear(cfg.pooled_dim, cfg.embed_dim) if cfg.embed_dim else None
        self.head = nn.Sequential(
            nn.Dropout(cfg.dropout),
            nn.Linear(cfg.feature_dim, cfg.hidden),
            nn.LayerNorm(cfg.hidden),
            nn.ReLU(),
            nn.Dropout(cfg.dropout),
            nn.Linear(cfg.hidden, len(cfg.class_names)),
        )

    def pooled(self, x: torch.Tensor, mask: torch.Tensor | None = None) -> tuple[torch.Tensor, torch.Tensor]:
        """Time-mean of the encoder output over valid frames, joints flattened (then embedded).

        Returns ``(features (B, feature_dim), counts (B,))`` where counts are the valid frames
        averaged. The embedding is affine, so a frame-weighted mean of window features equals the
        embedding of the mean representation.
        """
        rep = self.encoder(x, mask)  # (B, T, J, C)
        b, t, j, c = rep.shape
        weights = torch.ones(b, t, device=x.device, dtype=rep.dtype) if mask is None else mask.to(rep.dtype)
        counts = weights.sum(dim=1)
        feats = (rep.reshape(b, t, j * c) * weights[..., None]).sum(dim=1) / counts[:, None]
        return (feats if self.embed is None else self.embed(feats)), counts

    def head_logits(self, features: torch.Tensor) -> torch.Tensor:
        return self.head(features)

    def forward(self, x: torch.Tensor, mask: torch.Tensor | None = None) -> torch.Tensor:
        return self.head(self.pooled(x, mask)[0])


# ============================================================================ audio
def audio_segments(
    audio: Any, sample_rate: Any, cfg: AudioClassifierConfig, name: str = "audio"
) -> np.ndarray:
    """Log-mel segments ``(N, n_mels, segment_frames)`` float32 of one waveform (MoMu mel, App. B.2).

    Non-overlapping; a trailing partial segment is dropped (as VGGish drops its partial example).

    Raises:
        ValueError: invalid waveform / sample rate, or audio shorter than one segment.
    """
    if sample_rate is None:
        raise ValueError(f"{name}: has audio but no sample rate")
    wave = check_waveform(audio, sample_rate, name=name)
    seconds = cfg.segment_frames / cfg.mel.frame_rate
    if len(wave) / float(sample_rate) < seconds - 1.0 / cfg.mel.frame_rate:
        raise ValueError(f"{name}: audio is shorter than one {seconds:.2f} s segment ({len(wave)} samples)")
    mel = momu_mel(wave, sample_rate, cfg.mel)  # (n_mels, frames)
    n = mel.shape[1] // cfg.segment_frames
    if n == 0:
        raise ValueError(
            f"{name}: audio is shorter than one {seconds:.2f} s segment ({mel.shape[1]} mel frames)"
        )
    segs = mel[:, : n * cfg.segment_frames].reshape(mel.shape[0], n, cfg.segment_frames)
    return np.ascontiguousarray(segs.transpose(1, 0, 2))


class AudioClassifier(nn.Module):
    """Small log-mel CNN: ``(B, n_mels, L)`` segments → ``(B, embed_dim)`` embeddings → logits.

    Input log-mels are standardised per mel band with statistics fitted on the training segments
    (buffers ``mel_mean``/``mel_std``, saved with the weights).
    """

    mel_mean: torch.Tensor
    mel_std: torch.Tensor

    def __init__(self, cfg: AudioClassifierConfig) -> None:
        super().__init__()
        if len(cfg.class_names) < 2:
            raise ValueError(f"a classifier needs at least 2 classes, got {cfg.class_names}")
        self.cfg = cfg
        n_mels = cfg.mel.n_mels
        self.register_buffer("mel_mean", torch.zeros(n_mels))
        self.register_buffer("mel_std", torch.ones(n_mels))
        blocks: list[nn.Module] = []
        in_ch = 1
        for ch in cfg.channels:
            blocks += [nn.Conv2d(in_ch, ch, kernel_size=3, padding=1), nn.ReLU(), nn.MaxPool2d(2)]
            in_ch = ch
        self.conv = nn.Sequential(*blocks)
        self.embed = nn.Linear(in_ch, cfg.embed_dim)
        self.classify = nn.Sequential(
            nn.ReLU(), nn.Dropout(cfg.dropout), nn.Linear(cfg.embed_dim, len(cfg.class_names))
        )

    def embedding(self, segments: torch.Tensor) -> torch.Tensor:
        """``(B, n_mels, L)`` log-mel segments → ``(B, embed_dim)`` (pre-activation) embeddings."""
        if segments.ndim != 3 or segments.shape[1] != self.cfg.mel.n_mels:
            raise ValueError(
                f"audio segments must be (B, {self.cfg.mel.n_mels}, frames), got {tuple(segments.shape)}"
            )
        x = (segments - self.mel_mean[:, None]) / self.mel_std[:, None]
        h = self.conv(x[:, None])  # (B, C, n_mels / 2^k, L / 2^k)
        return self.embed(h.mean(dim=(2, 3)))

    def forward(self, segments: torch.Tensor) -> torch.Tensor:
        return self.classify(self.embedding(segments))


# ============================================================================ checkpoints
