"""HarmoGAN's perceptual harmony score ``h`` and hit rate (HarmoGAN §III, §V-E; METRICS.md §3.3).

Pipeline for one music/motion pair (times in **seconds**, both signals starting at t = 0):

1. Audio beats ``B_a`` (§III-B): local maxima of the onset strength — ``librosa.onset.onset_detect``
   with librosa's default peak picking on ``onset_strength`` (mono audio resampled to 22050 Hz, hop 512,
   23.2 ms frames); saliency ``s_a`` = onset strength at the beat.
2. Visual beats ``B_v`` (Eq. 2–3): strict local maxima and minima of the joint velocity sum
   ``j_t = Σ_p ‖v_t^p − v_{t−1}^p‖`` (:func:`momu.features.kinematics.visual_beats`), at ``frame / fps``;
   saliency ``s_v = j`` at the beat, replaced by ``s*_v,i = |s_v,i − s_v,i−1|`` (i ≥ 2) and
   ``|s_v,1 − j_initial|`` (i = 1) (Eq. 5).
3. Saliency masks (Eq. 4, 6): keep audio beat i iff ``s_a,i − λ1·σ(S_a) > 0`` and visual beat i iff
   ``s*_v,i − λ2·σ(S*_v) > 0``; σ is the population standard deviation (``np.std``, ddof 0); λ1 = 0.1,
   λ2 = 1 (§V-B). ``N'``/``M'`` = numbers of salient audio/visual beats.
4. Alignment (Eq. 9–11): ``hp_i = 1`` iff ``min_k |ba'_i − bv'_k| < T_delay`` (0.25 s, strict);
   ``h_s = Σ_i hp_i · sa'_i``; ``h = (1+β²)·h_s / (N'·β² + M')`` with β = 2 — the F_β combination of
   ``h_a = h_s/N'`` and ``h_v = h_s/M'``.
5. Hit rate (§V-E) = ``Σ_i hp_i / N'``, the fraction of salient audio beats with a salient visual beat
   within T_delay.

Choices where the paper is silent (documented in docs/metrics_beats.md):

* **Saliency normalisation**: ``sa'`` is divided by the largest audio-beat saliency of the clip
  (``normalize_saliency=True``), so ``h_s ≤ N'`` and ``h`` does not depend on the loudness scale of the
  onset-strength envelope (the masks are scale invariant either way). ``h ∈ [0, 1]`` whenever
  ``M' ≥ N'``; with fewer visual than audio beats ``h_v`` can exceed 1 and so can ``h``.
* **Empty sets**: no salient audio beat (e.g. silence) → :class:`EmptyBeatsError` (nothing to be in
  harmony with); no salient visual beat (e.g. static motion) → ``h = 0`` and hit rate 0.

The registered metrics (:class:`HarmonyMetric`) score a clip's motion against **its audio cut to the
motion's duration** (beats after the motion ends would count as misses), and, with
``window_seconds`` set, in consecutive windows of that length (HarmoGAN's 6-s Ballroom clips, §V-A),
each window evaluated as a clip of its own (:func:`clip_windows`); a clip's value is the mean over its
windows. Because the saliency normalisation and both masks are relative to the evaluated clip, ``h``
depends on the clip length (docs/papers/harmogan.md, "What the harmony score can and cannot show").

The differentiable surrogate :mod:`momu.losses.harmony` (HarmoGAN Eq. 16) reuses the audio side
(:func:`salient_audio_beats`) and Eq. 11 (:func:`combine_harmony`) from here.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import librosa
import numpy as np

from momu.data.types import Clip
from momu.features.kinematics import velocity_sum, visual_beats
from momu.metrics._audio import prepare_audio
from momu.metrics._checks import EmptyBeatsError, as_motion, as_times
from momu.metrics._clips import ClipMetric, clip_audio, clip_motion
from momu.metrics.base import MetricResult
from momu.registry import METRICS

__all__ = [
    "HarmonyResult",
    "audio_beats",
    "motion_beats_harmogan",
    "saliency_mask",
    "salient_audio_beats",
    "combine_harmony",
    "visual_saliency_star",
    "clip_windows",
    "clip_harmony",
    "harmony_from_beats",
    "harmony",
    "harmony_score",
    "hit_rate",
    "HarmonyConfig",
    "HarmonyMetric",
]

HARMONY_SR = 22050
HARMONY_HOP = 512


@dataclass(frozen=True)
class HarmonyResult:
    """Everything HarmoGAN's alignment computes for one pair.

    Attributes:
        h: harmony score (Eq. 11). h_s: saliency-weighted synchronised count (Eq. 10).
        h_a, h_v: ``h_s/N'`` and ``h_s/M'`` (0 when the denominator is 0).
        hit_rate: fraction of salient audio beats synchronised within T_delay (§V-E).
        n_audio, n_visual: ``N'`` and ``M'``, the numbers of salient beats.
        hits: number of synchronised salient audio beats ``Σ hp_i``.
    """

    h: float
    h_s: float
    h_a: float
    h_v: float
    hit_rate: float
    n_audio: int
    n_visual: int
    hits: int


def audio_beats(audio: np.ndarray, sr: int) -> tuple[np.ndarray, np.ndarray]:
    """HarmoGAN audio beats: ``(times_s, saliency)`` — onset peaks and the onset strength there (§III-B).

    ``audio`` mono ``(S,)`` or ``(C, S)`` at ``sr`` Hz; analysed at 22050 Hz with hop 512 (23.2 ms).
    """
    y = prepare_audio(audio, sr, HARMONY_SR)
    envelope = librosa.onset.onset_strength(y=y, sr=HARMONY_SR, hop_length=HARMONY_HOP)
    frames = librosa.onset.onset_detect(onset_envelope=envelope, sr=HARMONY_SR, hop_length=HARMONY_HOP)
    frames = np.asarray(frames, dtype=np.int64)
    times = librosa.frames_to_time(frames, sr=HARMONY_SR, hop_length=HARMONY_HOP)
    return np.asarray(times, dtype=np.float64), np.asarray(envelope[frames], dtype=np.float64)


def motion_beats_harmogan(motion: np.ndarray, fps: float) -> tuple[np.ndarray, np.ndarray, float]:
    """HarmoGAN visual beats: ``(times_s, saliency s_v, j_initial)`` (Eq. 2–3)."""
    joints = as_motion(motion, "motion", min_frames=2)
    frames, saliency = visual_beats(joints, fps)
    j0 = float(velocity_sum(joints[:2], fps)[0])
    return frames / float(fps), np.asarray(saliency, dtype=np.float64), j0


def visual_saliency_star(saliency: np.ndarray, j_initial: float) -> np.ndarray:
    """HarmoGAN Eq. 5: ``s*_1 = |s_1 − j_initial|``, ``s*_i = |s_i − s_{i−1}|`` for i ≥ 2."""
    s = np.asarray(saliency, dtype=np.float64).reshape(-1)
    if s.size == 0:
        return s
    return np.abs(np.diff(np.concatenate([[float(j_initial)], s])))


def saliency_mask(saliency: np.ndarray, lam: float) -> np.ndarray:
    """HarmoGAN Eq. 4/6: ``s_i − λ·σ(S) > 0`` with σ the population std (ddof 0)."""
    s = np.asarray(saliency, dtype=np.float64).reshape(-1)
    if s.size == 0:
        return np.zeros(0, dtype=bool)
    return (s - lam * np.std(s)) > 0


def salient_audio_beats(
    audio_times: np.ndarray, audio_saliency: np.ndarray, lambda1: float = 0.1, normalize_saliency: bool = True
) -> tuple[np.ndarray, np.ndarray]:
    """HarmoGAN Eq. 4 and 7: the salient audio beats ``B'_a`` and their saliencies ``S'_a``.

    ``S'_a`` is divided by the largest saliency of *all* the clip's audio beats when
    ``normalize_saliency`` (momu's choice for Eq. 10, module docstring).

    Raises:
        EmptyBeatsError: no audio beat, or none survives the λ1 mask.
    """
    ta = as_times(audio_times, "audio_times")
    sa = np.asarray(audio_saliency, dtype=np.float64).reshape(-1)
    if ta.size != sa.size:
        raise ValueError("salient_audio_beats: each audio beat needs exactly one saliency value")
    if not np.all(np.isfinite(sa)) or np.any(sa < 0):
        raise ValueError("salient_audio_beats: saliencies must be finite and >= 0")
    if ta.size == 0:
        raise EmptyBeatsError("harmony: the music has no audio beats (silence?); h is undefined")
    keep = saliency_mask(sa, lambda1)
    if not keep.any():
        raise EmptyBeatsError("harmony: no salient audio beat survives the λ1 mask (Eq. 4)")
    kept = sa[keep] / sa.max() if normalize_saliency else sa[keep]
    return ta[keep], kept


def combine_harmony(h_s: Any, n_audio: Any, n_visual: Any, beta: float = 2.0) -> Any:
    """HarmoGAN Eq. 11: ``h = (1 + β²) h_s / (N' β² + M')`` (floats, arrays or torch tensors alike)."""
    return (1 + beta**2) * h_s / (n_audio * beta**2 + n_visual)


def harmony_from_beats(
    audio_times: np.ndarray,
    audio_saliency: np.ndarray,
    visual_times: np.ndarray,
    visual_saliency: np.ndarray,
    j_initial: float,
    *,
    lambda1: float = 0.1,
    lambda2: float = 1.0,
    t_delay: float = 0.25,
    beta: float = 2.0,
    normalize_saliency: bool = True,
) -> HarmonyResult:
    """HarmoGAN Eq. 4–11 from beat times (seconds) and saliencies.

    Args:
        audio_times, audio_saliency: ``B_a`` and ``S_a`` (onset strength at each beat).
        visual_times, visual_saliency: ``B_v`` and ``S_v`` (velocity sum at each beat).
        j_initial: the first value of the velocity sum (Eq. 5).
        lambda1, lambda2: saliency thresholds of Eq. 4 and 6. t_delay: perceptual delay (s), Eq. 9.
        beta: audio/visual balance of Eq. 11. normalize_saliency: divide ``S_a`` by its maximum.

    Raises:
        EmptyBeatsError: no (salient) audio beat.
    """
    tv, sv = as_times(visual_times, "visual_times"), np.asarray(visual_saliency, dtype=np.float64).reshape(-1)
    if tv.size != sv.size:
        raise ValueError("harmony_from_beats: each beat needs exactly one saliency value")
    if not np.all(np.isfinite(sv)) or np.any(sv < 0):
        raise ValueError("harmony_from_beats: saliencies must be finite and >= 0")
    if t_delay <= 0 or beta <= 0:
        raise ValueError(f"t_delay and beta must be > 0, got t_delay={t_delay}, beta={beta}")
    ba, sa_kept = salient_audio_beats(audio_times, audio_saliency, lambda1, normalize_saliency)
    bv = tv[saliency_mask(visual_saliency_star(sv, j_initial), lambda2)]
    n_a, n_v = int(ba.size), int(bv.size)
    if n_v:
        bv_sorted = np.sort(bv)
        pos = np.searchsorted(bv_sorted, ba)
        left = bv_sorted[np.clip(pos - 1, 0, n_v - 1)]
        right = bv_sorted[np.clip(pos, 0, n_v - 1)]
        hp = np.minimum(np.abs(ba - left), np.abs(ba - right)) < t_delay
    else:
        hp = np.zeros(n_a, dtype=bool)
    h_s = float(np.sum(sa_kept[hp]))
    h = combine_harmony(h_s, n_a, n_v, beta)
    return HarmonyResult(
        h=float(h),
        h_s=h_s,
        h_a=h_s / n_a,
        h_v=h_s / n_v if n_v else 0.0,
        hit_rate=float(hp.sum()) / n_a,
        n_audio=n_a,
        n_visual=n_v,
        hits=int(hp.sum()),
    )


def harmony(
    audio: np.ndarray,
    sr: int,
    motion: np.ndarray,
    fps: float,
    *,
    lambda1: float = 0.1,
    lambda2: float = 1.0,
    t_delay: float = 0.25,
    beta: float = 2.0,
    normalize_saliency: bool = True,
) -> HarmonyResult:
    """HarmoGAN harmony evaluation of one music/motion pair (both starting at t = 0).

    Args:
        audio: waveform ``(S,)`` or ``(C, S)``; sr: its sample rate (Hz).
        motion: joint positions ``(T, J, D)``; fps: its frame rate.
        lambda1, lambda2, t_delay, beta, normalize_saliency: see :func:`harmony_from_beats`.
    """
    ta, sa = audio_beats(audio, sr)
    tv, sv, j0 = motion_beats_harmogan(motion, fps)
    return harmony_from_beats(
        ta,
        sa,
        tv,
        sv,
        j0,
        lambda1=lambda1,
        lambda2=lambda2,
        t_delay=t_delay,
        beta=beta,
        normalize_saliency=normalize_saliency,
    )


def harmony_score(audio: np.ndarray, sr: int, motion: np.ndarray, fps: float, **kwargs: float) -> float:
    """HarmoGAN harmony score ``h`` (Eq. 11) of one pair; see :func:`harmony`."""
    return harmony(audio, sr, motion, fps, **kwargs).h  # type: ignore[arg-type]


def hit_rate(audio: np.ndarray, sr: int, motion: np.ndarray, fps: float, **kwargs: float) -> float:
    """HarmoGAN hit rate (§V-E): fraction of salient audio beats within T_delay of a visual beat."""
    return harmony(audio, sr, motion, fps, **kwargs).hit_rate  # type: ignore[arg-type]


@dataclass
class HarmonyConfig:
    """Parameters of the registered ``harmony`` and ``hit_rate`` metrics (HarmoGAN §V-B values).

    Attributes:
        lambda1: audio saliency threshold (Eq. 4). lambda2: visual saliency threshold (Eq. 6).
        t_delay: perceptual delay in seconds (Eq. 9). beta: balance of Eq. 11.
        normalize_saliency: divide audio saliencies by the clip's maximum.
        window_seconds: evaluate in consecutive windows of this length (HarmoGAN's Ballroom protocol
            uses 6-s clips, §V-A) and average them per clip; ``None``: the whole clip. The audio is cut
            to the motion's duration either way.
    """

    lambda1: float = 0.1
    lambda2: float = 1.0
    t_delay: float = 0.25
    beta: float = 2.0
    normalize_saliency: bool = True
    window_seconds: float | None = None

    def __post_init__(self) -> None:
        if self.window_seconds is not None and not self.window_seconds > 0:
            raise ValueError(f"harmony: window_seconds must be > 0 or null, got {self.window_seconds}")


def clip_windows(
    audio: np.ndarray, sr: int, motion: np.ndarray, fps: float, window_seconds: float | None = None
) -> list[tuple[np.ndarray, np.ndarray]]:
    """``(audio, motion)`` pieces a clip is evaluated on: its audio cut to the motion's duration, or
    consecutive windows of ``window_seconds`` (``round(window_seconds · fps)`` frames each, the tail shorter
    than a window dropped; a clip shorter than one window is one piece).

    Window ``k`` holds motion frames ``[kF, (k+1)F)`` and the audio samples of the same seconds, so both
    modalities start at t = 0 in every piece, as :func:`harmony` expects.
    """
    frames = int(np.asarray(motion).shape[0])
    wave = np.asarray(audio)
    samples = wave.shape[-1]
    per_frame = float(sr) / float(fps)
    if window_seconds is None or frames < int(round(window_seconds * fps)):
        end = min(samples, int(round(frames * per_frame)))
        return [(wave[..., :end], np.asarray(motion))]
    width = int(round(window_seconds * fps))
    pieces = []
    for k in range(frames // width):
        a0, a1 = int(round(k * width * per_frame)), int(round((k + 1) * width * per_frame))
        if a1 > samples:
            break
        pieces.append((wave[..., a0:a1], np.asarray(motion)[k * width : (k + 1) * width]))
    return pieces or [(wave[..., : min(samples, int(round(frames * per_frame)))], np.asarray(motion))]


def clip_harmony(
    clip: Clip, cfg: HarmonyConfig | None = None, metric: str = "harmony"
) -> list[HarmonyResult]:
    """:func:`harmony` of every piece of ``clip`` (:func:`clip_windows`), with ``cfg``'s parameters.

    Raises:
        ValueError: the clip has no motion or audio, or a piece has no audio beat (named by clip id).
    """
    cfg = cfg or HarmonyConfig()
    motion = clip_motion(clip, metric)
    audio, sr = clip_audio(clip, metric)
    results = []
    for k, (wave, pose) in enumerate(clip_windows(audio, sr, motion, clip.fps, cfg.window_seconds)):
        try:
            results.append(
                harmony(
                    wave,
                    sr,
                    pose,
                    clip.fps,
                    lambda1=cfg.lambda1,
                    lambda2=cfg.lambda2,
                    t_delay=cfg.t_delay,
                    beta=cfg.beta,
                    normalize_saliency=cfg.normalize_saliency,
                )
            )
        except ValueError as exc:
            where = f" window {k}" if cfg.window_seconds is not None else ""
            raise type(exc)(f"{metric}: clip {clip.id!r}{where}: {exc}") from None
    return results


class HarmonyMetric(ClipMetric):
    """Registered ``harmony`` / ``hit_rate``: mean over the generated clips of each clip's mean over its
    pieces (:func:`clip_harmony`; motion vs the clip's music cut to the motion)."""

    score_field: str = "h"

    def per_clip(self, generated: Sequence[Clip]) -> np.ndarray:
        """``(N,)`` per-clip values (each the mean over the clip's windows)."""
        cfg: HarmonyConfig = self.cfg
        return np.asarray(
            [
                np.mean([getattr(r, self.score_field) for r in clip_harmony(clip, cfg, self.name)])
                for clip in self._require(generated)
            ],
            dtype=np.float64,
        )

    def __call__(self, generated: Sequence[Clip], reference: Sequence[Clip] | None = None) -> MetricResult:
        return {self.name: float(np.mean(self.per_clip(generated)))}


@METRICS.register("harmony", config=HarmonyConfig)
def build_harmony(cfg: HarmonyConfig) -> HarmonyMetric:
    """``harmony``: HarmoGAN harmony score h (Eq. 11; Table I)."""
    spec = "METRICS.md §3.3; HarmoGAN Eq. 1-11"
    metric = HarmonyMetric(cfg, name="harmony", needs_reference=False, spec=spec)
    metric.score_field = "h"
    return metric


@METRICS.register("hit_rate", config=HarmonyConfig)
def build_hit_rate(cfg: HarmonyConfig) -> HarmonyMetric:
    """``hit_rate``: HarmoGAN hit rate of salient audio beats (§V-E; Table II)."""
    metric = HarmonyMetric(cfg, name="hit_rate", needs_reference=False, spec="METRICS.md §3.3; HarmoGAN §V-E")
    metric.score_field = "hit_rate"
    return metric
