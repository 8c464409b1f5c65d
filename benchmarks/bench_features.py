"""Benchmark of the audio and rhythm feature extractors (issue 3 §3).

Prints, for ``--clips`` clips of ``--seconds`` s of 16 kHz audio (and matching 60 fps, 24-joint motion):
* MoMu mel through librosa (``momu_mel``, one clip at a time) vs the torch ``MelSpectrogram`` (one batch),
  on CPU and, when available, on CUDA; and the largest difference between the two;
* MFCC through librosa vs the torch ``Mfcc``;
* directogram + kinematic amplitude (numpy per clip vs torch batched) and HarmoGAN visual beats;
* the FeatureCache: a first run computing and a second run loading the mels.

Run from the repository root: ``python benchmarks/bench_features.py [--clips 16 --seconds 10]``.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from collections.abc import Callable
from typing import Any

import numpy as np
import torch

from momu.features.audio import MfccConfig, MoMuMelConfig, mfcc, momu_mel
from momu.features.audio_torch import MelSpectrogram, Mfcc
from momu.features.cache import FeatureCache
from momu.features.kinematics import kinematic_amplitude_torch, motion_kinematic_amplitude, visual_beats


def timed(fn: Callable[[], Any], repeat: int = 3) -> tuple[float, Any]:
    """Best wall time of ``repeat`` runs (seconds) and the last result."""
    best, out = float("inf"), None
    for _ in range(repeat):
        start = time.perf_counter()
        out = fn()
        if torch.cuda.is_available():
            torch.cuda.synchronize()
        best = min(best, time.perf_counter() - start)
    return best, out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--clips", type=int, default=16)
    parser.add_argument("--seconds", type=float, default=10.0)
    args = parser.parse_args()
    rng = np.random.default_rng(0)
    sr, n = 16000, int(args.seconds * 16000)
    audio = (0.1 * rng.standard_normal((args.clips, n))).astype(np.float32)
    total = args.clips * args.seconds
    threads = torch.get_num_threads()
    print(f"{args.clips} clips x {args.seconds:g} s ({total:g} s of audio), torch threads {threads}")
    momu_mel(audio[0, :sr], sr), mfcc(audio[0, :sr], sr)  # warm-up: librosa's first calls compile/cache

    t_lib, ref = timed(lambda: np.stack([momu_mel(a, sr) for a in audio]), repeat=1)
    module = MelSpectrogram(MoMuMelConfig())
    batch = torch.from_numpy(audio)
    with torch.no_grad():
        t_cpu, out = timed(lambda: module(batch))
    err = float(np.abs(out.numpy() - ref).max())
    print(f"momu_mel librosa   : {t_lib * 1e3:8.1f} ms  ({total / t_lib:7.0f}x real time)")
    print(
        f"MelSpectrogram cpu : {t_cpu * 1e3:8.1f} ms  ({total / t_cpu:7.0f}x real time), max |diff| {err:.2e}"
    )
    if torch.cuda.is_available():
        gpu_module, gpu_batch = module.cuda(), batch.cuda()
        with torch.no_grad():
            t_gpu, _ = timed(lambda: gpu_module(gpu_batch), repeat=5)
        print(f"MelSpectrogram cuda: {t_gpu * 1e3:8.1f} ms  ({total / t_gpu:7.0f}x real time)")

    cfg = MfccConfig()
    t_mfcc, ref_m = timed(lambda: np.stack([mfcc(a, sr, cfg) for a in audio]), repeat=1)
    with torch.no_grad():
        t_mfcc_t, out_m = timed(lambda: Mfcc(cfg)(batch))
    err_m = float(np.abs(out_m.numpy() - ref_m).max())
    print(f"mfcc librosa       : {t_mfcc * 1e3:8.1f} ms")
    print(f"Mfcc torch cpu     : {t_mfcc_t * 1e3:8.1f} ms, max |diff| {err_m:.2e}")

    frames = int(args.seconds * 60)
    motion = rng.standard_normal((args.clips, frames, 24, 3)).cumsum(axis=1) * 0.01
    t_q, _ = timed(lambda: [motion_kinematic_amplitude(m) for m in motion])
    t_qt, _ = timed(lambda: kinematic_amplitude_torch(torch.from_numpy(motion)))
    t_vb, _ = timed(lambda: [visual_beats(m, 60.0) for m in motion])
    print(f"kinematic amplitude: numpy {t_q * 1e3:7.1f} ms, torch batched {t_qt * 1e3:7.1f} ms")
    print(f"                     ({args.clips} motions of {frames} frames x 24 joints)")
    print(f"visual beats       : {t_vb * 1e3:7.1f} ms")

    with tempfile.TemporaryDirectory() as tmp:
        cache = FeatureCache(tmp)

        def run() -> list[Any]:
            cfg = MoMuMelConfig()
            return [
                cache.get_or_compute("momu_mel", cfg, f"clip-{i}", lambda a=a: momu_mel(a, sr))
                for i, a in enumerate(audio)
            ]

        t_first, _ = timed(run, repeat=1)
        t_second, _ = timed(run, repeat=1)
        print(f"FeatureCache       : first run {t_first * 1e3:7.1f} ms, second run {t_second * 1e3:7.1f} ms "
              f"(hits {cache.hits}, misses {cache.misses})")  # fmt: skip


if __name__ == "__main__":
    main()
