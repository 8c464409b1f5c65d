"""Learned-feature metrics of MoMu-Diffusion: ``fid_learned``, ``mean_kld``, ``diversity``, ``fad``.

Specification: METRICS.md §3.1 and MoMu App. B.4–B.5 (Tables 3–6, Fig. 3). Features come from the
extractors of :mod:`momu.metrics.extractors` (trained by ``momu extractor train``) or from VGGish with
user-provided weights; every result's :meth:`provenance` names the extractor kind, its config, its
checkpoint path and the sha256 of the weights file.

* ``fid_learned`` — Fréchet distance between the motion classifier's clip features of generated and
  reference motion (MoMu Table 6 "FID"; B.5). Features are not standardised (they are a network's
  embedding, as in Inception-FID); the Fréchet distance is :func:`momu.metrics.frechet.frechet_distance`
  with ``variant="mint"`` by default, which is the pytorch-fid convention
  (``sqrtm(Σ_ref·Σ_gen)``, fallback eps 1e-6, an error on a large imaginary part).
* ``mean_kld`` — MoMu Table 6 "Mean KLD". The paper gives no formula; momu's definition (documented
  choice): ``mode="paired"`` (default) — generated clip *i* was generated for the condition of reference
  clip *i*; ``KLD = mean_i KL(p_ref,i ‖ p_gen,i)`` with ``p`` the classifier's softmax over styles
  (the paired-KL convention of audio generation, e.g. AudioLDM's KL). ``mode="marginal"`` —
  ``KL(mean_i p_ref,i ‖ mean_j p_gen,j)`` between the two sets' mean class distributions (no pairing).
  Natural log (nats); computed from float64 log-softmax, so it is finite and ≥ 0.
* ``diversity`` — MoMu App. B.4/B.5: *inter*-diversity = mean feature distance over ``num_pairs`` = 200
  random pairs drawn from ``num_pieces`` = 50 pieces generated from different inputs (at most one piece
  per input); *intra*-diversity = mean distance over all pairs of the pieces generated from the same input
  (5 per input in the paper), averaged over inputs. The input of a generated clip is
  ``clip.meta[group_key]`` (default ``"condition_id"``, as ``multimodality``); without it every clip is its
  own input and only ``diversity.inter`` is reported. Features: the motion classifier's clip features
  (``modality="motion"``) or the mean of a clip's 0.96 s audio embeddings (``modality="music"``).
  Euclidean distance, float64. Pair sampling is seeded (``seed``).
* ``fad`` — Fréchet Audio Distance (Kilgour et al.; MoMu B.4 with gudgud96/frechet-audio-distance): the
  embeddings of every 0.96 s segment of every clip are pooled into one set per side (not averaged per
  clip), then the Fréchet distance between the reference ("background") and generated ("eval") sets,
  ``variant="mint"`` = gudgud96's ``calculate_frechet_distance``. Embedding: the momu-trained audio
  classifier (default; a stand-in for VGGish, reported as such) or VGGish from a local weights file.
"""

from __future__ import annotations

import dataclasses
import itertools
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from momu.data.types import Clip
from momu.metrics.base import MetricResult
from momu.metrics.diversity import average_pairwise_distance
from momu.metrics.extractors import (
    AudioEmbedding,
    MotionExtractor,
    load_audio_embedding,
)
from momu.metrics.frechet import FID_VARIANTS, frechet_distance
from momu.registry import METRICS

__all__ = [
    "FIDLearnedConfig",
    "MeanKLDConfig",
    "DiversityConfig",
    "FADConfig",
    "mean_kl_divergence",
    "paired_kl_values",
    "inter_diversity",
    "intra_diversity",
    "FIDLearned",
    "MeanKLD",
    "Diversity",
    "FAD",
]

_TRAIN_HINT = "train one with `momu extractor train --kind {kind} --data synth|DIR --out FILE.safetensors`"


# ============================================================================ pure functions
def _log_probs(name: str, x: np.ndarray) -> np.ndarray:
    arr = np.asarray(x, dtype=np.float64)
    if arr.ndim != 2 or arr.shape[1] < 1 or arr.shape[0] < 1:
        raise ValueError(f"{name}: expected (N, num_classes) log-probabilities, got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name}: contains NaN or inf")
    total = np.logaddexp.reduce(arr, axis=1)
    if not np.allclose(total, 0.0, atol=1e-6):
        raise ValueError(
            f"{name}: rows are not normalised log-probabilities (logsumexp up to {np.abs(total).max():.3g})"
        )
    return arr


def paired_kl_values(reference_log_probs: np.ndarray, generated_log_probs: np.ndarray) -> np.ndarray:
    """Per-pair ``KL(ref_i ‖ gen_i)`` in nats of ``(N, C)`` log class probabilities (``mean_kld`` paired)."""
    ref = _log_probs("reference_log_probs", reference_log_probs)
    gen = _log_probs("generated_log_probs", generated_log_probs)
    if ref.shape != gen.shape:
        raise ValueError(f"paired KL needs equal shapes: reference {ref.shape}, generated {gen.shape}")
    return np.asarray(np.sum(np.exp(ref) * (ref - gen), axis=1), dtype=np.float64)


def mean_kl_divergence(
    reference_log_probs: np.ndarray, generated_log_probs: np.ndarray, *, mode: str = "paired"
) -> float:
    """Mean KL divergence between class distributions (MoMu Table 6 "Mean KLD"; module docstring).

    Args:
        reference_log_probs: ``(N', C)`` natural-log class probabilities of the reference clips.
        generated_log_probs: ``(N, C)`` of the generated clips.
        mode: ``"paired"`` — ``mean_i KL(ref_i ‖ gen_i)``, needs N = N'; ``"marginal"`` —
            ``KL(mean ref ‖ mean gen)``.

    Returns:
        The divergence in nats (≥ 0; 0 for identical distributions).
    """
    ref = _log_probs("reference_log_probs", reference_log_probs)
    gen = _log_probs("generated_log_probs", generated_log_probs)
    if ref.shape[1] != gen.shape[1]:
        raise ValueError(f"class counts differ: reference {ref.shape[1]}, generated {gen.shape[1]}")
    if mode == "paired":
        if ref.shape[0] != gen.shape[0]:
            raise ValueError(
                f"mean_kld mode 'paired' pairs generated clip i with reference clip i, but there are "
                f"{gen.shape[0]} generated and {ref.shape[0]} reference clips (use mode='marginal')"
            )
        return float(max(0.0, np.mean(paired_kl_values(ref, gen))))
    if mode == "marginal":
        log_mean_ref = np.logaddexp.reduce(ref, axis=0) - np.log(ref.shape[0])
        log_mean_gen = np.logaddexp.reduce(gen, axis=0) - np.log(gen.shape[0])
        return float(max(0.0, np.sum(np.exp(log_mean_ref) * (log_mean_ref - log_mean_gen))))
    raise ValueError(f"mean_kld mode must be 'paired' or 'marginal', got {mode!r}")


def _check_features(features: np.ndarray) -> np.ndarray:
    feats = np.asarray(features, dtype=np.float64)
    if feats.ndim != 2:
        raise ValueError(f"features: expected (N, d), got shape {feats.shape}")
    if not np.all(np.isfinite(feats)):
        raise ValueError("features: contains NaN or inf")
    return feats


def inter_diversity(
    features: np.ndarray,
    groups: Sequence[Any] | None = None,
    *,
    num_pieces: int = 50,
    num_pairs: int = 200,
    seed: int = 0,
) -> float:
    """MoMu inter-diversity (App. B.4): mean distance of random pairs of pieces from different inputs.

    Args:
        features: ``(N, d)`` one feature row per generated piece.
        groups: the input each piece was generated from (``None``: all different). At most one piece per
            input is used (the first, in order of appearance).
        num_pieces: pieces drawn (without replacement) from the distinct inputs (all when fewer).
        num_pairs: distinct unordered pairs drawn from those pieces (all pairs when fewer exist).
        seed: seeds both draws.

    Returns:
        Mean Euclidean distance (float64) in feature units.
    """
    feats = _check_features(features)
    if groups is not None and len(groups) != len(feats):
        raise ValueError(f"groups has {len(groups)} entries for {len(feats)} feature rows")
    if groups is None:
        candidates = np.arange(len(feats))
    else:
        first: dict[Any, int] = {}
        for i, g in enumerate(groups):
            first.setdefault(g, i)
        candidates = np.array(sorted(first.values()), dtype=int)
    if len(candidates) < 2:
        raise ValueError(
            f"inter-diversity needs pieces from at least 2 different inputs, got {len(candidates)}"
        )
    if num_pieces < 2 or num_pairs < 1:
        raise ValueError(f"num_pieces must be >= 2 and num_pairs >= 1, got {num_pieces}, {num_pairs}")
    rng = np.random.default_rng(seed)
    pieces = rng.choice(candidates, size=min(num_pieces, len(candidates)), replace=False)
    all_pairs = np.array(list(itertools.combinations(range(len(pieces)), 2)))
    take = rng.choice(len(all_pairs), size=min(num_pairs, len(all_pairs)), replace=False)
    i, j = pieces[all_pairs[take, 0]], pieces[all_pairs[take, 1]]
    return float(np.mean(np.linalg.norm(feats[i] - feats[j], axis=1)))


def intra_diversity(features: np.ndarray, groups: Sequence[Any]) -> float:
    """MoMu intra-diversity (App. B.4): per input, mean distance over all pairs of its pieces, averaged.

    Inputs with a single piece are skipped; at least one input needs two pieces.
    """
    feats = _check_features(features)
    if len(groups) != len(feats):
        raise ValueError(f"groups has {len(groups)} entries for {len(feats)} feature rows")
    members: dict[Any, list[int]] = {}
    for i, g in enumerate(groups):
        members.setdefault(g, []).append(i)
    values = [
        average_pairwise_distance(feats[idx], accumulate="float64")
        for idx in members.values()
        if len(idx) >= 2
    ]
    if not values:
        raise ValueError("intra-diversity needs at least one input with 2 or more generated pieces")
    return float(np.mean(values))


# ============================================================================ configs
@dataclass
class FIDLearnedConfig:
    """``fid_learned``: FID on the motion classifier's features (MoMu Table 6, App. B.5).

    Attributes:
        extractor: path of a motion-classifier checkpoint (``.safetensors`` with its ``.json``).
        variant: Fréchet-distance convention of :mod:`momu.metrics.frechet` (``mint`` = pytorch-fid).
        device: torch device for feature extraction.
    """

    extractor: str | None = None
    variant: str = "mint"
    device: str = "cpu"


@dataclass
class MeanKLDConfig:
    """``mean_kld`` (MoMu Table 6): see the module docstring for ``mode``."""

    extractor: str | None = None
    mode: str = "paired"
    device: str = "cpu"


@dataclass
class DiversityConfig:
    """``diversity``: MoMu inter/intra diversity (App. B.4–B.5).

    Attributes:
        modality: ``"motion"`` (motion-classifier features) or ``"music"`` (mean audio embedding per clip).
        extractor: motion-classifier checkpoint, or audio embedding weights (momu audio classifier or VGGish).
        embedding: for music: ``"auto"``, ``"audio_classifier"`` or ``"vggish"``.
        num_pieces: pieces drawn for inter-diversity (50 in the paper).
        num_pairs: random pairs for inter-diversity (200 in the paper).
        group_key: ``clip.meta`` key naming the input a generated clip was generated from.
        seed: seeds the random draws.
        device: torch device.
    """

    modality: str = "motion"
    extractor: str | None = None
    embedding: str = "auto"
    num_pieces: int = 50
    num_pairs: int = 200
    group_key: str = "condition_id"
    seed: int = 0
    device: str = "cpu"


@dataclass
class FADConfig:
    """``fad``: Fréchet Audio Distance (MoMu Fig. 3, App. B.4).

    Attributes:
        extractor: audio embedding weights: a momu audio-classifier checkpoint (default embedding, trained on
            the dataset at hand) or a local VGGish state dict (``.safetensors`` / ``.pt``).
        embedding: ``"auto"``, ``"audio_classifier"`` or ``"vggish"``.
        variant: Fréchet-distance convention (``mint`` = gudgud96/pytorch-fid).
        device: torch device.
    """

    extractor: str | None = None
    embedding: str = "auto"
    variant: str = "mint"
    device: str = "cpu"


# ============================================================================ metrics
def _clips(name: str, label: str, clips: Sequence[Clip] | None) -> list[Clip]:
    if clips is None:
        raise ValueError(f"{name}: needs {label} clips")
    out = list(clips)
    if not out:
        raise ValueError(f"{name}: no {label} clips")
    return out


class _LearnedMetric:
    """Shared plumbing: lazily loads the extractor named in the config (or uses the one given)."""

    name = ""
    needs_reference = True
    _kind = "motion"

    def __init__(self, cfg: Any, extractor: Any = None) -> None:
        self.cfg = cfg
        self._extractor = extractor
        if getattr(cfg, "variant", "mint") not in FID_VARIANTS:
            raise ValueError(f"{self.name}: variant must be one of {FID_VARIANTS}, got {cfg.variant!r}")

    def _load(self) -> Any:
        raise NotImplementedError

    @property
    def extractor(self) -> Any:
        if self._extractor is None:
            if not self.cfg.extractor:
                raise ValueError(
                    f"{self.name}: no feature extractor configured (set `extractor: PATH`); "
                    + _TRAIN_HINT.format(kind=self._kind)
                )
            self._extractor = self._load()
        return self._extractor

    def _motion_extractor(self) -> MotionExtractor:
        ext = self.extractor
        if not isinstance(ext, MotionExtractor):
            raise ValueError(
                f"{self.name}: needs a motion classifier, got a {getattr(ext, 'kind', type(ext).__name__)}"
            )
        return ext

    def provenance(self) -> dict[str, Any]:
        """Metric config plus the extractor's kind, config, checkpoint path and sha256.

        ``extractor`` is ``None`` when none is configured yet; an in-memory extractor has no checkpoint
        hash (``sha256: None``) — save it with ``save_extractor`` to get one.
        """
        extractor = None
        if self._extractor is not None or self.cfg.extractor:
            extractor = self.extractor.provenance()
        return {
            "metric": self.name,
            "config": dataclasses.asdict(self.cfg),
            "extractor": extractor,
            "spec": "METRICS.md §3.1; MoMu-Diffusion App. B.4–B.5",
        }


class FIDLearned(_LearnedMetric):
    """``fid_learned``: Fréchet distance of motion-classifier clip features."""

    name = "fid_learned"

    def _load(self) -> MotionExtractor:
        return MotionExtractor.load(self.cfg.extractor, device=self.cfg.device)

    def __call__(self, generated: Sequence[Clip], reference: Sequence[Clip] | None = None) -> MetricResult:
        gen = _clips(self.name, "generated", generated)
        ref = _clips(self.name, "reference", reference)
        ext = self._motion_extractor()
        return {
            self.name: frechet_distance(
                ext.clip_features(gen), ext.clip_features(ref), variant=self.cfg.variant
            )
        }


class MeanKLD(_LearnedMetric):
    """``mean_kld``: KL divergence between classifier class distributions (reference ‖ generated)."""

    name = "mean_kld"

    def __init__(self, cfg: MeanKLDConfig, extractor: Any = None) -> None:
        if cfg.mode not in ("paired", "marginal"):
            raise ValueError(f"mean_kld: mode must be 'paired' or 'marginal', got {cfg.mode!r}")
        super().__init__(cfg, extractor)

    def _load(self) -> MotionExtractor:
        return MotionExtractor.load(self.cfg.extractor, device=self.cfg.device)

    def __call__(self, generated: Sequence[Clip], reference: Sequence[Clip] | None = None) -> MetricResult:
        gen = _clips(self.name, "generated", generated)
        ref = _clips(self.name, "reference", reference)
        ext = self._motion_extractor()
        if self.cfg.mode == "paired" and len(gen) != len(ref):
            raise ValueError(
                f"{self.name}: mode 'paired' needs as many generated as reference clips "
                f"({len(gen)} vs {len(ref)}); use mode 'marginal'"
            )
        value = mean_kl_divergence(ext.log_probabilities(ref), ext.log_probabilities(gen), mode=self.cfg.mode)
        return {self.name: value}


class Diversity(_LearnedMetric):
    """``diversity``: MoMu inter-/intra-diversity of generated pieces (reference not needed)."""

    name = "diversity"
    needs_reference = False

    def __init__(self, cfg: DiversityConfig, extractor: Any = None) -> None:
        if cfg.modality not in ("motion", "music"):
            raise ValueError(f"diversity: modality must be 'motion' or 'music', got {cfg.modality!r}")
        self._kind = "motion" if cfg.modality == "motion" else "audio"
        super().__init__(cfg, extractor)

    def _load(self) -> Any:
        if self.cfg.modality == "motion":
            return MotionExtractor.load(self.cfg.extractor, device=self.cfg.device)
        return load_audio_embedding(self.cfg.extractor, kind=self.cfg.embedding, device=self.cfg.device)

    def features(self, clips: Sequence[Clip]) -> np.ndarray:
        """One feature row per clip (motion-classifier feature, or mean audio embedding)."""
        if self.cfg.modality == "motion":
            return self._motion_extractor().clip_features(clips)
        emb = self.extractor
        if not isinstance(emb, AudioEmbedding):
            raise ValueError(
                f"diversity: modality 'music' needs an audio embedding, got {type(emb).__name__}"
            )
        return np.stack([emb.frame_embeddings(c).mean(axis=0) for c in clips])

    def __call__(self, generated: Sequence[Clip], reference: Sequence[Clip] | None = None) -> MetricResult:
        gen = _clips(self.name, "generated", generated)
        key = self.cfg.group_key
        has_groups = all(key in c.meta for c in gen)
        groups = [c.meta[key] for c in gen] if has_groups else None
        feats = self.features(gen)
        result: MetricResult = {
            f"{self.name}.inter": inter_diversity(
                feats,
                groups,
                num_pieces=self.cfg.num_pieces,
                num_pairs=self.cfg.num_pairs,
                seed=self.cfg.seed,
            )
        }
        if groups is not None and len(set(groups)) < len(groups):
            result[f"{self.name}.intra"] = intra_diversity(feats, groups)
        return result


class FAD(_LearnedMetric):
    """``fad``: Fréchet distance between pooled 0.96 s audio embeddings of reference and generated clips."""

    name = "fad"
    _kind = "audio"

    def _load(self) -> AudioEmbedding:
        return load_audio_embedding(self.cfg.extractor, kind=self.cfg.embedding, device=self.cfg.device)

    def embeddings(self, clips: Sequence[Clip]) -> np.ndarray:
        """All segment embeddings of all clips, concatenated ``(sum of segments, d)``."""
        emb = self.extractor
        return np.concatenate([emb.frame_embeddings(c) for c in clips], axis=0)

    def __call__(self, generated: Sequence[Clip], reference: Sequence[Clip] | None = None) -> MetricResult:
        gen = _clips(self.name, "generated", generated)
        ref = _clips(self.name, "reference", reference)
        return {
            self.name: frechet_distance(self.embeddings(gen), self.embeddings(ref), variant=self.cfg.variant)
        }


@METRICS.register("fid_learned", config=FIDLearnedConfig)
def build_fid_learned(cfg: FIDLearnedConfig, extractor: Any = None, **deps: Any) -> FIDLearned:
    """FID on motion-classifier features (MoMu Table 6). ``extractor`` may be given in memory."""
    return FIDLearned(cfg, extractor)


@METRICS.register("mean_kld", config=MeanKLDConfig)
def build_mean_kld(cfg: MeanKLDConfig, extractor: Any = None, **deps: Any) -> MeanKLD:
    """Mean KLD between style distributions (MoMu Table 6)."""
    return MeanKLD(cfg, extractor)


@METRICS.register("diversity", config=DiversityConfig)
def build_diversity(cfg: DiversityConfig, extractor: Any = None, **deps: Any) -> Diversity:
    """MoMu inter/intra diversity (App. B.4–B.5) on motion or music features."""
    return Diversity(cfg, extractor)


@METRICS.register("fad", config=FADConfig)
def build_fad(cfg: FADConfig, extractor: Any = None, **deps: Any) -> FAD:
    """Fréchet Audio Distance (MoMu Fig. 3) on the configured audio embedding."""
    return FAD(cfg, extractor)
