"""Learned-metric extractors: training time, feature throughput, and a real-data style check.

Run: ``python benchmarks/bench_learned_metrics.py [--threads 1] [--dwm-epochs 20]``. Prints:

* training time and held-out accuracy of the motion classifier and the audio classifier on synth_dance
  (openpose14, 15 fps, 3 styles);
* motion-feature / audio-embedding throughput (clips per second) for 10 s clips;
* when ``../shared/data/dance_with_melody`` exists: a leave-dances-out style test on real mocap — train on
  5 dances cut into 8 s pieces, classify the pieces of 3 held-out dances (cha-cha C_4, rumba R_3, waltz W_4).
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np
import torch

from momu.data.synth import SynthConfig, SynthDance
from momu.data.types import Clip
from momu.encoders.dstformer import DSTformerConfig
from momu.metrics.extractors import (
    AudioClassifierConfig,
    AudioClassifierEmbedding,
    MotionClassifierConfig,
    MotionExtractor,
    TrainConfig,
    train_extractor,
)
from momu.registry import DATASETS

DWM = Path(__file__).resolve().parents[1].parent / "shared" / "data" / "dance_with_melody"


def _synth(n: int, seconds: float, split: str) -> list[Clip]:
    cfg = SynthConfig(num_clips=n, min_seconds=seconds, max_seconds=seconds, skeleton="openpose14", fps=15.0)
    ds = SynthDance(cfg, split=split)
    return [ds[i] for i in range(len(ds))]


def _accuracy(pred: list[str], clips: list[Clip]) -> float:
    return float(np.mean([p == c.style for p, c in zip(pred, clips)]))


def bench_synth(epochs: int) -> None:
    train, test = _synth(96, 6.0, "train"), _synth(96, 6.0, "test")
    t0 = time.perf_counter()
    motion, summary = train_extractor("motion", train, train=TrainConfig(epochs=epochs, val_fraction=0.0))
    assert isinstance(motion, MotionExtractor)
    dt = time.perf_counter() - t0
    acc = _accuracy(motion.predict(test), test)
    print(
        f"motion classifier (synth, {len(train)} train clips, {epochs} epochs): {dt:.1f} s, "
        f"loss {summary['loss_history'][0]:.3f} -> {summary['loss_history'][-1]:.3f}, test accuracy {acc:.3f}"
    )
    clips = _synth(24, 10.0, "all")
    t0 = time.perf_counter()
    motion.clip_features(clips)
    print(f"motion features: {len(clips) / (time.perf_counter() - t0):.1f} clips/s (10 s clips)")

    t0 = time.perf_counter()
    audio, summary = train_extractor(
        "audio",
        train,
        model_config=AudioClassifierConfig(),
        train=TrainConfig(epochs=epochs, val_fraction=0.0),
    )
    assert isinstance(audio, AudioClassifierEmbedding)
    dt = time.perf_counter() - t0
    print(
        f"audio classifier (synth, {epochs} epochs): {dt:.1f} s, "
        f"loss {summary['loss_history'][0]:.3f} -> {summary['loss_history'][-1]:.3f}"
    )
    t0 = time.perf_counter()
    for clip in clips:
        audio.frame_embeddings(clip)
    print(f"audio embeddings: {len(clips) / (time.perf_counter() - t0):.1f} clips/s (10 s clips)")


def bench_dwm(epochs: int) -> None:
    if not DWM.is_dir():
        print(f"(real-data check skipped: {DWM} not found)")
        return
    ds = DATASETS.build("dance_with_melody", {"root": str(DWM), "load_audio": False})
    dances = [ds[i] for i in range(len(ds))]

    def pieces(c: Clip, seconds: float = 8.0) -> list[Clip]:
        assert c.motion is not None
        n = int(seconds * c.fps)
        return [
            Clip(f"{c.id}_{k}", c.motion[k * n : (k + 1) * n], c.fps, style=c.style)
            for k in range(len(c.motion) // n)
        ]

    held = {"DANCE_C_4", "DANCE_R_3", "DANCE_W_4"}
    train = [p for c in dances if c.id not in held for p in pieces(c)]
    test = [p for c in dances if c.id in held for p in pieces(c)]
    cfg = MotionClassifierConfig(
        fps=12.5,
        window=25,
        hidden=32,
        dstformer=DSTformerConfig(dim_feat=16, dim_rep=8, depth=1, num_heads=2),
    )
    t0 = time.perf_counter()
    ext, _ = train_extractor(
        "motion", train, model_config=cfg, train=TrainConfig(epochs=epochs, val_fraction=0.0)
    )
    assert isinstance(ext, MotionExtractor)
    acc = _accuracy(ext.predict(test), test)
    print(
        f"Dance with Melody leave-dances-out: {len(train)} train / {len(test)} held-out 8 s pieces, "
        f"{epochs} epochs, {time.perf_counter() - t0:.1f} s, accuracy {acc:.3f} (chance 0.25)"
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument(
        "--threads", type=int, default=1, help="torch threads (1 is fastest on shared 2-core CPUs)"
    )
    parser.add_argument("--epochs", type=int, default=20, help="synth training epochs")
    parser.add_argument("--dwm-epochs", type=int, default=20, help="real-data training epochs (0 = skip)")
    args = parser.parse_args()
    torch.set_num_threads(args.threads)
    bench_synth(args.epochs)
    if args.dwm_epochs:
        bench_dwm(args.dwm_epochs)


if __name__ == "__main__":
    main()
