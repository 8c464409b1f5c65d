"""Benchmark: 50-step DDIM music→motion generation of a 30 s clip on CPU (MoMu §5.1, §5.3).

Generation runs in MoMu's aligned latent space: the mel (62.5 frames/s, MoMu App. B.2) is
downsampled ×4 by the BiCoR-VAE, so a 30 s clip is ~469 latent frames of 20 channels for both the
music condition and the motion latent. The denoiser is the `dit` backbone at a small `cpu` size (or
Table 9's `paper` size); classifier-free guidance runs its conditional and unconditional branches
as one batched forward (batch 2B). Weights are random: the cost of sampling does not depend on them.

Prints wall time per generation, per step, and peak resident memory (whole process, and its growth
during generation).

    python benchmarks/bench_generation.py [--preset cpu|paper] [--seconds 30] [--steps 50] [--threads 2]
"""

from __future__ import annotations

import argparse
import json
import resource
import sys
import time

import torch

from momu.registry import BACKBONES, SAMPLERS

PRESETS = {
    "cpu": {"hidden": 128, "depth": 2, "heads": 4, "cond_embed_dim": 256},
    "paper": {"hidden": 576, "depth": 4, "heads": 8, "cond_embed_dim": 1024},  # MoMu Table 9
}


def peak_rss_mib() -> float:
    """Peak resident set size of this process in MiB (Linux reports KiB)."""
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--preset", choices=sorted(PRESETS), default="cpu")
    p.add_argument("--seconds", type=float, default=30.0, help="clip length in seconds")
    p.add_argument("--latent-rate", type=float, default=62.5 / 4, help="latent frames per second")
    p.add_argument("--channels", type=int, default=20, help="latent channels (Table 9: 20)")
    p.add_argument("--steps", type=int, default=50, help="DDIM steps (MoMu §5.1: 50)")
    p.add_argument("--batch", type=int, default=1)
    p.add_argument("--threads", type=int, default=torch.get_num_threads())
    p.add_argument("--repeats", type=int, default=2)
    args = p.parse_args(argv)

    torch.set_num_threads(args.threads)
    torch.manual_seed(0)
    frames = int(round(args.seconds * args.latent_rate))
    cfg = {**PRESETS[args.preset], "in_channels": args.channels, "cond_channels": args.channels}
    cfg["max_length"] = 2 * frames + 1
    model = BACKBONES.build("dit", cfg).eval()
    sampler = SAMPLERS.build("cfg", {"guidance_scale": 3.0, "scheduler": {"name": "ddim"}})
    music_latent = torch.randn(args.batch, frames, args.channels)

    calls: list[int] = []
    model.register_forward_pre_hook(lambda m, a, kw: calls.append(a[0].shape[0]), with_kwargs=True)

    base_rss = peak_rss_mib()
    times = []
    for r in range(args.repeats):
        gen = torch.Generator().manual_seed(r)
        start = time.perf_counter()
        motion = sampler.sample(
            model,
            (args.batch, frames, args.channels),
            music_latent,
            generator=gen,
            num_inference_steps=args.steps,
        )
        times.append(time.perf_counter() - start)
    assert motion.shape == (args.batch, frames, args.channels) and torch.isfinite(motion).all()
    forwards_per_run = len(calls) // args.repeats
    result = {
        "preset": args.preset,
        "params_M": round(sum(p.numel() for p in model.parameters()) / 1e6, 2),
        "clip_seconds": args.seconds,
        "latent_frames": frames,
        "fused_tokens": 2 * frames + 1,
        "ddim_steps": args.steps,
        "batch": args.batch,
        "forward_batch": calls[0],
        "forwards_per_generation": forwards_per_run,
        "threads": args.threads,
        "wall_s_per_generation": [round(t, 3) for t in times],
        "best_s": round(min(times), 3),
        "ms_per_step": round(1000 * min(times) / args.steps, 1),
        "peak_rss_mib": round(peak_rss_mib(), 1),
        "rss_growth_during_generation_mib": round(peak_rss_mib() - base_rss, 1),
        "torch": torch.__version__,
    }
    sys.stdout.write(json.dumps(result, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
