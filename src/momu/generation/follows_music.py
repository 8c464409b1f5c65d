"""Does a generated dance follow *its* song? Own-song vs other-song scores, paired per song, with intervals.

Superseded by the calibrated music-following benchmark (:mod:`momu.following`,
``recipes/music_following.py``, docs/following.md), which adds input sensitivity, tempo following,
beat phase, calibration rows and verdicts; this module stays as the short own-vs-other check of
``benchmarks/shipped_follows_synth.py`` and ``benchmarks/long_song_follows_music.py``, and scores BAS
with the benchmark's code.

For every song ``i`` the model dances ``g_i`` (per seed). ``g_i`` is scored against its own song and
against another song ``π(i) = i + 1 mod n`` cut to the same length, with

* **BAS** (Bailando's definition, :func:`momu.following.beat_align.bas_seconds`): the song's beats
  (librosa) against the dance's kinematic beats, both at the benchmark's common rate, σ = 50 ms;
* **kinematic-beat F1** (MoMu App. B.5, LORIS scores): the song's onset bins against the dance's
  kinematic-beat bins (MoMu Eq. 2), ``bin_seconds`` wide; per song, the harmonic mean of that pair's
  beat coverage and hit rate (the table F1 is the harmonic mean of their means over pairs).

A dance that follows its music scores higher against its own song. The difference ``own − other`` is
averaged over seeds per song and summarised over songs by its mean and a 95 % Student-t interval
(n = songs); "follows" is claimed only when the interval lies above 0. The same numbers for the
ground-truth dances (when given) show what the metrics can see on that data.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
from scipy import stats

from momu.following.beat_align import bas_seconds, kinematic_beats
from momu.following.signals import motion_at_rate, song_beats
from momu.metrics.kinematic_beats import kinematic_beat_bins
from momu.metrics.loris_scores import onset_beat_bins, pair_beat_scores

__all__ = ["Song", "pair_scores", "follow_music_study", "interval"]


@dataclass(frozen=True)
class Song:
    """A held-out song (mono waveform) and, optionally, its real dance."""

    id: str
    audio: np.ndarray
    sample_rate: int
    dance: np.ndarray | None = None
    dance_fps: float | None = None


def _bas(motion: np.ndarray, fps: float, audio: np.ndarray, sr: int) -> float:
    dance = kinematic_beats(motion_at_rate(motion, fps), "bailando")
    return bas_seconds(song_beats(audio, sr), dance, motion.shape[0] / fps, "bailando")


def _f1(motion: np.ndarray, fps: float, audio: np.ndarray, sr: int, bin_seconds: float) -> float:
    """One pair's F1: the harmonic mean of its beat coverage and hit rate (MoMu App. B.5 per pair)."""
    motion_bins = kinematic_beat_bins(motion, fps, bin_seconds)
    music_bins = onset_beat_bins(audio, sr, bin_seconds=bin_seconds)
    cover, hit = pair_beat_scores(music_bins, motion_bins, truncate="shortest")
    return 2 * cover * hit / (cover + hit) if cover + hit > 0 else 0.0


def pair_scores(
    motion: np.ndarray, fps: float, own: Song, other: Song, bin_seconds: float
) -> dict[str, float]:
    """BAS and F1 of ``motion`` against its own song and against ``other``, both cut to its length."""
    seconds = motion.shape[0] / fps
    out = {}
    for name, song in (("own", own), ("other", other)):
        n = min(len(song.audio), int(round(seconds * song.sample_rate)))
        audio = song.audio[:n]
        frames = min(motion.shape[0], int(np.floor(n / song.sample_rate * fps)))
        out[f"bas_{name}"] = _bas(motion[:frames], fps, audio, song.sample_rate)
        out[f"f1_{name}"] = _f1(motion[:frames], fps, audio, song.sample_rate, bin_seconds)
    return out


def interval(values: Sequence[float], confidence: float = 0.95) -> dict[str, float]:
    """Mean and Student-t ``confidence`` interval of ``values`` (``n`` songs)."""
    x = np.asarray(values, dtype=np.float64)
    mean = float(x.mean())
    if len(x) < 2:
        return {"mean": mean, "low": float("nan"), "high": float("nan"), "n": float(len(x))}
    half = float(stats.t.ppf(0.5 + confidence / 2, len(x) - 1) * x.std(ddof=1) / np.sqrt(len(x)))
    return {"mean": mean, "low": mean - half, "high": mean + half, "n": float(len(x))}


def _summary(per_song: list[dict[str, float]]) -> dict[str, dict[str, float]]:
    out = {}
    for metric in ("bas", "f1"):
        for side in ("own", "other"):
            out[f"{metric}_{side}"] = interval([s[f"{metric}_{side}"] for s in per_song])
        out[f"{metric}_own_minus_other"] = interval(
            [s[f"{metric}_own"] - s[f"{metric}_other"] for s in per_song]
        )
    return out


def follow_music_study(
    songs: Sequence[Song],
    generate: Callable[[Song, int], tuple[np.ndarray, float]],
    seeds: Sequence[int],
    *,
    bin_seconds: float = 0.25,
) -> dict[str, object]:
    """Own- vs other-song scores of generated (and real) dances; see the module docstring.

    Args:
        songs: at least two held-out songs.
        generate: ``(song, seed) -> (motion (T, J, D), fps)``.
        seeds: generation seeds (scores are averaged over them per song).
        bin_seconds: F1 bin width.
    """
    if len(songs) < 2:
        raise ValueError("follow_music_study: needs at least two songs (each is compared with another)")
    other = [songs[(i + 1) % len(songs)] for i in range(len(songs))]
    generated, truth = [], []
    for song, alt in zip(songs, other):
        per_seed = []
        for seed in seeds:
            motion, fps = generate(song, seed)
            per_seed.append(pair_scores(motion, fps, song, alt, bin_seconds))
        generated.append({k: float(np.mean([p[k] for p in per_seed])) for k in per_seed[0]} | {"id": song.id})  # type: ignore[dict-item]
        if song.dance is not None and song.dance_fps:
            truth.append(pair_scores(song.dance, song.dance_fps, song, alt, bin_seconds) | {"id": song.id})  # type: ignore[dict-item]
    result: dict[str, object] = {
        "songs": [s.id for s in songs],
        "seeds": list(seeds),
        "bin_seconds": bin_seconds,
        "generated": {"per_song": generated, "summary": _summary(generated)},  # type: ignore[arg-type]
    }
    if len(truth) == len(songs):
        result["ground_truth"] = {"per_song": truth, "summary": _summary(truth)}  # type: ignore[arg-type]
    return result
