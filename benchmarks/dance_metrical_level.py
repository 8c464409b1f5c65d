"""At which metrical level does a generated dance move, song stretch by song stretch? (issue 32)

The music-following benchmark's tempo slope compares the tempo of the dance generated for a stretched
song with the dance generated for the song itself, folded by powers of 2 only
(:func:`momu.following.tempo.fold_ratio`). For a few (song, generation seed) cells of a model this
generates the dance for the song's 15-s excerpt (from 2 s) and for it stretched ×0.8, ×0.9, ×1.1,
×1.25, and writes, per stretch, the dance's tempo as the benchmark reads it, the tempo of the song's
beat grid as the dance model's condition reads it (``music_rhythm``, librosa's tracker), and their
ratio with the nearest simple fraction (¼, ⅓, ½, ⅔, 1, 3/2, 2, 3) within 5 %: the metrical level the dance
moves at (``none`` when no fraction is that near).

    python benchmarks/dance_metrical_level.py --model DIR --cells DANCE_R_3:0 DANCE_T_5:2 \
        --data ../shared/data/dance_with_melody --out OUT.json
"""

from __future__ import annotations

import argparse
import json
import logging
from fractions import Fraction
from pathlib import Path

from momu.config import build_component
from momu.features.rhythm import ENVELOPE_RATE, RhythmConfig, music_envelope, track_beats
from momu.following.adapters import from_model_dir
from momu.following.analysis import analyse_motion
from momu.following.inputs import FACTORS
from momu.following.pairs import LEAD_S, dataset_node
from momu.following.signals import time_stretch_audio
from momu.following.tempo import beat_tempo

START_S, SECONDS = LEAD_S, 15.0
LEVELS = (
    Fraction(1, 3),
    Fraction(1, 2),
    Fraction(2, 3),
    Fraction(1),
    Fraction(3, 2),
    Fraction(2),
    Fraction(3),
)
"""Simple fractions of the beat a dance may move at."""
log = logging.getLogger("dance_metrical_level")


def nearest_level(ratio: float) -> str:
    """The fraction of :data:`LEVELS` within 5 % of ``ratio`` (the nearest), or ``"none"``."""
    level = min(LEVELS, key=lambda f: abs(ratio / float(f) - 1.0))
    return str(level) if abs(ratio / float(level) - 1.0) <= 0.05 else "none"


def main() -> None:
    logging.basicConfig(level=logging.INFO, format="%(message)s")
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--model", required=True, help="a MoMu model folder")
    p.add_argument("--cells", nargs="+", required=True, help="SONG_ID:SEED")
    p.add_argument("--data", default="../shared/data/dance_with_melody")
    p.add_argument("--out", type=Path, required=True)
    args = p.parse_args()
    generator = from_model_dir(args.model)
    ds = build_component(dataset_node(args.data, "all", "dwm21", SECONDS, 8), "datasets")
    clips = {ds[i].id: i for i in range(len(ds))}
    cells = []
    for cell in args.cells:
        song, _, seed = cell.partition(":")
        clip = ds[clips[song]]
        sr = clip.sample_rate
        excerpt = clip.audio[int(START_S * sr) : int((START_S + SECONDS) * sr)]
        rows = []
        for factor in (1.0, *FACTORS):
            audio = excerpt if factor == 1.0 else time_stretch_audio(excerpt, factor)
            motion, fps = generator.generate(audio, sr, int(seed))  # type: ignore[call-arg, arg-type]
            dance = analyse_motion(motion, fps, "dwm21").tempo
            beat = beat_tempo(track_beats(music_envelope(audio, sr), ENVELOPE_RATE, RhythmConfig()))
            rows.append(
                {
                    "factor": factor,
                    "dance_bpm": round(dance, 1),
                    "condition_beat_bpm": round(beat, 1),
                    "level": nearest_level(dance / beat),
                }
            )
            log.info("%s seed %s ×%g: %s", song, seed, factor, rows[-1])
        cells.append({"song": song, "seed": int(seed), "stretches": rows})
    args.out.write_text(
        json.dumps({"model": args.model, "excerpt_s": [START_S, SECONDS], "cells": cells}, indent=1) + "\n"
    )
    log.info("wrote %s", args.out)


if __name__ == "__main__":
    main()
