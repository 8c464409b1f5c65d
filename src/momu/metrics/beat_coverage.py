"""Dancing2Music-style beat coverage / beat hit in the motion domain (METRICS.md §1.7).

D2M (NVlabs/Dancing2Music) publishes no evaluation code; the public implementation of its definitions
is Ruilong Li's AIST++ metrics utility (``calculate_metrics`` / ``select_aligned``, verbatim in
GuHuangAI/GCDG ``evaluation/metric.py``). Per sequence, at 60 fps:

* music beats: mint recipe (§1.5) with ``start_bpm = bpm`` (default 120), one entry per onset frame;
* motion beats: mint detector (summed joint speed, order-10 minima, §1.6);
* both cut to ``end_id = min(len(motion envelope), len(music envelope))``;
* ``beat_coverage = #motion beats / (#music beats + 1e-6)`` (can exceed 1);
* ``beat_hit = #aligned / (#motion beats + 1e-6)`` with the greedy one-to-one :func:`select_aligned`
  (tolerance 12 frames = 0.2 s);
* ``beat_alignment`` = mint's alignment score (σ = 3 frames, over motion beats).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from momu.metrics._checks import EmptyBeatsError, as_frames, as_motion
from momu.metrics.beat_align import beat_align_score
from momu.metrics.beats import motion_beats

__all__ = ["select_aligned", "beat_coverage_scores", "beat_coverage_dataset"]

EPS = 1e-6


def select_aligned(
    music_beats: np.ndarray, motion_beats: np.ndarray, *, tol: float = 12
) -> tuple[np.ndarray, np.ndarray]:
    """Greedy one-to-one matching of motion beats to music beats (Ruilong Li's ``select_aligned``).

    For each motion beat in increasing order, the nearest music beat not yet used (ties → the lower
    index) is taken; the pair is accepted, and the music beat marked used, if ``|Δ| ≤ tol`` frames.

    Returns:
        ``(music_aligned, motion_aligned)``: the matched frame indices, in motion-beat order.

    Raises:
        EmptyBeatsError: there are motion beats but no music beats (the reference's ``argmin`` of
            an empty array).
    """
    music = as_frames(music_beats, "music_beats")
    motion = as_frames(motion_beats, "motion_beats")
    if motion.size and not music.size:
        raise EmptyBeatsError("select_aligned: motion beats but no music beats to align them to")
    used = np.zeros(music.size, dtype=bool)
    music_aligned: list[int] = []
    motion_aligned: list[int] = []
    # Greedy and order dependent by definition: one pass over the (few) motion beats.
    for beat in motion:
        dists = np.abs(music - beat).astype(np.float32)
        dists[used] = np.inf
        ind = int(np.argmin(dists))
        if dists[ind] > tol:
            continue
        used[ind] = True
        music_aligned.append(int(music[ind]))
        motion_aligned.append(int(beat))
    return np.asarray(music_aligned, dtype=np.int64), np.asarray(motion_aligned, dtype=np.int64)


def beat_coverage_scores(
    motion: np.ndarray,
    music_beats: np.ndarray,
    num_music_frames: int,
    *,
    tol: float = 12,
    sigma: float = 3.0,
    start_frame: int = 0,
) -> dict[str, float]:
    """D2M beat coverage, beat hit and beat alignment of one sequence (METRICS.md §1.7).

    Args:
        motion: joint positions ``(T, J, D)`` at 60 fps.
        music_beats: music beat frames at 60 fps (:func:`~momu.metrics.beats.music_beats` with
            ``recipe="mint", start_bpm=bpm``) or the one-hot vector.
        num_music_frames: length of the music onset envelope (frames); with ``T`` it sets
            ``end_id = min(T, num_music_frames)``.
        tol: alignment tolerance in frames (12 = 0.2 s).
        sigma: alignment-score width in frames.
        start_frame: ``start_id`` of the reference (frames before it are dropped).

    Returns:
        ``{"beat_coverage", "beat_hit", "beat_alignment"}``.

    Raises:
        EmptyBeatsError: motion beats but no music beats (alignment undefined; the reference
            raises). With no music beats and no motion beats coverage is 0 and hit 0.
    """
    joints = as_motion(motion, "motion", min_frames=2)
    music = as_frames(music_beats, "music_beats")
    end = min(joints.shape[0], int(num_music_frames))
    dance = motion_beats(joints, variant="mint")
    music = music[(music >= start_frame) & (music < end)]
    dance = dance[(dance >= start_frame) & (dance < end)]
    _, aligned = select_aligned(music, dance, tol=tol)
    return {
        "beat_coverage": dance.size / (music.size + EPS),
        "beat_hit": aligned.size / (dance.size + EPS),
        "beat_alignment": beat_align_score(music, dance, sigma=sigma, over="motion"),
    }


def beat_coverage_dataset(
    motions: Sequence[np.ndarray],
    music_beats: Sequence[np.ndarray],
    num_music_frames: Sequence[int],
    *,
    tol: float = 12,
    sigma: float = 3.0,
) -> dict[str, float]:
    """Dataset values of :func:`beat_coverage_scores`: ``sum / n`` over sequences, per key."""
    if not (len(motions) == len(music_beats) == len(num_music_frames)):
        raise ValueError("beat_coverage_dataset: motions, music_beats and num_music_frames differ in length")
    if not motions:
        raise ValueError("beat_coverage_dataset: no sequences")
    rows = [
        beat_coverage_scores(m, b, n, tol=tol, sigma=sigma)
        for m, b, n in zip(motions, music_beats, num_music_frames)
    ]
    return {key: sum(r[key] for r in rows) / len(rows) for key in rows[0]}
