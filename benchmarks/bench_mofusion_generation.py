"""Benchmark: MoFusion music→dance generation of a 30 s clip with the cpu-size and paper-size U-Net.

Builds :class:`momu.methods.mofusion.MoFusionModel` around a randomly initialised ``unet1d`` (the cost of
a forward pass does not depend on training) with the U-Net of ``recipes/configs/mofusion.yaml`` (cpu)
or ``recipes/configs/mofusion_paper.yaml`` (paper: base 128, 16 heads, cross-attention 1024), and
times :meth:`MoFusionModel.music_to_dance` for ``--steps`` DDIM steps (mel, every reverse step, decoding;
guidance 1 = one pass per step). The paper samples 1000 DDPM steps; the line ``per 1000 steps``
extrapolates linearly from the measured per-step time (a reverse step costs the same whatever the
scheduler). Also prints the process's CPU time and peak resident memory.

    OMP_NUM_THREADS=2 python benchmarks/bench_mofusion_generation.py [--seconds 30] [--steps 50]
        [--size cpu paper]

Prints one line per measurement; nothing is asserted.
"""

from __future__ import annotations

import argparse
import resource
import time
from pathlib import Path

import numpy as np
import torch
from omegaconf import OmegaConf

from momu.config import build_component, load_config
from momu.features.preprocess import Normalizer
from momu.methods.mofusion import MoFusionConfig, MoFusionModel
from momu.methods.mofusion.data import MoFusionNormalizers
from momu.methods.mofusion.method import node_with
from momu.registry import BACKBONES

ROOT = Path(__file__).resolve().parents[1]


def backbone_node(size: str) -> dict:
    if size == "cpu":
        node = load_config(ROOT / "recipes" / "configs" / "mofusion.yaml").method.backbone
    else:
        node = OmegaConf.load(ROOT / "recipes" / "configs" / "mofusion_paper.yaml").music.method.backbone
    return node_with(OmegaConf.to_container(node), BACKBONES, in_channels=72, cond_channels=80)


def build(size: str, steps: int) -> MoFusionModel:
    node = backbone_node(size)
    cfg = OmegaConf.to_object(
        OmegaConf.merge(
            OmegaConf.structured(MoFusionConfig),
            {
                "sampler": {
                    "name": "cfg",
                    "guidance_scale": 1.0,
                    "scheduler": {"name": "ddim", "num_inference_steps": steps},
                }
            },
        )
    )
    norms = MoFusionNormalizers(Normalizer(np.zeros(72), np.ones(72)), Normalizer(np.zeros(80), np.ones(80)))
    return MoFusionModel(
        cfg=cfg,  # type: ignore[arg-type]
        backbone=build_component(node, "backbones"),
        norms=norms,
        skeleton="smpl24",
        backbone_node=node,
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=30.0)
    parser.add_argument("--steps", type=int, default=50)
    parser.add_argument("--size", nargs="+", default=["cpu", "paper"], choices=["cpu", "paper"])
    args = parser.parse_args()
    rng = np.random.default_rng(0)
    wave = (0.1 * rng.standard_normal(int(args.seconds * 16000) + 16000)).astype(np.float32)
    for size in args.size:
        model = build(size, args.steps)
        params = sum(p.numel() for p in model.backbone.parameters())
        model.music_to_dance([(wave, 16000)], [2.0], [0])  # warm-up (mel filters, allocator)
        wall, cpu = time.perf_counter(), time.process_time()
        out = model.music_to_dance([(wave, 16000)], [args.seconds], [1])[0]
        wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
        print(
            f"{size}: unet1d {params / 1e6:.2f} M parameters, {out.shape[0]} frames "
            f"({args.seconds:g} s at 20 fps), "
            f"{args.steps} steps: {wall:.1f} s wall, {cpu:.1f} s CPU, {torch.get_num_threads()} threads; "
            f"per 1000 steps (the paper's DDPM): {wall / args.steps * 1000 / 60:.1f} min"
        )
    print(f"peak RSS {resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024:.0f} MiB")


if __name__ == "__main__":
    main()
