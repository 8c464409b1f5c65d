"""Wall time and peak memory of a dance for a 3-minute song, and the seam statistic of its windows.

    python benchmarks/bench_long_song.py [--model DIR] [--seconds 180] [--threads 2] [--out FILE.json]

The song is a ``synth_dance`` song of the model's skeleton (seed 1, not a training clip's seed). Timed:
``music_to_motion_long`` (encode, windowed inpainting, decode) and, separately, writing the BVH, npz and
mp4 outputs as ``momu generate dance`` does. Peak memory is the process's maximum resident set size.
The seam statistic compares the joint-velocity jump (``momu.generation.velocity_jumps``, m/s²) at every
window boundary with the 95th percentile of the same statistic on real-like data (synth_dance clips of
the same skeleton) and on the generated dance away from the boundaries.
"""

from __future__ import annotations

import argparse
import json
import resource
import tempfile
import time
from pathlib import Path

import numpy as np
import torch


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--model", type=Path)
    p.add_argument("--seconds", type=float, default=180.0)
    p.add_argument("--threads", type=int, default=2)
    p.add_argument("--out", type=Path)
    args = p.parse_args()
    torch.set_num_threads(args.threads)

    from momu.cli.generate_io import default_model_dir
    from momu.cli.generate_write import write_dance_outputs
    from momu.data.synth.dataset import SynthConfig, generate_clip
    from momu.generation import seam_jumps, velocity_jumps
    from momu.generation.momu_long import music_to_motion_long, plan_for_seconds
    from momu.methods.momu import MoMuModel

    folder = args.model or default_model_dir("dance")
    model = MoMuModel.load(folder)
    song = generate_clip(
        SynthConfig(
            num_clips=1, min_seconds=args.seconds, max_seconds=args.seconds, skeleton=model.skeleton, seed=1
        ),
        0,
    )
    assert song.audio is not None and song.sample_rate is not None
    rss0 = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    start = time.perf_counter()
    (motion,) = music_to_motion_long(model, [song.audio], song.sample_rate, [0])
    generate_s = time.perf_counter() - start
    fps = model.rates.motion_fps
    with tempfile.TemporaryDirectory() as tmp:
        paths = {f: Path(tmp) / f"dance.{f}" for f in ("npz", "bvh", "mp4")}
        start = time.perf_counter()
        write_dance_outputs(paths, motion, fps, model.skeleton, song.audio, song.sample_rate, {})
        write_s = time.perf_counter() - start
        sizes = {f: p.stat().st_size for f, p in paths.items()}
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024

    plan = plan_for_seconds(model, args.seconds)
    frames = [b * model.rates.motion_frames_per_latent for b in plan.boundaries]
    seams = seam_jumps(motion, frames, fps)
    jumps = velocity_jumps(motion, fps)
    away = np.ones(len(jumps), dtype=bool)
    for b in frames:
        away[max(0, b - 3) : b + 2] = False
    data = np.concatenate(
        [
            velocity_jumps(clip.motion, clip.fps)
            for clip in (
                generate_clip(SynthConfig(num_clips=8, skeleton=model.skeleton, seed=9), i) for i in range(8)
            )
        ]
    )
    result = {
        "model": str(folder),
        "song_seconds": args.seconds,
        "threads": args.threads,
        "windows": len(plan.starts),
        "generate_s": round(generate_s, 2),
        "write_outputs_s": round(write_s, 2),
        "peak_rss_mib": round(peak, 1),
        "rss_before_generation_mib": round(rss0, 1),
        "output_bytes": sizes,
        "seam_jump_m_s2": {
            "median": float(np.median(seams)),
            "max": float(seams.max()),
            "data_p95": float(np.percentile(data, 95)),
            "generated_away_from_seams_p95": float(np.percentile(jumps[away], 95)),
            "fraction_of_seams_above_data_p95": float(np.mean(seams > np.percentile(data, 95))),
        },
    }
    text = json.dumps(result, indent=2)
    print(text)
    if args.out:
        args.out.write_text(text + "\n")


if __name__ == "__main__":
    main()
