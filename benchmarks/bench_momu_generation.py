"""Benchmark: MoMu music→motion generation of a 30 s clip with 50 DDIM steps at the ``cpu`` preset size.

Times one call of :meth:`momu.methods.momu.MoMuModel.music_to_motion` (music encoding, 50 DDIM steps
of classifier-free guidance with the conditional and unconditional branches in ONE batched forward,
motion decoding) and reports the process's peak resident memory. Weights are random: the cost of a
forward pass does not depend on training. The DiT's ``max_length`` is raised to 1024 so a 30 s clip
fits (2 × 468 latent frames + 1 tokens at the cpu preset's 15.6 Hz latent rate).

    OMP_NUM_THREADS=2 python benchmarks/bench_momu_generation.py [--seconds 30] [--steps 50] [--repeats 2]

Prints one line per measurement; nothing is asserted.
"""

from __future__ import annotations

import argparse
import resource
import time
from pathlib import Path

import numpy as np
import torch

from momu.config import build_component, load_config
from momu.features.preprocess import Normalizer
from momu.methods.momu import MoMuModel
from momu.methods.momu.data import MoMuNormalizers

ROOT = Path(__file__).resolve().parents[1]


def build(seconds: float, steps: int) -> tuple[MoMuModel, np.ndarray]:
    cfg = load_config(
        ROOT / "recipes" / "configs" / "momu.yaml",
        [
            "method.music_backbone.max_length=1024",
            "method.motion_backbone.max_length=1024",
            f"method.sampler.num_inference_steps={steps}",
            "dataset.num_clips=3",
            f"dataset.min_seconds={seconds}",
            f"dataset.max_seconds={seconds}",
        ],
    )
    method = build_component(cfg.method, "methods")
    dataset = build_component(cfg.dataset, "datasets")
    clips = [dataset[i] for i in range(len(dataset))]
    torch.manual_seed(0)
    vae = method.build_encoder().eval()
    d = vae.latent_channels
    music_node, motion_node = method.backbone_nodes(d)
    model = MoMuModel(
        cfg=method.cfg,
        vae=vae,
        music_backbone=build_component(music_node, "backbones"),
        motion_backbone=build_component(motion_node, "backbones"),
        norms=MoMuNormalizers.fit(clips[:1], method.cfg.sample_rate),
        latent_music=Normalizer(np.zeros(d), np.ones(d)),
        latent_motion=Normalizer(np.zeros(d), np.ones(d)),
        rates=method.rates(vae),
        skeleton=str(clips[0].skeleton),
        bone_lengths=np.zeros(0),
        backbone_nodes=(music_node, motion_node),
    )
    return model, np.asarray(clips[0].audio)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=30.0)
    parser.add_argument("--steps", type=int, default=50)
    parser.add_argument("--repeats", type=int, default=2)
    args = parser.parse_args()
    model, audio = build(args.seconds, args.steps)
    params = sum(p.numel() for p in model.motion_backbone.parameters())
    print(
        f"music->motion, {args.seconds:.0f} s clip, {args.steps} DDIM steps, "
        f"latent {model.rates.latent_rate:.2f} Hz, "
        f"DiT {params / 1e6:.2f}M params, torch threads {torch.get_num_threads()}"
    )
    for r in range(args.repeats):
        start = time.perf_counter()
        (motion,) = model.music_to_motion([audio], model.rates.sample_rate, [r])
        wall = time.perf_counter() - start
        print(f"repeat {r}: {wall:.2f} s wall, motion {motion.shape} at {model.rates.motion_fps:.1f} fps")
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
    print(f"peak resident memory: {peak:.0f} MiB")


if __name__ == "__main__":
    main()
