"""Does the tempo read from a real dance match its song's? (issue 32, the dance → music direction)

    python benchmarks/dance_tempo_vs_song.py [--data ../shared/data/dance_with_melody] [--out FILE.json]
    python benchmarks/dance_tempo_vs_song.py --data synth --out FILE.json   # dance_tempo_vs_song_synth.json
    python benchmarks/dance_tempo_vs_song.py --seconds 30 --out FILE.json    # dance_tempo_vs_song_30s.json

For every Dance with Melody dance, the excerpt the music-following benchmark uses (2 s in; ``--seconds``,
default 15): the song's tempo (:func:`momu.following.analysis.analyse_audio`, the benchmark's periodogram)
against the dance's tempo as the shipped model's ``motion_rhythm`` condition reads it (librosa's beat
tracker on the kinematic-onset envelope, :mod:`momu.features.rhythm`), as ``motion_rhythm`` with ``tempo:
periodogram`` reads it (the envelope's dominant period given to the tracker), and as the benchmark reads
it (periodogram of the mean joint speed). A match is the benchmark's
(:func:`momu.following.tempo.tempo_matches`: within 5 % of ×1, ×2, ×½, ×3, ×⅓). Writes the per-dance tempi
and the shares.

Stretch: the same excerpt played ×0.8, ×0.9, ×1.1 and ×1.25 faster
(:func:`momu.following.signals.time_scale_motion`, as the benchmark's tempo-following test does): does
each estimate's tempo ratio (octave-folded, :func:`momu.following.tempo.fold_ratio`) follow the factor
within 5 %? The music the shipped model writes follows the ``motion_rhythm`` tempo, so this bounds its
tempo-following slope.

``--data synth``: the same on 24 clips of ``synth_dance`` as the shipped model is trained on
(``recipes/pretrain.py``'s ``SYNTH_OVERRIDES``: Dance with Melody's skeleton, the four ballroom styles,
60-160 BPM, a 4-m floor): how the synthetic dancers' dominant period relates to their song's beat,
which is what θ_a learns to answer.

Ceiling of the music's tempo match (the benchmark's dance → music ``tempo_match``: own song's tempo
matched minus the other songs' of the same split, :func:`momu.following.checks.pair_tests`): a music
written exactly at ``m`` times the dance's tempo, for ``m`` in :data:`MULTIPLES` (and ``m`` chosen per
style: 3 for a waltz's bar, 2 otherwise), scored against the songs of each split. Ground truth (the song
itself) passes this test by identity; the ceiling says what any music derived from the dance's tempo
alone can reach.
"""

from __future__ import annotations

import logging

import numpy as np
from study_common import excerpt, study_args, write_study  # benchmarks/study_common.py

from momu.config import build_component
from momu.features.rhythm import ENVELOPE_RATE, RhythmConfig, motion_envelope, track_beats
from momu.following.analysis import analyse_audio, analyse_motion
from momu.following.inputs import FACTORS
from momu.following.pairs import DWM_SPLIT
from momu.following.signals import time_scale_motion
from momu.following.stats import song_seed_bootstrap
from momu.following.tempo import beat_tempo, fold_ratio, tempo_matches

START_S = 2.0
SYNTH = {
    "name": "synth_dance",
    "skeleton": "dwm21",
    "styles": ["waltz", "rumba", "cha_cha", "quickstep"],
    "trajectory_radius": 4.0,
    "bpm_range": [60, 160],
    "num_clips": 24,
    "seed": 0,
}
"""``synth_dance`` as the shipped model sees it (``recipes/pretrain.py``'s ``SYNTH_OVERRIDES``)."""
MULTIPLES = (1, 2, 3, 4, 6)
"""Multiples of the dance's tempo tried as the music's (the ceiling above)."""
log = logging.getLogger("dance_tempo_vs_song")


def _tracked(motion: np.ndarray, fps: float, tempo: str = "tracker") -> float:
    """The dance's tempo as ``motion_rhythm`` reads it (``tempo``: its tempo estimate)."""
    env = motion_envelope(motion, fps)
    return float(beat_tempo(track_beats(env, ENVELOPE_RATE, RhythmConfig(tempo=tempo))))


def _followed(ratio: float, factor: float) -> bool:
    return abs(fold_ratio(ratio) / factor - 1.0) <= 0.05


def style_multiple(dance_id: str) -> int:
    """3 for a waltz (Dance with Melody's ``DANCE_W_*``: the dancer's period is the bar), else 2."""
    return 3 if "_W_" in dance_id else 2


def tempo_match_ceiling(rows: list[dict], key: str) -> dict[str, dict[str, list[float]]]:
    """Per split and multiple: ``[mean, low, high]`` over dances (the benchmark's bootstrap over songs)
    of ``tempo_match`` for music at ``multiple ×`` the dance's tempo ``row[key]`` (own song matched −
    the share of the split's other songs matched), the songs' tempi read as the benchmark reads them
    (librosa's beat grid, ``song_beat_bpm``)."""
    out: dict[str, dict[str, list[float]]] = {}
    for split in sorted({r["split"] for r in rows}):
        group = [r for r in rows if r["split"] == split]
        if len(group) < 2:
            continue
        scores: dict[str, list[float]] = {}
        for m in (*MULTIPLES, "style"):
            per = []
            for r in group:
                music = r[key] * (style_multiple(r["id"]) if m == "style" else m)
                others = [tempo_matches(music, o["song_beat_bpm"]) for o in group if o is not r]
                per.append(float(tempo_matches(music, r["song_beat_bpm"])) - float(np.mean(others)))
            est = song_seed_bootstrap(np.array(per))
            scores[f"x{m}"] = [round(v, 3) for v in (est.estimate, est.low, est.high)]
        out[split] = scores
    return out


def main() -> None:
    args = study_args(__doc__, "dance_tempo_vs_song", data_help="a folder, or synth")
    node = {"name": "dance_with_melody", "root": args.data, "sample_rate": 16000, "split": "all", **DWM_SPLIT}
    if args.data == "synth":
        length = START_S + args.seconds + 1.0
        node = {**SYNTH, "min_seconds": length, "max_seconds": length}
    ds = build_component(node, "datasets")
    rows = []
    for i in range(len(ds)):
        clip = ds[i]
        motion, audio = excerpt(clip, args.seconds, START_S)
        song_analysis = analyse_audio(audio, clip.sample_rate)
        song = song_analysis.tempo
        tracked = _tracked(motion, clip.fps)
        periodogram = analyse_motion(motion, clip.fps, "dwm21").tempo
        stretched = [time_scale_motion(motion, clip.fps, f) for f in FACTORS]
        tracked_ratios = [_tracked(m, clip.fps) / tracked for m in stretched]
        fixed = _tracked(motion, clip.fps, "periodogram")
        fixed_ratios = [_tracked(m, clip.fps, "periodogram") / fixed for m in stretched]
        periodogram_ratios = [analyse_motion(m, clip.fps, "dwm21").tempo / periodogram for m in stretched]
        rows.append(
            {
                "id": clip.id,
                "split": clip.meta.get("split", "all"),
                "song_bpm": round(float(song), 1),
                "song_beat_bpm": round(float(song_analysis.beat_tempo), 1),
                "motion_rhythm_bpm": round(float(tracked), 1),
                "periodogram_bpm": round(float(periodogram), 1),
                "motion_rhythm_periodogram_bpm": round(float(fixed), 1),
                "motion_rhythm_matches": bool(tempo_matches(tracked, song)),
                "motion_rhythm_periodogram_matches": bool(tempo_matches(fixed, song)),
                "periodogram_matches": bool(tempo_matches(periodogram, song)),
                "stretch_factors": list(FACTORS),
                "motion_rhythm_ratios": [round(fold_ratio(r), 3) for r in tracked_ratios],
                "periodogram_ratios": [round(fold_ratio(r), 3) for r in periodogram_ratios],
                "motion_rhythm_periodogram_ratios": [round(fold_ratio(r), 3) for r in fixed_ratios],
                "motion_rhythm_follows": [_followed(r, f) for r, f in zip(tracked_ratios, FACTORS)],
                "motion_rhythm_periodogram_follows": [_followed(r, f) for r, f in zip(fixed_ratios, FACTORS)],
                "periodogram_follows": [_followed(r, f) for r, f in zip(periodogram_ratios, FACTORS)],
            }
        )
        log.info("%s", rows[-1])
    summary = {
        key: f"{sum(r[key] for r in rows)} of {len(rows)}"
        for key in ("motion_rhythm_matches", "motion_rhythm_periodogram_matches", "periodogram_matches")
    }
    for key in ("motion_rhythm_follows", "motion_rhythm_periodogram_follows", "periodogram_follows"):
        summary[key + "_stretch"] = f"{sum(sum(r[key]) for r in rows)} of {len(rows) * len(FACTORS)}"
    if args.data != "synth":
        for key in ("periodogram_bpm", "motion_rhythm_periodogram_bpm"):
            summary[f"tempo_match_ceiling_{key}"] = tempo_match_ceiling(rows, key)
    log.info("%s", summary)
    write_study(args.out, {"excerpt_s": [START_S, args.seconds], "summary": summary, "dances": rows})


if __name__ == "__main__":
    main()
