"""Learned feature extractors behind ``fid_learned``, ``mean_kld``, ``diversity`` and ``fad``.

MoMu-Diffusion evaluates generated motion with features of a motion style classifier ("a MotionBert
encoder and a classification head", trained with Adam, lr 1e-4, 100 epochs on the dataset's genres —
MoMu App. B.5) and generated music with VGGish embeddings (App. B.4). momu provides:

* :class:`MotionClassifier` — the shared :class:`~momu.encoders.dstformer.DSTformer` encoder plus
  MotionBERT's classification head (time-mean pooling, joints flattened, ``Linear → LayerNorm → ReLU →
  Linear``), trained on labelled clips (``Clip.style``). Its *feature* is the pooled encoder
  representation (B.5: "we use the trained MotionBert encoder as the feature extractor").
* :class:`AudioClassifier` — a small log-mel CNN trained on the dataset's style labels; the default
  audio embedding, because VGGish weights cannot be downloaded here. It embeds every 0.96 s segment of
  a clip (60 frames of MoMu's 62.5 frames/s mel), like VGGish embeds 0.96 s examples.
* :class:`~momu.metrics.vggish.VGGish` with user-provided local weights (:class:`VGGishEmbedding`).

Extractors are trained by :func:`train_extractor` (CLI: ``momu extractor train``), saved by
:func:`save_extractor` as ``FILE.safetensors`` (weights) plus ``FILE.json`` (kind, config, training
summary; no pickle), and reloaded strictly by :func:`load_extractor`. Every loaded extractor knows the
sha256 of its weights file and reports it in :meth:`provenance`, which every learned metric copies.

Motion preprocessing (both training and evaluation, so they see the same inputs): positions are
resampled to the classifier's ``fps`` (linear interpolation), divided by the clip's body scale (mean
distance of the joints from their per-frame centroid — so pixels and metres look alike), cut into
windows of ``window`` frames, and each window is translated so its first frame's centroid is the origin.
A clip's feature is the frame-weighted mean of its windows' pooled representations (the last, partial
window is padded and masked), i.e. the time-mean of the encoder output over the whole clip.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import logging
import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal, Protocol, runtime_checkable

import numpy as np
import torch
import torch.nn.functional as F
from torch import nn
from tqdm.auto import tqdm

from momu.data.types import Clip
from momu.encoders.dstformer import DSTformer, DSTformerConfig
from momu.features.audio import MoMuMelConfig, check_waveform, momu_mel
from momu.io import atomic_path, read_json
from momu.metrics.vggish import VGGishConfig, load_vggish, vggish_examples

__all__ = [
    "MotionClassifierConfig",
    "AudioClassifierConfig",
    "TrainConfig",
    "MotionClassifier",
    "AudioClassifier",
    "MotionExtractor",
    "AudioEmbedding",
    "AudioClassifierEmbedding",
    "VGGishEmbedding",
    "file_sha256",
    "prepare_motion",
    "motion_windows",
    "audio_segments",
    "train_extractor",
    "train_motion_classifier",
    "train_audio_classifier",
    "save_extractor",
    "load_extractor",
    "load_audio_embedding",
]

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
    """

    class_names: list[str] = field(default_factory=list)
    fps: float = 15.0
    window: int = 30
    hidden: int = 128
    dropout: float = 0.1
    dstformer: DSTformerConfig = field(default_factory=lambda: DSTformerConfig(dim_feat=32, dim_rep=16))

    def __post_init__(self) -> None:
        if self.fps <= 0:
            raise ValueError(f"MotionClassifierConfig.fps must be positive, got {self.fps}")
        if self.window < 2:
            raise ValueError(f"MotionClassifierConfig.window must be >= 2 frames, got {self.window}")
        if isinstance(self.dstformer, dict):
            self.dstformer = DSTformerConfig(**self.dstformer)

    @property
    def feature_dim(self) -> int:
        """Width of the clip feature: ``num_joints · dim_rep``."""
        return self.dstformer.num_joints * self.dstformer.dim_rep


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


@dataclass
class TrainConfig:
    """Optimisation of an extractor.

    The defaults train in seconds on a CPU; :meth:`paper` gives MoMu App. B.5's schedule
    (Adam, lr 1e-4, 100 epochs).

    Attributes:
        epochs: passes over the training clips.
        batch_size: windows / segments per step.
        lr: Adam learning rate.
        weight_decay: Adam weight decay.
        samples_per_clip: random windows (motion) or segments (audio) drawn per clip per epoch.
        val_fraction: fraction of clips held out (stratified by style) to report accuracy; 0 = none.
        seed: seeds the split, the window sampling and the initialisation.
        device: torch device.
    """

    epochs: int = 20
    batch_size: int = 16
    lr: float = 1e-3
    weight_decay: float = 0.0
    samples_per_clip: int = 8
    val_fraction: float = 0.2
    seed: int = 0
    device: str = "cpu"

    @classmethod
    def paper(cls) -> TrainConfig:
        """MoMu App. B.5: Adam, learning rate 1e-4, 100 epochs."""
        return cls(epochs=100, lr=1e-4)

    def __post_init__(self) -> None:
        if self.epochs < 1 or self.batch_size < 1 or self.samples_per_clip < 1:
            raise ValueError("TrainConfig: epochs, batch_size and samples_per_clip must be >= 1")
        if not 0.0 <= self.val_fraction < 1.0:
            raise ValueError(f"TrainConfig.val_fraction must be in [0, 1), got {self.val_fraction}")
        if self.lr <= 0:
            raise ValueError(f"TrainConfig.lr must be positive, got {self.lr}")


# ============================================================================ motion
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
        self.head = nn.Sequential(
            nn.Dropout(cfg.dropout),
            nn.Linear(cfg.feature_dim, cfg.hidden),
            nn.LayerNorm(cfg.hidden),
            nn.ReLU(),
            nn.Dropout(cfg.dropout),
            nn.Linear(cfg.hidden, len(cfg.class_names)),
        )

    def pooled(self, x: torch.Tensor, mask: torch.Tensor | None = None) -> tuple[torch.Tensor, torch.Tensor]:
        """Time-mean of the encoder output over valid frames, joints flattened.

        Returns ``(features (B, J·dim_rep), counts (B,))`` where counts are the valid frames averaged.
        """
        rep = self.encoder(x, mask)  # (B, T, J, C)
        b, t, j, c = rep.shape
        weights = torch.ones(b, t, device=x.device, dtype=rep.dtype) if mask is None else mask.to(rep.dtype)
        counts = weights.sum(dim=1)
        feats = (rep.reshape(b, t, j * c) * weights[..., None]).sum(dim=1) / counts[:, None]
        return feats, counts

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
def file_sha256(path: str | Path) -> str:
    """Hex sha256 of a file's bytes (the checkpoint hash every learned metric reports)."""
    h = hashlib.sha256()
    with Path(path).open("rb") as fh:
        for chunk in iter(lambda: fh.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


def _sidecar(path: Path) -> Path:
    return path.with_suffix(".json")


def _kind_of(model: nn.Module) -> str:
    if isinstance(model, MotionClassifier):
        return "motion_classifier"
    if isinstance(model, AudioClassifier):
        return "audio_classifier"
    raise TypeError(f"cannot save {type(model).__name__}: not a momu extractor")


def save_extractor(
    path: str | Path, model: MotionClassifier | AudioClassifier, summary: dict[str, Any] | None = None
) -> str:
    """Write ``path`` (``.safetensors`` weights) and ``path.with_suffix('.json')`` (kind, config, summary).

    Both files are written atomically. Returns the sha256 of the weights file.
    """
    from safetensors.torch import save_file

    from momu import __version__

    path = Path(path)
    if path.suffix != ".safetensors":
        raise ValueError(f"{path}: extractor weights must be saved to a .safetensors file")
    kind = _kind_of(model)
    state = {k: v.detach().cpu().contiguous() for k, v in model.state_dict().items()}
    with atomic_path(path) as tmp:
        save_file(state, str(tmp), metadata={"momu_kind": kind, "format": "pt"})
    digest = file_sha256(path)
    meta = {
        "kind": kind,
        "config": dataclasses.asdict(model.cfg),
        "weights": path.name,
        "sha256": digest,
        "momu_version": __version__,
        "train": summary or {},
    }
    with atomic_path(_sidecar(path)) as tmp:
        tmp.write_text(json.dumps(meta, indent=2) + "\n", encoding="utf-8")
    return digest


def _load_model(path: Path) -> tuple[nn.Module, dict[str, Any], str]:
    from safetensors import safe_open
    from safetensors.torch import load_file

    if not path.is_file():
        raise FileNotFoundError(
            f"{path}: extractor weights not found (train one with `momu extractor train`)"
        )
    side = _sidecar(path)
    if not side.is_file():
        raise FileNotFoundError(f"{side}: extractor config not found next to {path.name}")
    meta = read_json(side)
    kind = meta.get("kind") if isinstance(meta, dict) else None
    if kind not in KINDS:
        raise ValueError(f"{side}: 'kind' must be one of {KINDS}, got {kind!r}")
    with safe_open(str(path), framework="pt") as fh:
        stored_kind = (fh.metadata() or {}).get("momu_kind")
    if stored_kind is not None and stored_kind != kind:
        raise ValueError(f"{path}: weights are a {stored_kind} but {side.name} says {kind}")
    try:
        cfg: Any
        model: nn.Module
        if kind == "motion_classifier":
            cfg = MotionClassifierConfig(**meta["config"])
            model = MotionClassifier(cfg)
        else:
            cfg = AudioClassifierConfig(**meta["config"])
            model = AudioClassifier(cfg)
    except (TypeError, KeyError) as exc:
        raise ValueError(f"{side}: invalid {kind} config: {exc}") from None
    try:
        model.load_state_dict(load_file(str(path), device="cpu"), strict=True)
    except RuntimeError as exc:
        raise ValueError(f"{path}: weights do not fit the config in {side.name}: {exc}") from None
    return model.eval(), meta, file_sha256(path)


# ============================================================================ evaluation wrappers
def _batched(n: int, size: int) -> list[slice]:
    return [slice(i, min(n, i + size)) for i in range(0, n, size)]


class _TrainedModelWrapper:
    """A model in eval mode on ``device`` plus where its weights came from (for provenance)."""

    kind: str

    def __init__(
        self,
        model: nn.Module,
        *,
        checkpoint: str | Path | None = None,
        sha256: str | None = None,
        device: str = "cpu",
        batch_size: int = 64,
    ) -> None:
        self.model: Any = model.to(device).eval()  # the subclass's model type
        self.cfg: Any = model.cfg
        self.checkpoint = None if checkpoint is None else str(checkpoint)
        self.sha256 = sha256
        self.device = torch.device(device)
        self.batch_size = batch_size

    def provenance(self) -> dict[str, Any]:
        """The extractor's kind and config, and the checkpoint file and sha256 of its weights."""
        return {
            "kind": self.kind,
            "config": dataclasses.asdict(self.cfg),
            "checkpoint": self.checkpoint,
            "sha256": self.sha256,
        }


class MotionExtractor(_TrainedModelWrapper):
    """A trained :class:`MotionClassifier` applied to clips (features and class probabilities).

    Attributes:
        model: the classifier (eval mode).
        checkpoint: the weights file (``None`` for an in-memory model).
        sha256: hash of the weights file (``None`` in memory).
    """

    kind = "motion_classifier"

    @classmethod
    def load(cls, path: str | Path, *, device: str = "cpu", batch_size: int = 64) -> MotionExtractor:
        model, _, digest = _load_model(Path(path))
        if not isinstance(model, MotionClassifier):
            raise ValueError(f"{path}: is an audio classifier, not a motion classifier")
        return cls(model, checkpoint=path, sha256=digest, device=device, batch_size=batch_size)

    @torch.no_grad()
    def clip_features(self, clips: Sequence[Clip]) -> np.ndarray:
        """``(N, J·dim_rep)`` float64 features: the time-mean encoder output of each clip."""
        if len(clips) == 0:
            raise ValueError("no clips to extract motion features from")
        windows, masks, owner = [], [], []
        for i, clip in enumerate(clips):
            if clip.motion is None:
                raise ValueError(f"clip {clip.id!r}: has no motion")
            w, m = motion_windows(
                prepare_motion(clip.motion, clip.fps, self.cfg, f"clip {clip.id!r}"), self.cfg.window
            )
            windows.append(w)
            masks.append(m)
            owner += [i] * len(w)
        x_all = torch.from_numpy(np.concatenate(windows))
        m_all = torch.from_numpy(np.concatenate(masks))
        sums = torch.zeros(len(clips), self.cfg.feature_dim, dtype=torch.float64)
        counts = torch.zeros(len(clips), dtype=torch.float64)
        idx = torch.tensor(owner)
        for sl in _batched(len(x_all), self.batch_size):
            feats, n = self.model.pooled(x_all[sl].to(self.device), m_all[sl].to(self.device))
            sums.index_add_(0, idx[sl], (feats.double() * n.double()[:, None]).cpu())
            counts.index_add_(0, idx[sl], n.double().cpu())
        return (sums / counts[:, None]).numpy()

    @torch.no_grad()
    def probabilities_from_features(self, features: np.ndarray) -> np.ndarray:
        """Softmax class distributions ``(N, C)`` of clip features (the classifier head)."""
        logits = self.model.head_logits(torch.as_tensor(features, dtype=torch.float32, device=self.device))
        return logits.softmax(dim=-1).double().cpu().numpy()

    @torch.no_grad()
    def log_probabilities(self, clips: Sequence[Clip]) -> np.ndarray:
        """``(N, C)`` float64 log-softmax class distributions of the clips (for KL divergences)."""
        feats = torch.as_tensor(self.clip_features(clips), dtype=torch.float32, device=self.device)
        return torch.log_softmax(self.model.head_logits(feats).double(), dim=-1).cpu().numpy()

    def clip_probabilities(self, clips: Sequence[Clip]) -> np.ndarray:
        """``(N, C)`` class distributions of the clips."""
        return self.probabilities_from_features(self.clip_features(clips))

    def predict(self, clips: Sequence[Clip]) -> list[str]:
        """The most probable style name of each clip."""
        probs = self.clip_probabilities(clips)
        return [self.cfg.class_names[i] for i in probs.argmax(axis=1)]


@runtime_checkable
class AudioEmbedding(Protocol):
    """What ``fad`` and music ``diversity`` need: per-segment embeddings of a clip's audio."""

    kind: str

    def frame_embeddings(self, clip: Clip) -> np.ndarray:
        """``(n_segments, d)`` embeddings of the clip's consecutive 0.96 s segments."""
        ...

    def provenance(self) -> dict[str, Any]: ...


class AudioClassifierEmbedding(_TrainedModelWrapper):
    """The trained :class:`AudioClassifier`'s embedding of each 0.96 s segment."""

    kind = "audio_classifier"

    @torch.no_grad()
    def frame_embeddings(self, clip: Clip) -> np.ndarray:
        if clip.audio is None:
            raise ValueError(f"clip {clip.id!r}: has no audio")
        segs = torch.from_numpy(audio_segments(clip.audio, clip.sample_rate, self.cfg, f"clip {clip.id!r}"))
        out = [
            self.model.embedding(segs[sl].to(self.device)).double().cpu()
            for sl in _batched(len(segs), self.batch_size)
        ]
        return torch.cat(out).numpy()


class VGGishEmbedding(_TrainedModelWrapper):
    """VGGish embeddings (user-provided local weights) of each 0.96 s example (MoMu App. B.4 / FAD)."""

    kind = "vggish"

    @classmethod
    def load(
        cls, path: str | Path, cfg: VGGishConfig | None = None, *, device: str = "cpu"
    ) -> VGGishEmbedding:
        return cls(load_vggish(path, cfg), checkpoint=path, sha256=file_sha256(path), device=device)

    @torch.no_grad()
    def frame_embeddings(self, clip: Clip) -> np.ndarray:
        if clip.audio is None:
            raise ValueError(f"clip {clip.id!r}: has no audio")
        if clip.sample_rate is None:
            raise ValueError(f"clip {clip.id!r}: has audio but no sample rate")
        examples = torch.from_numpy(vggish_examples(clip.audio, clip.sample_rate))
        if len(examples) == 0:
            raise ValueError(f"clip {clip.id!r}: audio shorter than one 0.96 s VGGish example")
        out = [
            self.model(examples[sl, None].to(self.device)).double().cpu()
            for sl in _batched(len(examples), self.batch_size)
        ]
        return torch.cat(out).numpy()


def load_extractor(path: str | Path, *, device: str = "cpu") -> MotionExtractor | AudioClassifierEmbedding:
    """Load a saved extractor (strict), wrapped for evaluation, with its checkpoint hash."""
    model, _, digest = _load_model(Path(path))
    if isinstance(model, MotionClassifier):
        return MotionExtractor(model, checkpoint=path, sha256=digest, device=device)
    assert isinstance(model, AudioClassifier)
    return AudioClassifierEmbedding(model, checkpoint=path, sha256=digest, device=device)


def load_audio_embedding(path: str | Path, *, kind: str = "auto", device: str = "cpu") -> AudioEmbedding:
    """An audio embedding from a local file.

    Args:
        path: a momu audio-classifier checkpoint (``.safetensors`` with its ``.json``) or VGGish weights.
        kind: ``"audio_classifier"``, ``"vggish"`` or ``"auto"`` (a ``.safetensors`` file with a momu
            ``.json`` beside it is an audio classifier; anything else is VGGish weights).
    """
    path = Path(path)
    if kind == "auto":
        kind = "audio_classifier" if path.suffix == ".safetensors" and _sidecar(path).is_file() else "vggish"
    if kind == "vggish":
        return VGGishEmbedding.load(path, device=device)
    if kind != "audio_classifier":
        raise ValueError(f"audio embedding kind must be 'auto', 'audio_classifier' or 'vggish', got {kind!r}")
    extractor = load_extractor(path, device=device)
    if not isinstance(extractor, AudioClassifierEmbedding):
        raise ValueError(f"{path}: is a motion classifier, not an audio embedding")
    return extractor


# ============================================================================ training
def _labelled(clips: Sequence[Clip], need: str) -> tuple[list[Clip], list[str]]:
    usable = [c for c in clips if c.style is not None and getattr(c, need) is not None]
    if len(usable) < len(clips):
        logger.info("skipping %d clip(s) without a style label or %s", len(clips) - len(usable), need)
    classes = sorted({str(c.style) for c in usable})
    if len(classes) < 2:
        raise ValueError(
            f"training a classifier needs clips of at least 2 styles (Clip.style) with {need}; "
            f"found {len(usable)} usable clip(s) of styles {classes}"
        )
    return usable, classes


def _split(
    labels: np.ndarray, val_fraction: float, rng: np.random.Generator
) -> tuple[np.ndarray, np.ndarray]:
    """Stratified split of clip indices; every class keeps at least one training clip."""
    train, val = [], []
    for c in np.unique(labels):
        idx = rng.permutation(np.nonzero(labels == c)[0])
        n_val = min(len(idx) - 1, int(round(val_fraction * len(idx))))
        val += idx[:n_val].tolist()
        train += idx[n_val:].tolist()
    return np.array(sorted(train), dtype=int), np.array(sorted(val), dtype=int)


def _fit_loop(
    model: nn.Module,
    sample_batch: Any,
    num_samples: int,
    train: TrainConfig,
    desc: str,
) -> list[float]:
    """Adam over ``train.epochs`` epochs of ``num_samples`` samples; returns the mean loss per epoch."""
    opt = torch.optim.Adam(model.parameters(), lr=train.lr, weight_decay=train.weight_decay)
    rng = np.random.default_rng(train.seed + 1)
    history: list[float] = []
    model.train()
    bar = tqdm(range(train.epochs), desc=desc, unit="epoch", leave=False)
    for _ in bar:
        order = rng.permutation(num_samples)
        total, seen = 0.0, 0
        for sl in _batched(num_samples, train.batch_size):
            x, mask, y = sample_batch(order[sl], rng)
            logits = model(x, mask) if mask is not None else model(x)
            loss = F.cross_entropy(logits, y)
            opt.zero_grad(set_to_none=True)
            loss.backward()
            opt.step()
            total += float(loss.detach()) * len(y)
            seen += len(y)
        history.append(total / seen)
        bar.set_postfix(loss=f"{history[-1]:.4f}")
    model.eval()
    return history


def train_motion_classifier(
    clips: Sequence[Clip],
    cfg: MotionClassifierConfig | None = None,
    train: TrainConfig | None = None,
) -> tuple[MotionClassifier, dict[str, Any]]:
    """Train a motion style classifier on labelled clips (MoMu App. B.5).

    Each epoch draws ``samples_per_clip`` random windows of ``cfg.window`` frames from every training
    clip (the whole clip, padded and masked, when it is shorter). ``cfg.class_names`` and the DSTformer's
    ``num_joints``/``dim_in`` are filled from the data when left empty / mismatched.

    Returns:
        ``(model, summary)``; the summary holds the per-epoch loss, the class names, the clip split
        and the held-out clip accuracy (``val_accuracy``, None without a validation split).
    """
    train = train or TrainConfig()
    usable, classes = _labelled(clips, "motion")
    first = np.asarray(usable[0].motion)
    if first.ndim != 3:
        raise ValueError(f"clip {usable[0].id!r}: motion must be (T, J, D), got shape {first.shape}")
    cfg = cfg or MotionClassifierConfig()
    dcfg = dataclasses.replace(cfg.dstformer, num_joints=int(first.shape[1]), dim_in=int(first.shape[2]))
    cfg = dataclasses.replace(cfg, class_names=classes, dstformer=dcfg)
    torch.manual_seed(train.seed)
    rng = np.random.default_rng(train.seed)
    labels = np.array([classes.index(str(c.style)) for c in usable])
    tr_idx, va_idx = _split(labels, train.val_fraction, rng)
    prepared = [
        prepare_motion(usable[i].motion, usable[i].fps, cfg, f"clip {usable[i].id!r}") for i in tr_idx
    ]
    model = MotionClassifier(cfg).to(train.device)
    device = torch.device(train.device)
    owners = np.repeat(np.arange(len(prepared)), train.samples_per_clip)

    def sample_batch(
        sel: np.ndarray, rng: np.random.Generator
    ) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
        xs, ms = [], []
        for k in owners[sel]:
            motion = prepared[k]
            start = int(rng.integers(0, max(1, motion.shape[0] - cfg.window + 1)))
            w, m = motion_windows(motion[start : start + cfg.window], cfg.window)
            xs.append(w[0])
            ms.append(m[0])
        y = torch.as_tensor(labels[tr_idx][owners[sel]], device=device)
        return torch.from_numpy(np.stack(xs)).to(device), torch.from_numpy(np.stack(ms)).to(device), y

    history = _fit_loop(model, sample_batch, len(owners), train, "motion classifier")
    summary: dict[str, Any] = {
        "class_names": classes,
        "loss_history": history,
        "train_clips": [usable[i].id for i in tr_idx],
        "val_clips": [usable[i].id for i in va_idx],
        "val_accuracy": None,
        "train": dataclasses.asdict(train),
    }
    extractor = MotionExtractor(model, device=train.device)
    if len(va_idx):
        predicted = extractor.clip_probabilities([usable[i] for i in va_idx]).argmax(axis=1)
        summary["val_accuracy"] = float(np.mean(predicted == labels[va_idx]))
    logger.info("motion classifier: final loss %.4f, val accuracy %s", history[-1], summary["val_accuracy"])
    return model.cpu(), summary


def train_audio_classifier(
    clips: Sequence[Clip],
    cfg: AudioClassifierConfig | None = None,
    train: TrainConfig | None = None,
) -> tuple[AudioClassifier, dict[str, Any]]:
    """Train the default audio embedding: a log-mel CNN classifying 0.96 s segments by style.

    Each epoch draws ``samples_per_clip`` random segments (any start frame) per training clip; the mel
    standardisation statistics come from the training clips. Returns ``(model, summary)`` like
    :func:`train_motion_classifier` (validation accuracy = clip-level, mean logits over segments).
    """
    train = train or TrainConfig()
    usable, classes = _labelled(clips, "audio")
    cfg = dataclasses.replace(cfg or AudioClassifierConfig(), class_names=classes)
    torch.manual_seed(train.seed)
    rng = np.random.default_rng(train.seed)
    labels = np.array([classes.index(str(c.style)) for c in usable])
    tr_idx, va_idx = _split(labels, train.val_fraction, rng)
    mels = []
    for i in tr_idx:
        clip = usable[i]
        if clip.sample_rate is None:
            raise ValueError(f"clip {clip.id!r}: has audio but no sample rate")
        wave = check_waveform(clip.audio, clip.sample_rate, name=f"clip {clip.id!r}")
        mel = momu_mel(wave, clip.sample_rate, cfg.mel)
        if mel.shape[1] < cfg.segment_frames:
            raise ValueError(
                f"clip {clip.id!r}: audio shorter than one {cfg.segment_frames}-frame segment "
                f"({mel.shape[1]} mel frames)"
            )
        mels.append(mel)
    stacked = np.concatenate(mels, axis=1)
    model = AudioClassifier(cfg)
    model.mel_mean.copy_(torch.from_numpy(stacked.mean(axis=1)))
    model.mel_std.copy_(torch.from_numpy(stacked.std(axis=1) + 1e-5))
    device = torch.device(train.device)
    model.to(device)
    owners = np.repeat(np.arange(len(mels)), train.samples_per_clip)
    seg = cfg.segment_frames

    def sample_batch(sel: np.ndarray, rng: np.random.Generator) -> tuple[torch.Tensor, None, torch.Tensor]:
        xs = []
        for k in owners[sel]:
            start = int(rng.integers(0, mels[k].shape[1] - seg + 1))
            xs.append(mels[k][:, start : start + seg])
        y = torch.as_tensor(labels[tr_idx][owners[sel]], device=device)
        return torch.from_numpy(np.stack(xs)).to(device), None, y

    history = _fit_loop(model, sample_batch, len(owners), train, "audio classifier")
    summary: dict[str, Any] = {
        "class_names": classes,
        "loss_history": history,
        "train_clips": [usable[i].id for i in tr_idx],
        "val_clips": [usable[i].id for i in va_idx],
        "val_accuracy": None,
        "train": dataclasses.asdict(train),
    }
    if len(va_idx):
        correct = []
        with torch.no_grad():
            for i in va_idx:
                clip = usable[i]
                segs = torch.from_numpy(audio_segments(clip.audio, clip.sample_rate, cfg)).to(device)
                correct.append(int(model(segs).mean(dim=0).argmax()) == labels[i])
        summary["val_accuracy"] = float(np.mean(correct))
    logger.info("audio classifier: final loss %.4f, val accuracy %s", history[-1], summary["val_accuracy"])
    return model.cpu(), summary


def train_extractor(
    kind: str,
    clips: Sequence[Clip],
    out: str | Path | None = None,
    *,
    model_config: MotionClassifierConfig | AudioClassifierConfig | None = None,
    train: TrainConfig | None = None,
) -> tuple[MotionExtractor | AudioClassifierEmbedding, dict[str, Any]]:
    """Train a ``"motion"`` or ``"audio"`` extractor on labelled clips and (optionally) save it to ``out``.

    Returns the evaluation wrapper (with checkpoint path and sha256 when saved) and the training summary.
    """
    if kind in ("motion", "motion_classifier"):
        if model_config is not None and not isinstance(model_config, MotionClassifierConfig):
            raise ValueError("model_config must be a MotionClassifierConfig for kind 'motion'")
        model: MotionClassifier | AudioClassifier
        model, summary = train_motion_classifier(clips, model_config, train)
    elif kind in ("audio", "audio_classifier"):
        if model_config is not None and not isinstance(model_config, AudioClassifierConfig):
            raise ValueError("model_config must be an AudioClassifierConfig for kind 'audio'")
        model, summary = train_audio_classifier(clips, model_config, train)
    else:
        raise ValueError(f"extractor kind must be 'motion' or 'audio', got {kind!r}")
    digest = None if out is None else save_extractor(out, model, summary)
    device = (train or TrainConfig()).device
    if isinstance(model, MotionClassifier):
        return MotionExtractor(model, checkpoint=out, sha256=digest, device=device), summary
    return AudioClassifierEmbedding(model, checkpoint=out, sha256=digest, device=device), summary
