"""Train a small stage; write the thread count and a hash of the weights (test_launch_threads.py)."""

from __future__ import annotations

import hashlib
import json
import sys
from pathlib import Path

import torch
from torch import nn
from torch.utils.data import TensorDataset

from momu.engine import RunConfig, TrainConfig, finish_accelerator, make_accelerator, train_stage

out = Path(sys.argv[1])
acc = make_accelerator(RunConfig(tracker="none"), out, "thr", {})
g = torch.Generator().manual_seed(0)
x = torch.randn(128, 64, generator=g)
y = torch.randn(128, 1, generator=g)
torch.manual_seed(0)
model = nn.Sequential(nn.Linear(64, 128), nn.Tanh(), nn.Linear(128, 1))
m = train_stage(
    acc,
    name="t",
    model=model,
    dataset=TensorDataset(x, y),
    loss_fn=lambda m, b: ((m(b[0]) - b[1]) ** 2).mean(),
    cfg=TrainConfig(steps=8, batch_size=32, lr=1e-3),
    checkpoint_root=out / "ck",
)
h = hashlib.sha256(b"".join(v.numpy().tobytes() for v in m.state_dict().values())).hexdigest()
(out / "r.json").write_text(json.dumps({"threads": torch.get_num_threads(), "hash": h}))
finish_accelerator(acc)
