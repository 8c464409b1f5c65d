"""Run under `accelerate launch --multi_gpu --num_processes 2`: train a toy stage, gather an evaluation."""

from __future__ import annotations

import sys
from pathlib import Path

import torch
from torch import nn
from torch.utils.data import TensorDataset

from momu.engine import (
    RunConfig,
    TrainConfig,
    finish_accelerator,
    make_accelerator,
    map_gathered,
    train_stage,
)
from momu.io import write_json


def loss_fn(model: nn.Module, batch: list[torch.Tensor]) -> torch.Tensor:
    x, y = batch
    return ((model(x) - y) ** 2).mean()


def main(out: Path) -> None:
    acc = make_accelerator(RunConfig(tracker="none"), out, "two-procs", {})
    x = torch.randn(30, 2, generator=torch.Generator().manual_seed(0))
    model = train_stage(
        acc,
        name="toy",
        model=nn.Linear(2, 1),
        dataset=TensorDataset(x, x.sum(1, keepdim=True)),
        loss_fn=loss_fn,
        cfg=TrainConfig(steps=6, batch_size=4, checkpoint_every=3),
        checkpoint_root=out / "ckpt",
    )
    # 7 items over 2 processes with batch 2: the last round is padded; nothing may come back twice
    results = map_gathered(acc, list(range(7)), lambda b: [(i, acc.process_index) for i in b], batch_size=2)
    if acc.is_main_process:
        write_json(
            out / "result.json",
            {
                "num_processes": acc.num_processes,
                "items": [r[0] for r in results],
                "ranks": sorted({r[1] for r in results}),
                "weight": model.weight.detach().flatten().tolist(),
            },
        )
    finish_accelerator(acc)


if __name__ == "__main__":
    main(Path(sys.argv[1]))
