"""Does θ_m's song condition follow a time-stretched real song? (issue 32)

The dance model θ_m is conditioned on ``music_rhythm``: the song's beat phase, tempo and onset envelope,
its beats placed by librosa's tracker (``tempo: tracker``, the shipped setting) or on the onset envelope's
periodogram tempo (``tempo: periodogram``, which θ_a's ``motion_rhythm`` uses for the dance). A dance can
follow a stretched song only as well as its condition does. For each Dance with Melody song (the
benchmark's excerpt from 2 s: ``--seconds``, default 15), this reads the condition's tempo (the beat
grid's median interval) on the excerpt and on it stretched ×0.8, ×0.9, ×1.1, ×1.25 (librosa's phase
vocoder, as the benchmark stretches it) and counts, per split, the stretches followed within 5 % (up to an
octave, as the benchmark folds ratios).

    python benchmarks/song_condition_stretch.py --data ../shared/data/dance_with_melody \
        --out benchmarks/results/song_condition_stretch.json
"""

from __future__ import annotations

import logging

from study_common import study_args, write_study  # benchmarks/study_common.py

from momu.config import build_component
from momu.features.rhythm import ENVELOPE_RATE, RhythmConfig, music_envelope, track_beats
from momu.following.inputs import FACTORS
from momu.following.pairs import LEAD_S, dataset_node
from momu.following.signals import time_stretch_audio
from momu.following.tempo import beat_tempo, fold_ratio

START_S = LEAD_S
CONDITIONS = {
    "tracker": RhythmConfig(),
    "periodogram": RhythmConfig(tempo="periodogram"),
    "periodogram_unfolded": RhythmConfig(min_bpm=20, max_bpm=200, tempo="periodogram"),
}
"""``music_rhythm``'s tempo estimates: as shipped, the periodogram folded into 55-160 BPM, unfolded."""
log = logging.getLogger("song_condition_stretch")


def main() -> None:
    args = study_args(__doc__, "song_condition_stretch")
    ds = build_component(dataset_node(args.data, "all", "dwm21", args.seconds, 8), "datasets")
    rows = []
    for i in range(len(ds)):
        clip = ds[i]
        sr = clip.sample_rate
        y = clip.audio[int(START_S * sr) : int((START_S + args.seconds) * sr)]
        versions = {1.0: y, **{f: time_stretch_audio(y, f) for f in FACTORS}}
        row: dict = {"id": clip.id, "split": clip.meta.get("split", "all")}
        for name, cfg in CONDITIONS.items():
            bpm = {
                f: beat_tempo(track_beats(music_envelope(a, sr), ENVELOPE_RATE, cfg))
                for f, a in versions.items()
            }
            row[f"{name}_bpm"] = round(float(bpm[1.0]), 1)
            row[f"{name}_followed"] = [
                bool(abs(fold_ratio(bpm[f] / bpm[1.0]) / f - 1.0) <= 0.05) for f in FACTORS
            ]
        rows.append(row)
        log.info("%s", row)
    summary = {
        split: {
            name: f"{sum(sum(r[f'{name}_followed']) for r in group)} of {len(group) * len(FACTORS)}"
            for name in CONDITIONS
        }
        for split in ("train", "val", "test")
        if (group := [r for r in rows if r["split"] == split])
    }
    write_study(
        args.out,
        {"excerpt_s": [START_S, args.seconds], "factors": list(FACTORS), "summary": summary, "songs": rows},
        indent=1,
    )
    log.info("stretches followed within 5 %%: %s; wrote %s", summary, args.out)


if __name__ == "__main__":
    main()
