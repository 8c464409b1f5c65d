"""Benchmark: what a checkpoint costs against a training step (issue 13: the default interval).

Usage::

    python benchmarks/bench_checkpoint.py [--steps 20] [--threads N]

For the MoMu denoiser at the ``cpu`` preset size (θ_a: DiT hidden 128, depth 4) and at the
``paper`` size (MoMu Table 9: hidden 576, depth 4, condition embedding 1024), it times one
optimizer step (batch 16 of 4-s latent windows, AdamW) and one crash-safe checkpoint
(:func:`momu.engine.trainer._save`: model + optimizer + RNG, staging folder, marker, rename), then
prints the overhead of checkpointing every ``checkpoint_minutes`` (the default 10) and every N steps.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path
from typing import Any

import torch

from momu.engine.accelerate_setup import RunConfig, make_accelerator
from momu.engine.trainer import TrainConfig, _save
from momu.registry import BACKBONES

SIZES = {
    "cpu (θ_a)": {"hidden": 128, "heads": 4, "depth": 4, "cond_embed_dim": 128, "channels": 16, "frames": 62},
    "paper (Table 9)": {
        "hidden": 576,
        "heads": 8,
        "depth": 4,
        "cond_embed_dim": 1024,
        "channels": 20,
        "frames": 125,
    },
}


def _model(size: dict[str, int]) -> torch.nn.Module:
    return BACKBONES.build(
        "dit",
        {
            "in_channels": size["channels"],
            "cond_channels": size["channels"],
            "hidden": size["hidden"],
            "heads": size["heads"],
            "depth": size["depth"],
            "cond_embed_dim": size["cond_embed_dim"],
            "max_length": 512,
        },
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--steps", type=int, default=20, help="timed optimizer steps per size")
    parser.add_argument("--threads", type=int, default=None, help="torch threads (default: momu's choice)")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        accelerator = make_accelerator(RunConfig(tracker="none"), Path(tmp), "bench", {})
        if args.threads:
            torch.set_num_threads(args.threads)
        print(f"torch threads: {torch.get_num_threads()}")
        for label, size in SIZES.items():
            model = _model(size)
            params = sum(p.numel() for p in model.parameters())
            optimizer = torch.optim.AdamW(model.parameters(), lr=1e-4)
            model, optimizer = accelerator.prepare(model, optimizer)
            b, c, n = 16, size["channels"], size["frames"]
            x, cond = torch.randn(b, n, c), torch.randn(b, n, c)

            def step(model: Any = model, optimizer: Any = optimizer, x: Any = x, cond: Any = cond) -> None:
                t = torch.randint(0, 1000, (x.shape[0],))
                loss = (model(x, t, cond) - x).pow(2).mean()
                accelerator.backward(loss)
                optimizer.step()
                optimizer.zero_grad(set_to_none=True)

            step()  # warm-up (and optimizer state)
            t0 = time.perf_counter()
            for _ in range(args.steps):
                step()
            per_step = (time.perf_counter() - t0) / args.steps
            root = Path(tmp) / label.split()[0]
            saves = []
            for i in range(3):
                t0 = time.perf_counter()
                _save(accelerator, root, i + 1, model, optimizer, TrainConfig(keep_checkpoints=2))
                saves.append(time.perf_counter() - t0)
            save = sorted(saves)[1]
            size_mb = sum(p.stat().st_size for p in (root / "step_00000003").iterdir()) / 1e6
            print(
                f"{label}: {params / 1e6:.2f} M parameters, step {per_step * 1000:.0f} ms, "
                f"checkpoint {save * 1000:.0f} ms ({size_mb:.1f} MB)"
            )
            for minutes in (10.0, 5.0):
                print(f"  every {minutes:g} min: {100 * save / (60 * minutes):.3f} % of training time")
            for every in (100, 500, 1000):
                print(f"  every {every} steps: {100 * save / (every * per_step):.2f} % of training time")


if __name__ == "__main__":
    main()
