"""Registered clip-level motion-feature metrics: ``fid_k``, ``fid_g``, ``div_k``, ``div_g``,
``multimodality``.

The Bailando evaluation pipeline (METRICS.md §1.3, ``utils/metrics_new.py``) over
:class:`~momu.data.types.Clip` sequences:

1. per clip (generated and reference alike): SMPL-24 positions ``(T, 24, 3)`` (metres, y up) cut to the
   first ``max_frames`` = 1200 frames (20 s at 60 fps), the frame-0 root position subtracted from every joint
   of every frame, then kinetic (:func:`~momu.metrics.kinetic.kinetic_features`, 72-d) or geometric
   (:func:`~momu.metrics.geometric.geometric_features`, 32-d) features;
2. features normalised with the reference (ground-truth) mean / std;
3. FID (:func:`~momu.metrics.frechet.fid`), Div (:func:`~momu.metrics.diversity.diversity`) or MoFusion's
   Multimodality (:func:`~momu.metrics.diversity.multimodality`).

The kinetic frame time is ``1/clip.fps`` unless ``frame_time`` is set (for 60-fps data this is the reference's
1/60 s); the geometric features' compat time per frame is the reference's constant 1/120 s.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from momu.data.types import Clip
from momu.metrics._clips import clip_motion, require_clips
from momu.metrics.base import MetricResult
from momu.metrics.diversity import diversity, multimodality
from momu.metrics.frechet import FID_VARIANTS, fid
from momu.metrics.geometric import GEOMETRIC_VARIANTS, geometric_features
from momu.metrics.kinetic import KINETIC_VARIANTS, kinetic_features
from momu.registry import METRICS

__all__ = [
    "MotionFeatureConfig",
    "FIDConfig",
    "DivConfig",
    "MultimodalityConfig",
    "prepare_motion",
    "clip_features",
    "FIDMetric",
    "DivMetric",
    "MultimodalityMetric",
]

FEATURE_KINDS = ("kinetic", "geometric")
SPEC = "METRICS.md §1.1–1.4 (Bailando utils/metrics_new.py, AIST++ API features); MoFusion §4.1"


@dataclass
class MotionFeatureConfig:
    """How clips become kinetic / geometric feature vectors (Bailando ``calc_and_save_feats``).

    Attributes:
        feature_variant: ``"compat"`` (reference features with their quirks) or ``"corrected"``.
        max_frames: keep the first N frames (Bailando: 1200 = 20 s at 60 fps); ``None`` keeps all.
        root_shift: subtract the frame-0 root (joint 0) position from every joint of every frame
            (Bailando).
        frame_time: kinetic seconds per frame; ``None`` = 1/clip.fps (1/60 for AIST++-style 60-fps data).
        up_axis: vertical axis of the positions for the kinetic energies (``"y"``; ``"z"`` for EDGE-style
            data).
    """

    feature_variant: str = "compat"
    max_frames: int | None = 1200
    root_shift: bool = True
    frame_time: float | None = None
    up_axis: str = "y"


@dataclass
class FIDConfig(MotionFeatureConfig):
    """FID_k / FID_g (METRICS.md §1.3).

    Attributes:
        variant: ``"bailando"`` (default; ``sqrtm(Σ_gen Σ_gt)``, complex parts dropped) or ``"mint"``.
        normalize: normalise both sets with the reference statistics (both references do).
        constant: zero-variance reference dimensions: ``"keep"`` (reference; huge FID, logged) or ``"raise"``.
    """

    variant: str = "bailando"
    normalize: bool = True
    constant: str = "keep"


@dataclass
class DivConfig(MotionFeatureConfig):
    """Div_k / Div_g (METRICS.md §1.4).

    Attributes:
        normalize: compute distances on reference-normalised features (Bailando; needs reference clips).
        accumulate: ``"reference"`` (Bailando's float32 running sum) or ``"float64"``.
    """

    normalize: bool = True
    accumulate: str = "reference"


@dataclass
class MultimodalityConfig(MotionFeatureConfig):
    """MoFusion Multimodality (§4.1; METRICS.md §3.2) on kinetic features.

    Attributes:
        group_key: ``clip.meta`` key naming the condition (music) each generated clip was generated for;
            clips sharing a value form one group of K generations (MoFusion: K = 50).
        normalize: normalise with the reference statistics (as Div; needs reference clips).
        accumulate: ``"float64"`` (default) or ``"reference"`` (float32 running sum).
    """

    group_key: str = "condition_id"
    normalize: bool = True
    accumulate: str = "float64"


def prepare_motion(
    motion: np.ndarray, *, max_frames: int | None = 1200, root_shift: bool = True
) -> np.ndarray:
    """Bailando's per-sequence preprocessing: first ``max_frames`` frames, frame-0 root moved to the origin.

    Args:
        motion: ``(T, J, 3)`` positions (joint 0 = root).
        max_frames: frames kept from the start (``None``: all).
        root_shift: subtract ``motion[0, 0]`` from every joint of every frame (in the input dtype).

    Returns:
        ``(min(T, max_frames), J, 3)`` array.
    """
    x = np.asarray(motion)
    if max_frames is not None:
        if max_frames < 1:
            raise ValueError(f"max_frames must be ≥ 1 or None, got {max_frames}")
        x = x[:max_frames]
    if root_shift:
        x = x - x[:1, :1, :]
    return x


def _check_config(cfg: MotionFeatureConfig) -> None:
    if cfg.feature_variant not in KINETIC_VARIANTS or cfg.feature_variant not in GEOMETRIC_VARIANTS:
        raise ValueError(f"feature_variant must be one of {KINETIC_VARIANTS}, got {cfg.feature_variant!r}")
    if cfg.up_axis not in ("y", "z"):
        raise ValueError(f"up_axis must be 'y' or 'z', got {cfg.up_axis!r}")
    if cfg.frame_time is not None and not cfg.frame_time > 0:
        raise ValueError(f"frame_time must be > 0 seconds or None, got {cfg.frame_time!r}")
    if cfg.max_frames is not None and cfg.max_frames < 3:
        raise ValueError(
            f"max_frames must be ≥ 3 (kinetic features need 3 frames) or None, got {cfg.max_frames}"
        )


def _clip_positions(clip: Clip, metric: str) -> np.ndarray:
    """The clip's global SMPL-24 positions ``(T, 24, 3)`` (root-centred motion + ``trajectory`` when given),
    with clear errors for anything else."""
    motion = clip_motion(clip, metric)  # has motion and a positive frame rate
    if clip.skeleton and clip.skeleton != "smpl24":
        raise ValueError(
            f"{metric}: clip {clip.id!r} has skeleton {clip.skeleton!r}; kinetic/geometric features are "
            "defined on SMPL-24 joints ('smpl24'; AIST++: dataset.motion=smpl24 with dataset.smpl_model=PATH)"
        )
    if motion.ndim != 3 or motion.shape[1:] != (24, 3):
        raise ValueError(
            f"{metric}: clip {clip.id!r} motion must be SMPL-24 positions (T, 24, 3), "
            f"got shape {motion.shape}"
        )
    if clip.trajectory is not None:
        # Root-centred motion (Clip.trajectory holds the root's global path): restore global positions,
        # which the reference features are computed on.
        trajectory = np.asarray(clip.trajectory)
        if trajectory.shape != (motion.shape[0], 3):
            raise ValueError(
                f"{metric}: clip {clip.id!r} trajectory must be ({motion.shape[0]}, 3) to match its motion, "
                f"got {trajectory.shape}"
            )
        motion = motion + trajectory[:, None, :].astype(motion.dtype, copy=False)
    return motion


def clip_features(
    clips: Sequence[Clip],
    kind: str,
    cfg: MotionFeatureConfig | None = None,
    *,
    metric: str = "motion features",
) -> np.ndarray:
    """Kinetic (72-d) or geometric (32-d) features of every clip, Bailando-preprocessed.

    Clips of equal length and frame rate are stacked and computed in one batch.

    Args:
        clips: clips with SMPL-24 ``motion`` ``(T, 24, 3)`` (metres, y up) at ``clip.fps``.
        kind: ``"kinetic"`` or ``"geometric"``.
        cfg: preprocessing / variant settings (defaults: Bailando).
        metric: name used in error messages.

    Returns:
        float32 ``(len(clips), 72 | 32)``, rows in clip order.
    """
    cfg = cfg or MotionFeatureConfig()
    _check_config(cfg)
    if kind not in FEATURE_KINDS:
        raise ValueError(f"kind must be one of {FEATURE_KINDS}, got {kind!r}")
    clips = list(clips)
    if not clips:
        raise ValueError(f"{metric}: no clips")
    prepared = []
    for clip in clips:
        x = prepare_motion(
            _clip_positions(clip, metric), max_frames=cfg.max_frames, root_shift=cfg.root_shift
        )
        if x.shape[0] < 3:
            raise ValueError(f"{metric}: clip {clip.id!r} has {x.shape[0]} frames; at least 3 are needed")
        if not np.all(np.isfinite(x)):
            raise ValueError(f"{metric}: clip {clip.id!r} motion contains NaN or inf")
        prepared.append(x)

    dim = 72 if kind == "kinetic" else 32
    out = np.empty((len(clips), dim), dtype=np.float32)
    buckets: dict[tuple[int, float, str], list[int]] = {}
    for i, (clip, x) in enumerate(zip(clips, prepared)):
        buckets.setdefault((x.shape[0], float(clip.fps), str(x.dtype)), []).append(i)
    batch = 8  # clips per vectorised call: larger batches leave the cache and run slower
    for (_, fps, _), indices in buckets.items():
        for start in range(0, len(indices), batch):
            idx = indices[start : start + batch]
            stacked = np.stack([prepared[i] for i in idx])
            if kind == "kinetic":
                frame_time = cfg.frame_time if cfg.frame_time is not None else 1.0 / fps
                out[idx] = kinetic_features(
                    stacked,
                    frame_time=frame_time,
                    up_axis=cfg.up_axis,  # type: ignore[arg-type]
                    variant=cfg.feature_variant,  # type: ignore[arg-type]
                )
            else:
                out[idx] = geometric_features(stacked, variant=cfg.feature_variant, fps=fps)  # type: ignore[arg-type]
    return out


def _features_name(kind: str) -> str:
    return "kinetic (72-d)" if kind == "kinetic" else "geometric (32-d)"


@dataclasses.dataclass
class _FeatureMetric:
    cfg: Any
    name: str
    kind: str
    needs_reference: bool = True

    def provenance(self) -> dict[str, Any]:
        return {
            "name": self.name,
            "features": _features_name(self.kind),
            "config": dataclasses.asdict(self.cfg),
            "spec": SPEC,
        }

    def _generated(self, generated: Sequence[Clip]) -> list[Clip]:
        return require_clips(generated, self.name)

    def _reference(self, reference: Sequence[Clip] | None) -> list[Clip]:
        if reference is None:
            raise ValueError(
                f"{self.name}: needs reference (ground-truth) clips for the normalisation statistics"
            )
        clips = list(reference)
        if not clips:
            raise ValueError(f"{self.name}: no reference clips")
        return clips


@dataclasses.dataclass
class FIDMetric(_FeatureMetric):
    """FID_k / FID_g over clips (Bailando ``quantized_metrics``)."""

    def __post_init__(self) -> None:
        _check_config(self.cfg)
        if self.cfg.variant not in FID_VARIANTS:
            raise ValueError(f"{self.name}: variant must be one of {FID_VARIANTS}, got {self.cfg.variant!r}")
        if self.cfg.constant not in ("keep", "raise"):
            raise ValueError(f"{self.name}: constant must be 'keep' or 'raise', got {self.cfg.constant!r}")

    def __call__(self, generated: Sequence[Clip], reference: Sequence[Clip] | None = None) -> MetricResult:
        gen = clip_features(self._generated(generated), self.kind, self.cfg, metric=self.name)
        ref = clip_features(self._reference(reference), self.kind, self.cfg, metric=self.name)
        for label, feats in (("generated", gen), ("reference", ref)):
            if feats.shape[0] < 2:
                raise ValueError(
                    f"{self.name}: needs at least 2 {label} clips for a covariance, got {feats.shape[0]}"
                )
        value = fid(
            gen, ref, variant=self.cfg.variant, normalize=self.cfg.normalize, constant=self.cfg.constant
        )
        return {self.name: value}


@dataclasses.dataclass
class _DistanceMetric(_FeatureMetric):
    """Base of Div and Multimodality: an ``accumulate`` mode, and reference clips only when normalising."""

    def __post_init__(self) -> None:
        _check_config(self.cfg)
        if self.cfg.accumulate not in ("reference", "float64"):
            raise ValueError(
                f"{self.name}: accumulate must be 'reference' or 'float64', got {self.cfg.accumulate!r}"
            )
        self.needs_reference = bool(self.cfg.normalize)


@dataclasses.dataclass
class DivMetric(_DistanceMetric):
    """Div_k / Div_g over clips: ``name`` for the generated set, ``name.reference`` for the ground truth."""

    def __call__(self, generated: Sequence[Clip], reference: Sequence[Clip] | None = None) -> MetricResult:
        gen = clip_features(self._generated(generated), self.kind, self.cfg, metric=self.name)
        acc = self.cfg.accumulate
        if not self.cfg.normalize:
            result = {self.name: diversity(gen, normalize=False, accumulate=acc)}
            if reference is not None:
                ref = clip_features(list(reference), self.kind, self.cfg, metric=self.name)
                result[f"{self.name}.reference"] = diversity(ref, normalize=False, accumulate=acc)
            return result
        ref = clip_features(self._reference(reference), self.kind, self.cfg, metric=self.name)
        return {
            self.name: diversity(gen, ref, accumulate=acc),
            f"{self.name}.reference": diversity(ref, ref, accumulate=acc),
        }


@dataclasses.dataclass
class MultimodalityMetric(_DistanceMetric):
    """MoFusion Multimodality over clips grouped by ``clip.meta[group_key]``."""

    def __call__(self, generated: Sequence[Clip], reference: Sequence[Clip] | None = None) -> MetricResult:
        clips = self._generated(generated)
        key = self.cfg.group_key
        groups: dict[Any, list[int]] = {}
        for i, clip in enumerate(clips):
            if key not in clip.meta:
                raise ValueError(
                    f"{self.name}: generated clip {clip.id!r} has no meta[{key!r}] naming the condition it "
                    "was generated for (set group_key to the right meta key)"
                )
            groups.setdefault(clip.meta[key], []).append(i)
        small = [g for g, idx in groups.items() if len(idx) < 2]
        if small:
            raise ValueError(
                f"{self.name}: every condition needs at least 2 generations; {len(small)} have only one "
                f"(e.g. {small[0]!r})"
            )
        gen = clip_features(clips, self.kind, self.cfg, metric=self.name)
        ref = None
        if self.cfg.normalize:
            ref = clip_features(self._reference(reference), self.kind, self.cfg, metric=self.name)
        value = multimodality(
            [gen[idx] for idx in groups.values()],
            ref,
            normalize=self.cfg.normalize,
            accumulate=self.cfg.accumulate,
        )
        return {self.name: value, f"{self.name}.num_conditions": float(len(groups))}


@METRICS.register("fid_k", config=FIDConfig)
def build_fid_k(cfg: FIDConfig) -> FIDMetric:
    """FID on 72-d kinetic features (Bailando FID_k; MoFusion Table 1)."""
    return FIDMetric(cfg, "fid_k", "kinetic")


@METRICS.register("fid_g", config=FIDConfig)
def build_fid_g(cfg: FIDConfig) -> FIDMetric:
    """FID on 32-d geometric (manual) features (Bailando FID_g, ``fid_m`` in its code)."""
    return FIDMetric(cfg, "fid_g", "geometric")


@METRICS.register("div_k", config=DivConfig)
def build_div_k(cfg: DivConfig) -> DivMetric:
    """Diversity on kinetic features (Bailando Div_k)."""
    return DivMetric(cfg, "div_k", "kinetic")


@METRICS.register("div_g", config=DivConfig)
def build_div_g(cfg: DivConfig) -> DivMetric:
    """Diversity on geometric features (Bailando Div_g, ``div_m`` in its code)."""
    return DivMetric(cfg, "div_g", "geometric")


@METRICS.register("multimodality", config=MultimodalityConfig)
def build_multimodality(cfg: MultimodalityConfig) -> MultimodalityMetric:
    """MoFusion Multimodality on kinetic features."""
    return MultimodalityMetric(cfg, "multimodality", "kinetic")
