"""Saving, loading and wrapping trained feature extractors (safetensors + JSON sidecar, no pickle).

See :mod:`momu.metrics.extractors`.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import logging
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any, Protocol, runtime_checkable

import numpy as np
import torch
from torch import nn

from momu.data.types import Clip
from momu.io import atomic_path, read_json
from momu.metrics.extractors.networks import (
    KINDS,
    AudioClassifier,
    AudioClassifierConfig,
    MotionClassifier,
    MotionClassifierConfig,
    audio_segments,
    motion_windows,
    prepare_motion,
)
from momu.metrics.vggish import VGGishConfig, load_vggish, vggish_examples

logger = logging.getLogger(__name__)


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
    path: str | Path,
    model: MotionClassifier | AudioClassifier,
    summary: dict[str, Any] | None = None,
    provenance: Mapping[str, str] | None = None,
) -> str:
    """Write ``path`` (``.safetensors`` weights) and ``path.with_suffix('.json')`` (kind, config, summary).

    ``provenance`` (e.g. ``{"git_commit": ...}``) is stored in the ``.json`` beside the other fields.

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
        **dict(provenance or {}),
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
def batched_slices(n: int, size: int) -> list[slice]:
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
        for sl in batched_slices(len(x_all), self.batch_size):
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
            for sl in batched_slices(len(segs), self.batch_size)
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
            for sl in batched_slices(len(examples), self.batch_size)
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
