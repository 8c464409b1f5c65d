"""Benchmark: HarmoGAN dance generation for a 3-minute song at the ``cpu`` preset size.

Times :meth:`momu.methods.harmogan.HarmoGANModel.generate` — MFCCs, the metric's onset detection,
meter segmentation and recurrent generation over all K meter units from one initial pose — on a
180-s synth_dance song, and reports the number of units, wall and CPU seconds and peak memory. With
``--model DIR`` a trained model (e.g. ``outputs/reproduce/harmogan_shared/models/harmogan-<hash>``)
is timed; otherwise the cpu preset's generator with random weights (the cost of a forward pass does
not depend on training).

    OMP_NUM_THREADS=1 python benchmarks/bench_harmogan_generation.py [--seconds 180] [--repeats 3] \
        [--model DIR]

Prints one line per measurement; nothing is asserted.
"""

from __future__ import annotations

import argparse
import resource
import time
from pathlib import Path

import numpy as np

from momu.config import build_component, load_config
from momu.methods.harmogan import HarmoGANModel
from momu.methods.harmogan.data import MfccStats
from momu.methods.harmogan.meter import meter_units
from momu.metrics.harmony import audio_beats
from momu.registry import DATASETS

ROOT = Path(__file__).resolve().parents[1]


def build(model_dir: Path | None) -> HarmoGANModel:
    if model_dir is not None:
        return HarmoGANModel.load(model_dir)
    cfg = load_config(ROOT / "recipes" / "configs" / "harmogan.yaml")
    method = build_component(cfg.method, "methods")
    generator = build_component(method.nodes(21)["generator"], "encoders")
    stats = MfccStats(
        np.zeros(method.cfg.mfcc.n_mfcc, np.float32), np.ones(method.cfg.mfcc.n_mfcc, np.float32)
    )
    return HarmoGANModel(method.cfg, generator, stats, np.zeros((21, 3), np.float32))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=180.0)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--model", type=Path, default=None)
    args = parser.parse_args()
    model = build(args.model)
    song = DATASETS.build(
        "synth_dance",
        {
            "num_clips": 1,
            "skeleton": "dwm21",
            "fps": 15.0,
            "min_seconds": args.seconds,
            "max_seconds": args.seconds,
        },  # fmt: skip
    )[0]
    assert song.audio is not None and song.sample_rate is not None
    times, saliency = audio_beats(song.audio, song.sample_rate)
    units = meter_units(times, saliency, args.seconds, model.fps, model.cfg.meter)
    print(
        f"song {args.seconds:.0f} s: {len(times)} onset beats, {len(units)} meter units "
        f"of {model.cfg.meter.unit_seconds} s"
    )
    for r in range(args.repeats):
        wall, cpu = time.perf_counter(), time.process_time()
        motion = model.generate(song.audio, song.sample_rate, seed=r)
        print(
            f"generate: {motion.shape[0]} frames in {time.perf_counter() - wall:.2f} s wall, "
            f"{time.process_time() - cpu:.2f} s CPU"
        )
    print(f"peak memory {resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024:.0f} MiB")


if __name__ == "__main__":
    main()
