"""Beat Align Score (BAS), MoFusion Eq. 10 — both reference variants (METRICS.md §1.6).

* ``"bailando"`` (Bailando ``utils/beat_align_score.py``; MoFusion Eq. 10): averaged over **music**
  beats, ``BA = (1/|M|) Σ_{b∈M} exp(−min_{d∈D} (d − b)² / (2σ²))`` with σ = 3 frames (50 ms at 60 fps);
  motion beats from the smoothed mean joint speed (order-1 minima), music beats truncated to the first
  T−1 frames; dataset value = mean over sequences.
* ``"mint"`` (mint/FACT ``tools/calculate_beat_scores.py``): averaged over **motion** beats,
  ``(1/|D|) Σ_{d∈D} exp(−min_{b∈M} (b − d)² / (2σ²))`` in float32; motion beats from the summed joint
  speed (order-10 minima), music beats ``[:T]``; an optional ``seed_frames`` prefix (120 for mint's
  generated results) is dropped from both; no motion beats → 0.0.

σ is in frames of the motion (METRICS.md §2.7): 3 frames is 50 ms at 60 fps but 100 ms at 30 fps.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Literal

import numpy as np

from momu.data.types import Clip
from momu.metrics._checks import EmptyBeatsError, as_frames, as_motion
from momu.metrics._clips import ClipMetric, clip_audio, clip_beat_times, clip_motion
from momu.metrics.base import MetricResult
from momu.metrics.beats import MUSIC_FPS, aistpp_tempo, motion_beats, music_beats, resample_beat_frames
from momu.registry import METRICS

__all__ = ["beat_align_score", "bas", "bas_dataset", "nearest_distances", "BASConfig", "BASMetric"]

Variant = Literal["bailando", "mint"]


def nearest_distances(queries: np.ndarray, targets: np.ndarray) -> np.ndarray:
    """``|q − nearest target|`` for every query (both 1-D int frame arrays; ``targets`` non-empty)."""
    t = np.sort(np.asarray(targets, dtype=np.int64))
    q = np.asarray(queries, dtype=np.int64)
    pos = np.searchsorted(t, q)
    left = t[np.clip(pos - 1, 0, len(t) - 1)]
    right = t[np.clip(pos, 0, len(t) - 1)]
    return np.minimum(np.abs(q - left), np.abs(q - right))


def beat_align_score(
    music_beats: np.ndarray,
    motion_beats: np.ndarray,
    *,
    sigma: float = 3.0,
    over: Literal["music", "motion"] = "music",
) -> float:
    """Gaussian beat-alignment score of one sequence from beat frame indices (same frame rate).

    Args:
        music_beats: music beat frames (int indices or a boolean one-hot vector).
        motion_beats: motion beat frames (idem).
        sigma: Gaussian width in frames.
        over: ``"music"`` — Bailando / MoFusion Eq. 10, mean over music beats of the nearest motion
            beat's ``exp(−Δ²/2σ²)`` (float64); ``"motion"`` — mint, mean over motion beats of the
            nearest music beat's score (float32, as the reference).

    Returns:
        A score in [0, 1]; 1 when every averaged beat coincides with a beat of the other set.

    Raises:
        EmptyBeatsError: ``over="music"`` with no music or no motion beats (the reference raises
            ``ZeroDivisionError`` / ``ValueError``); ``over="motion"`` with no music beats. With
            ``over="motion"`` and no motion beats the reference's value 0.0 is returned.
    """
    if not sigma > 0:
        raise ValueError(f"sigma: must be > 0 frames, got {sigma!r}")
    music = as_frames(music_beats, "music_beats")
    motion = as_frames(motion_beats, "motion_beats")
    if over == "music":
        if music.size == 0:
            raise EmptyBeatsError("beat_align_score: no music beats to average over (Bailando divides by 0)")
        if motion.size == 0:
            raise EmptyBeatsError("beat_align_score: no motion beats (static motion?); BAS is undefined")
        d2 = nearest_distances(music, motion) ** 2
        scores = np.exp(-d2 / 2 / sigma**2)
        return float(np.cumsum(scores)[-1] / len(scores))
    if over == "motion":
        if motion.size == 0:
            return 0.0
        if music.size == 0:
            raise EmptyBeatsError("beat_align_score: no music beats to match the motion beats against")
        d = nearest_distances(motion, music).astype(np.float32)
        scores32 = np.exp(-(d**2) / 2 / np.float32(sigma**2)).astype(np.float32)
        return float(np.cumsum(scores32, dtype=np.float32)[-1] / np.float32(len(scores32)))
    raise ValueError(f"over: expected 'music' or 'motion', got {over!r}")


def bas(
    motion: np.ndarray,
    music_beats: np.ndarray,
    *,
    variant: Variant = "bailando",
    sigma: float = 3.0,
    seed_frames: int = 0,
) -> float:
    """Beat Align Score of one motion against its music beats (METRICS.md §1.6).

    Args:
        motion: joint positions ``(T, J, D)`` at frame rate f (60 fps for AIST++; any unit).
        music_beats: music beat frame indices at the same frame rate f (e.g. :func:`music_beats`
            at 60 fps, or :func:`~momu.metrics.beats.resample_beat_frames` for other rates).
        variant: ``"bailando"`` (over music beats; music beats < T−1 kept) or ``"mint"`` (over motion
            beats; music beats < T kept).
        sigma: Gaussian width in frames of f.
        seed_frames: frames at the start dropped from both beat sets (mint scores generated motion
            after 120 seed frames).

    Returns:
        BAS in [0, 1].
    """
    joints = as_motion(motion, "motion", min_frames=3)
    music = as_frames(music_beats, "music_beats")
    if seed_frames < 0:
        raise ValueError(f"seed_frames: must be >= 0, got {seed_frames}")
    if variant == "bailando":
        dance = motion_beats(joints, variant="bailando")
        music = music[music < joints.shape[0] - 1]
        over: Literal["music", "motion"] = "music"
    elif variant == "mint":
        dance = motion_beats(joints, variant="mint")
        music = music[music < joints.shape[0]]
        over = "motion"
    else:
        raise ValueError(f"variant: expected 'bailando' or 'mint', got {variant!r}")
    if seed_frames:
        dance, music = dance[dance >= seed_frames], music[music >= seed_frames]
    return beat_align_score(music, dance, sigma=sigma, over=over)


def bas_dataset(
    motions: Sequence[np.ndarray],
    music_beats: Sequence[np.ndarray],
    *,
    variant: Variant = "bailando",
    sigma: float = 3.0,
    seed_frames: int = 0,
) -> float:
    """Dataset BAS: the mean of :func:`bas` over sequences (``np.mean`` for Bailando, ``sum/n`` for mint)."""
    if len(motions) != len(music_beats):
        raise ValueError(f"bas_dataset: {len(motions)} motions but {len(music_beats)} music beat lists")
    if not motions:
        raise ValueError("bas_dataset: no sequences")
    scores = [
        bas(m, b, variant=variant, sigma=sigma, seed_frames=seed_frames) for m, b in zip(motions, music_beats)
    ]
    return float(np.mean(scores)) if variant == "bailando" else sum(scores) / len(scores)


@dataclass
class BASConfig:
    """Parameters of the registered ``bas`` metric.

    Attributes:
        variant: ``"bailando"`` (MoFusion Eq. 10, over music beats) or ``"mint"`` (over motion beats).
        sigma: Gaussian width in motion frames (3 = 50 ms at 60 fps).
        sigma_seconds: if set, overrides ``sigma`` with ``sigma_seconds × fps`` frames (compare across
            frame rates).
        music_beats: ``"audio"`` — extract beats from the clip's audio (§1.5); ``"meta"`` — use
            ``clip.meta["beat_times"]`` (seconds).
        recipe: music-beat recipe (``"bailando"``/``"mint"``); ``None`` = the same as ``variant``.
        start_bpm: beat-tracker tempo prior; ``None`` = 120, or mint's genre tempo when the clip id
            holds an AIST++ music id and the recipe is ``"mint"``.
        seed_frames: leading frames dropped from both beat sets.
    """

    variant: str = "bailando"
    sigma: float = 3.0
    sigma_seconds: float | None = None
    music_beats: str = "audio"
    recipe: str | None = None
    start_bpm: float | None = None
    seed_frames: int = 0


def clip_music_beat_frames(
    clip: Clip, metric: str, source: str, recipe: str, start_bpm: float | None
) -> np.ndarray:
    """Music beat frames of ``clip`` at the clip's motion frame rate."""
    if source == "meta":
        times = clip_beat_times(clip, metric)
        return np.unique(np.round(times * clip.fps).astype(np.int64))
    if source != "audio":
        raise ValueError(f"{metric}: music_beats must be 'audio' or 'meta', got {source!r}")
    audio, sr = clip_audio(clip, metric)
    bpm = start_bpm
    if bpm is None and recipe == "mint":
        try:
            bpm = aistpp_tempo(clip.id)
        except ValueError:
            bpm = None
    frames = music_beats(audio, sr, recipe=recipe, start_bpm=bpm)  # type: ignore[arg-type]
    return resample_beat_frames(frames, MUSIC_FPS, clip.fps)


class BASMetric(ClipMetric):
    """Registered ``bas``: mean BAS of the generated clips against their own music."""

    def __call__(self, generated: Sequence[Clip], reference: Sequence[Clip] | None = None) -> MetricResult:
        cfg: BASConfig = self.cfg
        recipe = cfg.recipe or cfg.variant
        scores = []
        for clip in self._require(generated):
            motion = clip_motion(clip, self.name)
            sigma = cfg.sigma if cfg.sigma_seconds is None else cfg.sigma_seconds * clip.fps
            beats = clip_music_beat_frames(clip, self.name, cfg.music_beats, recipe, cfg.start_bpm)
            try:
                scores.append(
                    bas(motion, beats, variant=cfg.variant, sigma=sigma, seed_frames=cfg.seed_frames)  # type: ignore[arg-type]
                )
            except ValueError as exc:
                raise type(exc)(f"{self.name}: clip {clip.id!r}: {exc}") from None
        value = float(np.mean(scores)) if cfg.variant == "bailando" else sum(scores) / len(scores)
        return {self.name: value}


@METRICS.register("bas", config=BASConfig)
def build_bas(cfg: BASConfig) -> BASMetric:
    """``bas`` (MoFusion Eq. 10, METRICS.md §1.6)."""
    if cfg.variant not in ("bailando", "mint"):
        raise ValueError(f"bas.variant: expected 'bailando' or 'mint', got {cfg.variant!r}")
    return BASMetric(cfg, name="bas", needs_reference=False, spec="METRICS.md §1.6; MoFusion Eq. 10")
