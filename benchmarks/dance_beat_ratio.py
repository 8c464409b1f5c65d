"""Why a dance model's tempo following fails at some training seeds (issue 32; validation split only).

    python benchmarks/dance_beat_ratio.py MODEL_DIR [--out benchmarks/results/dance_beat_ratio_NAME.json]
        [--data ../shared/data/dance_with_melody] [--guidance-interval LOW HIGH]

For every validation song excerpt (15 s, as ``reproductions/music_following_dwm``), generation seeds 0 1
2 and the benchmark's tempo factors, the generated dance's tempo over the stretched song's tempo
(both by the benchmark's periodogram, :func:`momu.following.analysis.analyse_motion` /
``analyse_audio``), folded by powers of 2 into [1/√2, √2): the dance's *movement-to-beat ratio*. A
dance that follows the song keeps this ratio as the song is stretched; a dance that steps to the beat
in one stretch and in a three-beat figure (or a slow-quick-quick pattern) in the next changes it by a
non-octave factor (4/3, 3/2), which the benchmark's octave folding rightly does not forgive. Written:
per (song, seed) the five ratios, their spread (max/min), and the benchmark's own slope for the cell.
"""

from __future__ import annotations

import argparse
import json
import logging
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
FACTORS = (0.8, 0.9, 1.1, 1.25)
SEEDS = (0, 1, 2)

log = logging.getLogger("dance_beat_ratio")


def main() -> int:
    from momu.following.adapters import from_model_dir
    from momu.following.analysis import analyse_audio, analyse_motion
    from momu.following.pairs import dataset_node, load_pairs
    from momu.following.signals import time_stretch_audio
    from momu.following.tempo import fold_ratio

    logging.basicConfig(level=logging.INFO, format="%(levelname)s %(name)s: %(message)s")
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("model", type=Path)
    p.add_argument("--data", default=str(ROOT.parent / "shared" / "data" / "dance_with_melody"))
    p.add_argument("--out", type=Path, default=None)
    p.add_argument("--guidance-interval", type=int, nargs=2, default=None, metavar=("LOW", "HIGH"))
    args = p.parse_args()
    gen = from_model_dir(args.model, "dance")
    if args.guidance_interval is not None:
        from momu.samplers.base import check_guidance_interval

        sampler = gen.model.sampler_for("motion")  # type: ignore[attr-defined]
        sampler.interval = check_guidance_interval(args.guidance_interval)
    pairs = load_pairs(dataset_node(args.data, "val", "dwm21", 15.0, 8), 15.0, 8)
    cells = []
    for pair in pairs:
        song = analyse_audio(pair.excerpt_audio(), pair.sample_rate)
        for seed in SEEDS:
            tempi = []
            for f in (1.0, *FACTORS):
                motion, fps = gen.generate(
                    time_stretch_audio(pair.excerpt_audio(), f), pair.sample_rate, seed
                )
                tempi.append(analyse_motion(motion, fps).tempo)
            ratios = [fold_ratio(t / (song.tempo * f)) for t, f in zip(tempi, (1.0, *FACTORS), strict=True)]
            slopes = [
                np.log(fold_ratio(t / tempi[0])) / np.log(f) for t, f in zip(tempi[1:], FACTORS, strict=True)
            ]
            cells.append(
                {
                    "song": pair.id,
                    "seed": seed,
                    "song_tempo_bpm": song.tempo,
                    "movement_to_beat": ratios,
                    "spread": max(ratios) / min(ratios),
                    "slope": float(np.median(slopes)),
                }
            )
            log.info(
                "%s seed %d: ratios %s slope %.2f", pair.id, seed, np.round(ratios, 2), cells[-1]["slope"]
            )
    spread = np.array([c["spread"] for c in cells])
    follows = np.array([abs(c["slope"] - 1.0) <= 0.1 for c in cells])
    summary = {
        "cells": len(cells),
        "follows (slope within 0.1 of 1)": int(follows.sum()),
        "ratio spread < 1.1 among cells that follow": int((spread[follows] < 1.1).sum()),
        "ratio spread < 1.1 among cells that do not": int((spread[~follows] < 1.1).sum()),
        "cells that do not follow": int((~follows).sum()),
    }
    log.info("%s", summary)
    if args.out is not None:
        args.out.parent.mkdir(parents=True, exist_ok=True)
        command = ["python", "benchmarks/dance_beat_ratio.py", *sys.argv[1:]]
        args.out.write_text(
            json.dumps({"command": command, "summary": summary, "cells": cells}, indent=1) + "\n"
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
