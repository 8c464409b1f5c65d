"""Benchmark: beat metrics over N sequences — audio decoding vs audio analysis vs metric code.

The issue asks that BAS / LORIS scores on a 1,000-sequence evaluation be dominated by audio decoding,
not by metric code. This script times, per sequence, the three stages separately:

* decode   — reading the audio file (soundfile) and resampling to the analysis rates;
* analysis — librosa's onset strength / onset detection / beat tracking (the references' own calls);
* metric   — momu's code on the decoded arrays: motion envelopes and beats, BAS (Bailando and mint),
  D2M coverage/hit, LORIS bins and pair scores, dataset aggregation.

Files: ``--files`` distinct wav files (synthetic clicks + noise) are written to a temporary folder and
read round-robin, so N decodes happen without N files on disk.

    python benchmarks/bench_beat_metrics.py --n 1000 --seconds 10
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import librosa
import numpy as np
import soundfile as sf

from momu.metrics.beat_align import bas, beat_align_score
from momu.metrics.beat_coverage import beat_coverage_scores
from momu.metrics.beats import MUSIC_HOP, MUSIC_SR, motion_beats
from momu.metrics.loris_scores import (
    LORIS_SR,
    ONSET_PARAMS,
    aggregate_beat_scores,
    pair_beat_scores,
    second_bins,
)


def synth_audio(seconds: float, sr: int, bpm: float, rng: np.random.Generator) -> np.ndarray:
    n = int(seconds * sr)
    y = 0.01 * rng.standard_normal(n)
    burst = int(0.02 * sr)
    for t in np.arange(0.3, seconds - 0.05, 60.0 / bpm):
        i = int(t * sr)
        y[i : i + burst] += (
            0.5 * rng.standard_normal(burst)[: n - i] * np.exp(-np.arange(burst) / (0.004 * sr))
        )
    return y.astype(np.float32)


def synth_motion(seconds: float, fps: float, bpm: float, rng: np.random.Generator) -> np.ndarray:
    t = np.arange(int(seconds * fps)) / fps
    speed = 1.2 + np.cos(2 * np.pi * t * bpm / 60.0)
    x = np.cumsum(speed) / fps
    base = rng.normal(0, 0.3, (24, 3))
    return (base[None] + x[:, None, None] * np.array([1.0, 0.2, 0.1])).astype(np.float32)


def reference_style_ba(music: np.ndarray, motion: np.ndarray) -> float:
    """Bailando's BA() loop, for the speed comparison."""
    ba = 0.0
    for bb in music:
        ba += np.exp(-np.min((motion - bb) ** 2) / 2 / 9)
    return ba / len(music)


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--n", type=int, default=1000, help="sequences to evaluate")
    parser.add_argument("--seconds", type=float, default=10.0, help="length of each sequence")
    parser.add_argument("--files", type=int, default=20, help="distinct audio files (read round-robin)")
    parser.add_argument("--sr", type=int, default=44100, help="sample rate of the files")
    args = parser.parse_args()

    rng = np.random.default_rng(0)
    fps = 60.0
    with tempfile.TemporaryDirectory() as tmp:
        paths, motions = [], []
        for i in range(args.files):
            bpm = 90 + 5 * (i % 8)
            path = Path(tmp) / f"s{i}.wav"
            sf.write(path, synth_audio(args.seconds, args.sr, bpm, rng), args.sr)
            paths.append(path)
            motions.append(synth_motion(args.seconds, fps, bpm, rng))

        # warm-up (imports, numba JIT of librosa)
        y, _ = sf.read(paths[0], dtype="float32")
        librosa.onset.onset_detect(y=librosa.resample(y, orig_sr=args.sr, target_sr=LORIS_SR), sr=LORIS_SR)

        t_decode = t_analysis = t_metric = t_ref_loop = 0.0
        covers, hits, bas_scores = [], [], []
        for k in range(args.n):
            i = k % args.files
            t0 = time.perf_counter()
            y, sr = sf.read(paths[i], dtype="float32")
            y60 = librosa.resample(y, orig_sr=sr, target_sr=MUSIC_SR, res_type="soxr_hq")
            y22 = librosa.resample(y, orig_sr=sr, target_sr=LORIS_SR, res_type="soxr_hq")
            t1 = time.perf_counter()
            env = librosa.onset.onset_strength(y=y60, sr=MUSIC_SR)
            _, beats = librosa.beat.beat_track(
                onset_envelope=env, sr=MUSIC_SR, hop_length=MUSIC_HOP, start_bpm=120
            )
            onsets = librosa.onset.onset_detect(y=y22, sr=LORIS_SR, units="time", **ONSET_PARAMS["loris"])
            t2 = time.perf_counter()
            motion = motions[i]
            bas_scores.append(bas(motion, beats))
            bas(motion, beats, variant="mint")
            beat_coverage_scores(motion, beats, len(env))
            gt_bins = second_bins(onsets, len(y22) / LORIS_SR)
            cover, hit = pair_beat_scores(gt_bins, gt_bins)
            covers.append(cover)
            hits.append(hit)
            t3 = time.perf_counter()
            reference_style_ba(beats[beats < motion.shape[0] - 1], motion_beats(motion))
            t4 = time.perf_counter()
            t_decode += t1 - t0
            t_analysis += t2 - t1
            t_metric += t3 - t2
            t_ref_loop += t4 - t3
        t0 = time.perf_counter()
        aggregate_beat_scores(covers, hits)
        t_metric += time.perf_counter() - t0

        # Bailando's HPSS recipe is much slower than the mint recipe: time it on a few files
        t0 = time.perf_counter()
        n_hpss = min(5, args.files)
        for i in range(n_hpss):
            y, sr = sf.read(paths[i], dtype="float32")
            y60 = librosa.resample(y, orig_sr=sr, target_sr=MUSIC_SR, res_type="soxr_hq")
            _, perc = librosa.effects.hpss(y60)
            librosa.onset.onset_strength(y=perc, aggregate=np.median, sr=MUSIC_SR)
        t_hpss = (time.perf_counter() - t0) / n_hpss

    total = t_decode + t_analysis + t_metric
    frames = int(args.seconds * fps)
    print(f"{args.n} sequences x {args.seconds:g} s audio ({args.sr} Hz) + {frames}-frame motion")
    for label, t in (
        ("decode + resample", t_decode),
        ("librosa analysis", t_analysis),
        ("momu metric code", t_metric),
    ):
        print(f"  {label:<18}: {t:8.3f} s  ({1e3 * t / args.n:7.3f} ms/seq, {100 * t / total:5.1f} %)")
    print(f"  decode / metric   : {t_decode / t_metric:8.1f} x")
    print(f"  reference-style BA loop (motion beats + loop): {1e3 * t_ref_loop / args.n:.3f} ms/seq")
    print(f"  Bailando HPSS recipe (extra, per sequence): {1e3 * t_hpss:.1f} ms/seq")
    print(f"  mean BAS {np.mean(bas_scores):.4f}; beat_align_score check {beat_align_score([1], [1]):.1f}")


if __name__ == "__main__":
    main()
