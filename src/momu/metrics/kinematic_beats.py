"""Music→motion beat scores from kinematic beats (MoMu-Diffusion App. B.5; METRICS.md §3.1).

MoMu reports BCS/CSD/BHS/HSD/F1 for music→motion with ``N_s`` = kinematic beats of the generated
motion, ``N_t`` = musical beats of the ground-truth music, and the kinematic beats taken from the
bin-wise directogram difference ``Q(r)`` (MoMu Eq. 2) "as the indicator". The paper gives no peak
picker; momu makes the motion side a frame-rate-independent copy of the audio side (§1.8):

* ``Q`` = :func:`momu.features.kinematics.motion_kinematic_amplitude` (Eq. 1–2, K = 8 bins, normalised
  to [0, 1] by its maximum, as ``onset_detect`` min-max normalises the onset envelope); ``Q[r]`` belongs
  to motion frame ``r`` (the change from displacement ``r−1→r`` to ``r→r+1``), time ``r / fps``;
* kinematic beats = ``librosa.util.peak_pick(Q, ...)`` with LORIS's ``onset_detect`` parameters converted
  from audio frames (512/22050 s = 23.2 ms) to motion frames: pre/post max and pre/post avg = 3 audio
  frames = 69.7 ms, wait = 1 audio frame = 23.2 ms, each rounded to motion frames (at least 1), and
  ``delta = 0.2``;
* one-second bins over ``ceil(T / fps)`` seconds (``bin[trunc(t)] = 1``) for the motion, LORIS's onset
  bins for the music; per pair both vectors are cut to the shorter (motion and music lengths differ by
  rounding) — ``truncate="reference"`` applies the LORIS rule instead;
* ``BCS = Nm/Ns``, ``BHS = Nm/Nt``, CSD/HSD ``std(ddof=1)``, F1 of the means (§1.8 aggregation).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import librosa
import numpy as np

from momu.data.types import Clip
from momu.features.kinematics import motion_kinematic_amplitude
from momu.metrics._checks import as_motion
from momu.metrics._clips import ClipMetric, clip_audio, clip_motion
from momu.metrics.base import MetricResult
from momu.metrics.loris_scores import (
    LORIS_SR,
    aggregate_beat_scores,
    check_bin_seconds,
    onset_beat_bins,
    pair_beat_scores,
    second_bins,
)
from momu.registry import METRICS

__all__ = [
    "AUDIO_FRAME_S",
    "kinematic_beat_frames",
    "kinematic_beat_bins",
    "kinematic_beat_scores",
    "KinematicBeatScoresConfig",
    "KinematicBeatScoresMetric",
]

AUDIO_FRAME_S = 512 / LORIS_SR
"""Duration of one onset-detection frame of the LORIS reference (23.2 ms)."""


def _frames(seconds: float, fps: float) -> int:
    return max(1, int(round(seconds * fps)))


def kinematic_beat_frames(
    motion: np.ndarray,
    fps: float,
    *,
    bins: int = 8,
    plane: tuple[int, int] = (0, 1),
    window: str = "paper",
    delta: float = 0.2,
    max_window_s: float = 3 * AUDIO_FRAME_S,
    avg_window_s: float = 3 * AUDIO_FRAME_S,
    wait_s: float = AUDIO_FRAME_S,
) -> np.ndarray:
    """Kinematic beat frames of a motion: peaks of MoMu's kinematic amplitude ``Q`` (Eq. 2).

    Args:
        motion: joint positions ``(T, J, 2|3)`` at ``fps`` frames per second.
        bins, plane, window: directogram options (:func:`momu.features.kinematics.directogram`).
        delta: peak threshold above the local mean of the [0, 1]-normalised ``Q``.
        max_window_s / avg_window_s / wait_s: ``peak_pick`` windows in seconds (converted to frames).

    Returns:
        int64 motion-frame indices (seconds = frame / fps). A motionless clip has no beats.
    """
    joints = as_motion(motion, "motion", min_frames=3)
    if not fps or fps <= 0:
        raise ValueError(f"fps: must be > 0, got {fps!r}")
    q = motion_kinematic_amplitude(joints, bins, plane=plane, window=window)
    if not np.any(q > 0):
        return np.zeros(0, dtype=np.int64)
    w_max, w_avg = _frames(max_window_s, fps), _frames(avg_window_s, fps)
    peaks = librosa.util.peak_pick(
        q,
        pre_max=w_max,
        post_max=w_max,
        pre_avg=w_avg,
        post_avg=w_avg,
        delta=float(delta),
        wait=_frames(wait_s, fps),
    )
    return np.asarray(peaks, dtype=np.int64)


def kinematic_beat_bins(
    motion: np.ndarray, fps: float, bin_seconds: float = 1.0, **kwargs: object
) -> np.ndarray:
    """One-second kinematic-beat vector of a motion: ``ceil(T / fps)`` bins (see the module doc).

    ``bin_seconds`` other than 1 gives bins of that width (:func:`~momu.metrics.loris_scores.second_bins`).
    """
    frames = kinematic_beat_frames(motion, fps, **kwargs)  # type: ignore[arg-type]
    return second_bins(frames / float(fps), np.asarray(motion).shape[0] / float(fps), bin_seconds)


def kinematic_beat_scores(
    motions: Sequence[np.ndarray],
    fps: float | Sequence[float],
    music: Sequence[np.ndarray],
    sr: int | Sequence[int],
    *,
    truncate: str = "shortest",
    bin_seconds: float = 1.0,
    **kwargs: object,
) -> dict[str, float]:
    """Music→motion BCS/CSD/BHS/HSD/F1 (MoMu App. B.5): generated motions vs ground-truth music.

    Args:
        motions: generated motions ``(T, J, D)``; ``fps``: their frame rate(s).
        music: the ground-truth music waveforms paired by position; ``sr``: their sample rate(s).
        truncate: ``"shortest"`` (default) or ``"reference"`` (LORIS's rule), see
            :func:`~momu.metrics.loris_scores.pair_beat_scores`.
        bin_seconds: bin width (1 s in MoMu / LORIS).
        kwargs: options of :func:`kinematic_beat_frames`.

    Returns:
        ``{"bcs", "csd", "bhs", "hsd", "f1", "n"}`` (fractions in [0, 1]).
    """
    n = len(motions)
    if len(music) != n:
        raise ValueError(f"kinematic_beat_scores: {n} motions but {len(music)} music waveforms")
    fps_list = [float(fps)] * n if isinstance(fps, (int, float)) else [float(f) for f in fps]
    sr_list = [int(sr)] * n if isinstance(sr, (int, np.integer)) else [int(r) for r in sr]
    if len(fps_list) != n or len(sr_list) != n:
        raise ValueError("kinematic_beat_scores: one fps and one sample rate per pair (or one for all)")
    covers, hits = [], []
    for i in range(n):
        motion_bins = kinematic_beat_bins(motions[i], fps_list[i], bin_seconds, **kwargs)
        music_bins = onset_beat_bins(music[i], sr_list[i], bin_seconds=bin_seconds)
        try:
            cover, hit = pair_beat_scores(music_bins, motion_bins, truncate=truncate)
        except ValueError as exc:
            raise type(exc)(f"pair {i}: {exc}") from None
        covers.append(cover)
        hits.append(hit)
    return aggregate_beat_scores(covers, hits)


@dataclass
class KinematicBeatScoresConfig:
    """Parameters of the registered ``kinematic_beat_scores`` metric (MoMu Table 5).

    Attributes:
        bins: directogram bins K; plane: projection axes for 3D motion; window: ``"paper"``/``"hard"``.
        delta: peak threshold on the normalised ``Q``.
        truncate: ``"shortest"`` or ``"reference"``.
        music_from: ``"reference"`` — the ground-truth music of the paired reference clip (MoMu B.5);
            ``"generated"`` — the generated clip's own audio.
        bin_seconds: bin width in seconds (1 = MoMu's / LORIS's one-second bins).
    """

    bins: int = 8
    plane: tuple[int, int] = (0, 1)
    window: str = "paper"
    delta: float = 0.2
    truncate: str = "shortest"
    music_from: str = "reference"
    bin_seconds: float = 1.0


class KinematicBeatScoresMetric(ClipMetric):
    """Registered ``kinematic_beat_scores``: generated motion against the reference music."""

    def __call__(self, generated: Sequence[Clip], reference: Sequence[Clip] | None = None) -> MetricResult:
        covers, hits = self.pairs(generated, reference)
        scores = aggregate_beat_scores(covers, hits)
        return {f"{self.name}.{k}": v for k, v in scores.items() if k != "n"}

    def pairs(
        self, generated: Sequence[Clip], reference: Sequence[Clip] | None = None
    ) -> tuple[list[float], list[float]]:
        """Per-pair ``(covers, hits)`` (BCS and BHS of each clip; the cell is their aggregate)."""
        cfg: KinematicBeatScoresConfig = self.cfg
        gen = self._require(generated)
        if cfg.music_from == "reference":
            if reference is None or len(reference) != len(gen):
                raise ValueError(
                    f"{self.name}: music_from='reference' needs one reference clip per generated clip"
                )
            music_clips = list(reference)
        elif cfg.music_from == "generated":
            music_clips = gen
        else:
            raise ValueError(
                f"{self.name}: music_from: expected 'reference' or 'generated', got {cfg.music_from!r}"
            )
        covers, hits = [], []
        for g, m in zip(gen, music_clips):
            motion_bins = kinematic_beat_bins(
                clip_motion(g, self.name),
                g.fps,
                cfg.bin_seconds,
                bins=cfg.bins,
                plane=tuple(cfg.plane),
                window=cfg.window,
                delta=cfg.delta,
            )
            music_bins = onset_beat_bins(*clip_audio(m, self.name), bin_seconds=cfg.bin_seconds)
            try:
                cover, hit = pair_beat_scores(music_bins, motion_bins, truncate=cfg.truncate)
            except ValueError as exc:
                raise type(exc)(f"{self.name}: clip {g.id!r}: {exc}") from None
            covers.append(cover)
            hits.append(hit)
        return covers, hits


@METRICS.register("kinematic_beat_scores", config=KinematicBeatScoresConfig)
def build_kinematic_beat_scores(cfg: KinematicBeatScoresConfig) -> KinematicBeatScoresMetric:
    """``kinematic_beat_scores`` (MoMu App. B.5; METRICS.md §3.1)."""
    check_bin_seconds(cfg.bin_seconds)
    return KinematicBeatScoresMetric(
        cfg, name="kinematic_beat_scores", needs_reference=True, spec="METRICS.md §3.1; MoMu B.5, Eq. 1-2"
    )
