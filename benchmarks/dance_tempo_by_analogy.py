"""Can a dance's song tempo be learned from other dances? Tempo by analogy with the training dances
(issue 32, the dance → music direction's tempo match).

    python benchmarks/dance_tempo_by_analogy.py [--data ../shared/data/dance_with_melody] [--out FILE.json]
    python benchmarks/dance_tempo_by_analogy.py --seconds 30 --out FILE.json  # ..._by_analogy_30s.json

``dance_tempo_vs_song.py`` reads a tempo from the dance alone and tries fixed multiples of it; this asks
whether the *training* dances can supply the multiple. Each dance's excerpt (``--seconds``, default 15:
the music-following benchmark's, 2 s in) is described by the spectrum of its motion envelope on a log-BPM
axis (20-400 BPM, 0.5 % steps; log power, standardised). The references are every window of that length
(7.5-s hop) of the train split's dances with the tempo of their song's window (librosa's beat grid, as the
benchmark reads it). A query's tempo is the reference tempo times the time scale ``f`` (within ×1/1.6 …
×1.6) that best aligns the query's spectrum with the reference's, taken from the best-correlated
(reference, ``f``) — a nearest neighbour that learns each kind of dance's ratio of movement to beat and is
invariant to tempo by construction. Train dances are scored leave-one-dance-out.

Scored like the benchmark's dance → music ``tempo_match`` (:func:`momu.following.checks.pair_tests`):
own song's tempo matched (:func:`momu.following.tempo.tempo_matches`, 5 %, ×1 ×2 ×½ ×3 ×⅓) minus the
share of the split's other songs matched; mean and bootstrap interval over dances. Ground truth's
score (the song itself: 1 − the share of other songs its tempo matches) is the ceiling beside it.
Two envelopes, both reported: the mean joint speed (the benchmark's) and the kinematic onset
(``motion_rhythm``'s, :func:`momu.features.rhythm.motion_envelope`). The design was fixed before any
split was scored; nothing was tuned.
"""

from __future__ import annotations

import json
import logging

import numpy as np
from study_common import study_args, write_study  # benchmarks/study_common.py

from momu.features.rhythm import ENVELOPE_RATE, motion_envelope
from momu.following.analysis import analyse_audio
from momu.following.pairs import Pair, dataset_node, load_pairs
from momu.following.signals import RATE, joint_speed, motion_at_rate
from momu.following.stats import song_seed_bootstrap
from momu.following.tempo import tempo_matches

HOP_S = 7.5
LOG_STEP = 0.005
GRID = np.exp(np.arange(np.log(20.0), np.log(400.0), LOG_STEP))
MAX_SCALE = 1.6
SHIFTS = np.arange(-int(np.log(MAX_SCALE) / LOG_STEP), int(np.log(MAX_SCALE) / LOG_STEP) + 1)
ENVELOPES = ("joint_speed", "kinematic_onset")
log = logging.getLogger("dance_tempo_by_analogy")


def log_spectrum(envelope: np.ndarray, rate: float) -> np.ndarray:
    """Standardised log power of the detrended, Hann-windowed envelope on :data:`GRID`."""
    x = np.asarray(envelope, dtype=np.float64)
    t = np.arange(x.size)
    x = x - np.polyval(np.polyfit(t, x, 1), t)
    n = max(x.size, int(rate * 60.0 / 0.05))
    power = np.abs(np.fft.rfft(x * np.hanning(x.size), n)) ** 2
    s = np.log(np.interp(GRID, np.fft.rfftfreq(n, 1.0 / rate) * 60.0, power) + 1e-6 * power.max())
    return (s - s.mean()) / s.std()


def describe(pair: Pair, offset: float, envelope: str) -> np.ndarray:
    motion = pair.excerpt_motion(offset)
    if envelope == "joint_speed":
        return log_spectrum(joint_speed(motion_at_rate(motion, pair.fps)), RATE)
    return log_spectrum(motion_envelope(motion, pair.fps), ENVELOPE_RATE)


def song_tempo(pair: Pair, offset: float = 0.0) -> float:
    return float(analyse_audio(pair.excerpt_audio(offset), pair.sample_rate).beat_tempo)


def best_alignment(query: np.ndarray, ref: np.ndarray) -> tuple[float, float]:
    """``(correlation, f)``: the time scale ``f`` of the query relative to the reference whose shifted
    spectra correlate best (the query's spectrum at log BPM ``x`` matches the reference's at
    ``x − log f``)."""
    best = (-np.inf, 1.0)
    for k in SHIFTS:
        a, b = (query[k:], ref[: len(ref) - k]) if k >= 0 else (query[:k], ref[-k:])
        c = float(np.mean(a * b))
        if c > best[0]:
            best = (c, float(np.exp(k * LOG_STEP)))
    return best


def main() -> None:
    args = study_args(__doc__, "dance_tempo_by_analogy")
    splits = {
        s: load_pairs(dataset_node(args.data, s, "dwm21", args.seconds, 100), args.seconds, None)
        for s in ("train", "val", "test")
    }
    songs = {s: [song_tempo(q) for q in pairs] for s, pairs in splits.items()}
    windows = []  # (train pair, offset, its song's tempo): the references, whatever the envelope
    for q in splits["train"]:
        length = min(len(q.motion) / q.fps, len(q.audio) / q.sample_rate) - q.start - args.seconds
        windows += [(q, off, song_tempo(q, off)) for off in np.arange(0.0, length, HOP_S)]
    windows = [w for w in windows if np.isfinite(w[2])]
    out: dict = {"excerpt_s": args.seconds, "max_scale": MAX_SCALE, "summary": {}, "dances": []}
    for envelope in ENVELOPES:
        refs = [(q.id, describe(q, off, envelope), tempo) for q, off, tempo in windows]
        for split, pairs in splits.items():
            own = songs[split]
            score, ceiling = [], []
            for i, q in enumerate(pairs):
                spec = describe(q, 0.0, envelope)
                fits = [(*best_alignment(spec, s), t, rid) for rid, s, t in refs if rid != q.id]
                corr, scale, ref_tempo, ref_id = max(fits, key=lambda f: f[0])
                tempo = ref_tempo * scale
                others = [tempo_matches(tempo, own[j]) for j in range(len(pairs)) if j != i]
                score.append(float(tempo_matches(tempo, own[i])) - float(np.mean(others)))
                gt_others = [tempo_matches(own[i], own[j]) for j in range(len(pairs)) if j != i]
                ceiling.append(1.0 - float(np.mean(gt_others)))
                row = {"envelope": envelope, "id": q.id, "split": split, "song_bpm": round(own[i], 1)}
                row |= {"predicted_bpm": round(tempo, 1), "reference": ref_id, "correlation": round(corr, 3)}
                out["dances"].append(row | {"matches": bool(tempo_matches(tempo, own[i]))})
                log.info("%s", out["dances"][-1])
            matched = sum(r["matches"] for r in out["dances"][-len(pairs) :])
            est, gt = song_seed_bootstrap(np.array(score)), song_seed_bootstrap(np.array(ceiling))
            out["summary"].setdefault(envelope, {})[split] = {
                "own_song_matched": f"{matched} of {len(pairs)}",
                "tempo_match": [round(v, 3) for v in (est.estimate, est.low, est.high)],
                "ground_truth": [round(v, 3) for v in (gt.estimate, gt.low, gt.high)],
            }
    log.info("%s", json.dumps(out["summary"], indent=1))
    write_study(args.out, out)


if __name__ == "__main__":
    main()
