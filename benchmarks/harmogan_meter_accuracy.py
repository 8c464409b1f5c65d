"""How well HarmoGAN's meter segmentation (§IV-A) recovers synth_dance's downbeats and meters.

    python benchmarks/harmogan_meter_accuracy.py [--clips 24] [--seconds 12]

For every clip the music's onset beats and saliencies (the harmony metric's detector) are segmented by
:func:`momu.methods.harmogan.meter.segment_meters`; a meter start is a recovered downbeat when it lies
within 70 ms of one of the generator's ``downbeat_times``. Per style: precision, recall and F1 of the
downbeats, chance precision (1 / beats per bar), the share of meter starts on any music beat, and the
share of meters with the style's ``beats_per_bar`` beats. Prints a Markdown table; nothing is asserted.
"""

from __future__ import annotations

import argparse

import numpy as np

from momu.methods.harmogan.meter import segment_meters
from momu.metrics.harmony import audio_beats
from momu.registry import DATASETS

STYLES = ["ballet", "hiphop", "zumba", "techno"]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--clips", type=int, default=24)
    parser.add_argument("--seconds", type=float, default=12.0)
    args = parser.parse_args()
    ds = DATASETS.build(
        "synth_dance",
        {
            "num_clips": args.clips,
            "skeleton": "dwm21",
            "fps": 15.0,
            "min_seconds": args.seconds,
            "max_seconds": args.seconds,
            "styles": STYLES,
        },  # fmt: skip
    )
    stats: dict[str, dict[str, float]] = {}
    for clip in ds:
        assert clip.audio is not None and clip.sample_rate is not None
        times, saliency = audio_beats(clip.audio, clip.sample_rate)
        meters = segment_meters(saliency)
        starts = times[[m.first_beat for m in meters]]
        down = np.asarray(clip.meta["downbeat_times"])
        down = down[down < clip.duration]
        beats = np.asarray(clip.meta["beat_times"])
        s = stats.setdefault(
            str(clip.style), {k: 0.0 for k in ("tp_p", "n_p", "tp_r", "n_r", "on", "bars", "n_m")}
        )
        s["tp_p"] += sum(np.min(np.abs(down - t)) < 0.07 for t in starts)
        s["n_p"] += len(starts)
        s["tp_r"] += sum(np.min(np.abs(starts - t)) < 0.07 for t in down)
        s["n_r"] += len(down)
        s["on"] += sum(np.min(np.abs(beats - t)) < 0.07 for t in starts)
        s["bars"] += sum(m.num_beats == clip.meta["beats_per_bar"] for m in meters)
        s["n_m"] += len(meters)
        s["bpb"] = float(clip.meta["beats_per_bar"])
    print(
        "| style | beats/bar | downbeat precision | chance | recall | F1 | starts on a beat "
        "| meters of beats/bar |"
    )
    print("|---|---|---|---|---|---|---|---|")
    for style, s in stats.items():
        p, r = s["tp_p"] / max(s["n_p"], 1), s["tp_r"] / max(s["n_r"], 1)
        f1 = 2 * p * r / max(p + r, 1e-9)
        print(
            f"| {style} | {s['bpb']:.0f} | {p:.2f} | {1 / s['bpb']:.2f} | {r:.2f} | {f1:.2f} | "
            f"{s['on'] / max(s['n_p'], 1):.2f} | {s['bars'] / max(s['n_m'], 1):.2f} |"
        )


if __name__ == "__main__":
    main()
