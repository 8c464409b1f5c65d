"""The tests of the music-following benchmark, each as one value per (song, seed).

Notation: song ``i`` (a song and its real dance), seed ``s``, the row's output ``o(i, s, f)`` for the
input played ``f`` times faster (``f = 1``: the excerpt itself). The "music side" of pair ``(i, s)`` is
song ``i``'s beats for music → dance and the output's beats for dance → music; the "motion side" is the
output's kinematic beats, or dance ``i``'s.

* ``input_sensitivity`` — ``D_song / (D_song + D_seed)`` with ``D_song = d(o(i, s), o(i+1, s))`` (same
  seed, another input) and ``D_seed = d(o(i, s), o(i, s+1))`` (same input, another seed):
  ½ when another input changes the output as much as another seed, 0 when the input changes nothing
  (0/0, an output that never varies, counts as 0). Passes unless its interval lies below ½.
* ``tempo_following`` — per (i, s) the slope of log output tempo on log input tempo: the median over
  the factors of ``log r_f / log f``, ``r_f`` = :func:`~momu.following.tempo.fold_ratio` of
  ``tempo(o(i, s, f)) / tempo(o(i, s, 1))`` (the median, not a least-squares fit: one octave slip of
  the estimator in four factors does not move it); 1 = the output's tempo follows the input's, 0 = it
  ignores it. An output with no tempo counts as not following (``r_f = 1``). Also
  ``share_within_5pct``: the fraction of factors with ``|r_f / f − 1| ≤ 5 %``.
* ``tempo_match`` — does the output's tempo match song ``i``'s (octave-tolerant, 5 %) more often than
  the other songs' tempi: ``match(i) − mean_{j≠i} match(j)``; chance = 0.
* ``beat_phase_<variant>`` — BAS of the pair against the music side's beats minus BAS against those
  beats moved half a beat later; > 0 when motion beats fall on the beat rather than between.
* ``matched_<variant>`` — the output scored against its own input minus against input ``j``, the other
  song of the closest tempo (the partner); > 0 when the output belongs with its own input.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from momu.following.analysis import Analysis, AudioAnalysis, MotionAnalysis, distance
from momu.following.beat_align import VARIANTS, bas_seconds, half_beat_shift
from momu.following.inputs import Request
from momu.following.tempo import TOLERANCE, fold_ratio, tempo_matches

__all__ = ["TESTS", "Inputs", "tempo_partners", "pair_tests", "generator_tests", "bas_own"]

TESTS = (
    "input_sensitivity",
    "tempo_following",
    "tempo_match",
    *(f"beat_phase_{v}" for v in VARIANTS),
    *(f"matched_{v}" for v in VARIANTS),
)
GENERATOR_ONLY = ("input_sensitivity", "tempo_following")
"""Tests that need outputs for inputs other than the excerpts (another seed, a stretched input)."""


@dataclass
class Inputs:
    """Analyses of the benchmark's songs and dances (excerpts), their reference tempi (BPM, the songs'
    beat grids) and each song's tempo partner (:func:`tempo_partners`)."""

    songs: list[AudioAnalysis]
    dances: list[MotionAnalysis]
    tempo: np.ndarray
    partner: np.ndarray


def tempo_partners(tempo: np.ndarray) -> np.ndarray:
    """For each song the other song whose tempo is closest (in log ratio)."""
    t = np.log(np.asarray(tempo, dtype=np.float64))
    d = np.abs(t[:, None] - t[None, :])
    np.fill_diagonal(d, np.inf)
    d[~np.isfinite(d)] = np.inf
    return np.argmin(d, axis=1)


def _sides(
    direction: str, inputs: Inputs, i: int, output: Analysis
) -> tuple[np.ndarray, dict[str, np.ndarray], float]:
    """Music beats, motion beats per variant and the common duration of pair ``i`` with ``output``."""
    if direction == "dance":
        assert isinstance(output, MotionAnalysis)
        song = inputs.songs[i]
        return song.beats, output.beats, min(song.duration, output.duration)
    assert isinstance(output, AudioAnalysis)
    dance = inputs.dances[i]
    return output.beats, dance.beats, min(dance.duration, output.duration)


def bas_own(
    direction: str, inputs: Inputs, outputs: dict[Request, Analysis], seeds: list[int]
) -> dict[str, np.ndarray]:
    """BAS of each pair (both variants), ``(songs, seeds)`` — descriptive, no verdict."""
    n = len(inputs.songs)
    out: dict[str, np.ndarray] = {v: np.full((n, len(seeds)), np.nan) for v in VARIANTS}
    for i in range(n):
        for k, s in enumerate(seeds):
            o = outputs.get(Request(i, s))
            if o is None:
                continue
            music, motion, dur = _sides(direction, inputs, i, o)
            for v in VARIANTS:
                out[v][i, k] = bas_seconds(music, motion[v], dur, v)
    return out


def pair_tests(
    direction: str, inputs: Inputs, outputs: dict[Request, Analysis], seeds: list[int]
) -> dict[str, np.ndarray]:
    """``tempo_match``, ``beat_phase_*`` and ``matched_*`` as ``(songs, seeds)`` matrices (NaN: no output)."""
    n = len(inputs.songs)
    res = {t: np.full((n, len(seeds)), np.nan) for t in TESTS if t not in GENERATOR_ONLY}
    for i in range(n):
        j = int(inputs.partner[i])
        for k, s in enumerate(seeds):
            o = outputs.get(Request(i, s))
            if o is None:
                continue
            own = float(tempo_matches(o.tempo, inputs.tempo[i]))
            others = [float(tempo_matches(o.tempo, inputs.tempo[m])) for m in range(n) if m != i]
            res["tempo_match"][i, k] = own - float(np.mean(others))
            music, motion, dur = _sides(direction, inputs, i, o)
            for v in VARIANTS:
                score = bas_seconds(music, motion[v], dur, v)
                res[f"beat_phase_{v}"][i, k] = score - bas_seconds(half_beat_shift(music), motion[v], dur, v)
                if direction == "dance":
                    other = bas_seconds(
                        inputs.songs[j].beats, motion[v], min(dur, inputs.songs[j].duration), v
                    )
                else:
                    d = inputs.dances[j]
                    other = bas_seconds(music, d.beats[v], min(dur, d.duration), v)
                res[f"matched_{v}"][i, k] = score - other
    return res


def _index(d_song: float, d_seed: float) -> float:
    total = d_song + d_seed
    return d_song / total if total > 0 else 0.0


def generator_tests(
    outputs: dict[Request, Analysis], songs: int, seeds: list[int], factors: tuple[float, ...]
) -> dict[str, np.ndarray]:
    """``input_sensitivity`` (with its ``seed_distance`` D_seed, the outputs' spread over seeds, and
    ``song_distance`` D_song), ``tempo_following`` and ``tempo_following_share`` as ``(songs, seeds)``.

    ``input_sensitivity`` needs 2 songs and 2 seeds (NaN otherwise); ``tempo_following`` the stretched
    outputs (NaN where missing).
    """
    n, m = songs, len(seeds)
    keys = ("input_sensitivity", "seed_distance", "song_distance", "tempo_following", "tempo_following_share")
    res = {k: np.full((n, m), np.nan) for k in keys}
    x = np.log(np.asarray(factors, dtype=np.float64))
    for i in range(n):
        for k, s in enumerate(seeds):
            o = outputs.get(Request(i, s))
            if o is None:
                continue
            other_song = outputs.get(Request((i + 1) % n, s))
            other_seed = outputs.get(Request(i, seeds[(k + 1) % m]))
            if n > 1 and m > 1 and other_song is not None and other_seed is not None:
                d_song, d_seed = distance(o, other_song), distance(o, other_seed)
                res["input_sensitivity"][i, k] = _index(d_song, d_seed)
                res["seed_distance"][i, k], res["song_distance"][i, k] = d_seed, d_song
            stretched = [outputs.get(Request(i, s, f)) for f in factors]
            if any(a is None for a in stretched):
                continue
            ratios = np.array([fold_ratio(a.tempo / o.tempo) if a is not None else np.nan for a in stretched])
            ratios[~np.isfinite(ratios)] = 1.0  # no tempo: it did not follow
            res["tempo_following"][i, k] = float(np.median(np.log(ratios) / x))
            res["tempo_following_share"][i, k] = float(np.mean(np.abs(ratios / np.exp(x) - 1.0) <= TOLERANCE))
    return res
