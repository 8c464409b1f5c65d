"""Benchmark of the motion-feature metrics (issue 4, performance).

Prints:
* kinetic (72-d) + geometric (32-d) features of one 1200-frame, 24-joint motion (target ≤ 20 ms; the
  reference's per-frame Python loops take about 2 s on a 2-core machine);
* optionally (``--reference``) the same features through the slow transcriptions of the reference loops in
  ``tests/helpers/motion_reference.py``;
* features of ``--num`` clips through the batched clip pipeline, then FID_k, FID_g, Div_k, Div_g on them.

Run from the repository root: ``python benchmarks/bench_motion_features.py [--reference] [--num 1000]``.
"""

from __future__ import annotations

import argparse
import logging
import statistics
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from momu.data.types import Clip
from momu.features.skeletons import get_skeleton
from momu.metrics import diversity, fid, geometric_features, kinetic_features
from momu.metrics.motion_metrics import clip_features


def motion(seed: int, frames: int = 1200) -> np.ndarray:
    """A smooth random SMPL-24 motion (rest pose + random walk), float32 (T, 24, 3), metres."""
    rng = np.random.default_rng(seed)
    rest = get_skeleton("smpl24").rest_pose()
    walk = rng.normal(0, 0.01, size=(frames, 24, 3)).cumsum(axis=0)
    return (rest[None] + walk).astype(np.float32)


def timeit(fn: Callable[[], Any], repeats: int) -> tuple[float, float]:
    """(median, min) wall time in milliseconds over ``repeats`` calls after one warm-up."""
    fn()
    times = []
    for _ in range(repeats):
        start = time.perf_counter()
        fn()
        times.append((time.perf_counter() - start) * 1000.0)
    return statistics.median(times), min(times)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--reference", action="store_true", help="also time the slow reference transcription")
    parser.add_argument("--num", type=int, default=1000, help="sequences for the FID/Div benchmark")
    parser.add_argument("--repeats", type=int, default=30)
    args = parser.parse_args()
    # Random-walk poses never trigger some geometric features: keep the zero-variance warning quiet here.
    logging.getLogger("momu.metrics.frechet").setLevel(logging.ERROR)

    x = motion(0)
    k_med, k_min = timeit(lambda: kinetic_features(x), args.repeats)
    g_med, g_min = timeit(lambda: geometric_features(x), args.repeats)
    b_med, b_min = timeit(lambda: (kinetic_features(x), geometric_features(x)), args.repeats)
    print("one motion, 1200 frames x 24 joints (float32):")
    print(f"  kinetic features           median {k_med:8.2f} ms   min {k_min:8.2f} ms")
    print(f"  geometric features         median {g_med:8.2f} ms   min {g_min:8.2f} ms")
    print(f"  kinetic + geometric        median {b_med:8.2f} ms   min {b_min:8.2f} ms   (target <= 20 ms)")

    if args.reference:
        sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
        from tests.helpers.motion_reference import reference_kinetic, reference_manual

        start = time.perf_counter()
        ref_k = reference_kinetic(x)
        ref_g = reference_manual(x)
        ref_ms = (time.perf_counter() - start) * 1000.0
        same = np.array_equal(ref_k, kinetic_features(x)) and np.array_equal(ref_g, geometric_features(x))
        speedup = ref_ms / b_med
        print(f"  reference loops (kin+geo)  {ref_ms:8.1f} ms   speed-up x{speedup:.0f}   identical: {same}")

    clips = [Clip(id=f"s{i}", motion=motion(i + 1), fps=60.0, skeleton="smpl24") for i in range(args.num)]
    half = args.num // 2
    start = time.perf_counter()
    feats_k = clip_features(clips, "kinetic")
    t_k = time.perf_counter() - start
    start = time.perf_counter()
    feats_g = clip_features(clips, "geometric")
    t_g = time.perf_counter() - start
    print(f"{args.num} clips x 1200 frames through the Bailando pipeline:")
    print(f"  kinetic features           {t_k * 1000:8.1f} ms total   {t_k * 1000 / args.num:6.2f} ms/clip")
    print(f"  geometric features         {t_g * 1000:8.1f} ms total   {t_g * 1000 / args.num:6.2f} ms/clip")
    gen_k, ref_k_set = feats_k[:half], feats_k[half:]
    gen_g, ref_g_set = feats_g[:half], feats_g[half:]
    for label, fn in (
        ("FID_k", lambda: fid(gen_k, ref_k_set)),
        ("FID_g", lambda: fid(gen_g, ref_g_set)),
        ("Div_k (reference sum)", lambda: diversity(feats_k, feats_k)),
        ("Div_g (reference sum)", lambda: diversity(feats_g, feats_g)),
    ):
        med, _ = timeit(fn, 3)
        print(f"  {label:<26} {med:8.1f} ms   (n = {args.num if 'Div' in label else f'{half} vs {half}'})")


if __name__ == "__main__":
    main()
