"""The shared training loop: exact resume, SIGTERM checkpoints, pickle-free state, evaluation gather."""

from __future__ import annotations

import dataclasses
import math
import os
import signal
from pathlib import Path

import pytest
import torch
from torch import nn
from torch.utils.data import TensorDataset

from momu.engine import Preempted, RunConfig, TrainConfig, make_accelerator, map_gathered, train_stage
from momu.engine.state import capture_rng, flatten_state, latest_checkpoint, restore_rng, unflatten_state
from momu.engine.trainer import lr_factor


def _data() -> TensorDataset:
    gen = torch.Generator().manual_seed(0)
    x = torch.randn(40, 3, generator=gen)
    y = x @ torch.tensor([[1.0], [-2.0], [0.5]]) + 0.1
    return TensorDataset(x, y)


def _loss(model: nn.Module, batch: list[torch.Tensor]) -> torch.Tensor:
    x, y = batch
    noise = 0.01 * torch.randn_like(y)  # uses the global RNG, as diffusion losses do
    return ((model(x) - y - noise) ** 2).mean()


def _model(seed: int) -> nn.Module:
    torch.manual_seed(seed)
    return nn.Sequential(nn.Linear(3, 8), nn.Tanh(), nn.Linear(8, 1))


CFG = TrainConfig(steps=12, batch_size=4, lr=1e-2, grad_accum=2, checkpoint_every=4, log_every=3, seed=3)


def _accelerator(tmp: Path):
    return make_accelerator(RunConfig(tracker="none"), tmp, "test", {})


def _train(acc, root: Path, cfg: TrainConfig = CFG, *, model_seed: int = 0, loss_fn=_loss, **kw) -> nn.Module:
    """``train_stage`` on the toy regression data with a fresh ``_model(model_seed)``."""
    kw.setdefault("name", "run")
    return train_stage(
        acc, model=_model(model_seed), dataset=_data(), loss_fn=loss_fn, cfg=cfg, checkpoint_root=root, **kw
    )


@pytest.mark.parametrize("schedule", ["constant", "cosine"])
def test_resume_after_interruption_is_bit_identical(tmp_path: Path, schedule: str) -> None:
    cfg = dataclasses.replace(CFG, lr_schedule=schedule, warmup_steps=2)
    acc = _accelerator(tmp_path)
    reference = _train(acc, tmp_path / "a", cfg, name="ref")

    calls = {"n": 0}

    def crashing_loss(model: nn.Module, batch: list[torch.Tensor]) -> torch.Tensor:
        calls["n"] += 1
        if calls["n"] == 15:  # micro-batch 15 = inside optimizer step 8, after the step-4 checkpoint
            raise KeyboardInterrupt
        return _loss(model, batch)

    with pytest.raises(KeyboardInterrupt):
        _train(acc, tmp_path / "b", cfg, loss_fn=crashing_loss)
    assert latest_checkpoint(tmp_path / "b").name == "step_00000004"
    torch.manual_seed(1234)  # a resumed process starts with arbitrary RNG state and weights
    resumed = _train(acc, tmp_path / "b", cfg, model_seed=99, resume=True)
    for (name, a), (_, b) in zip(reference.state_dict().items(), resumed.state_dict().items()):
        assert torch.equal(a, b), name


def test_training_reduces_loss_and_keeps_newest_checkpoints(tmp_path: Path) -> None:
    acc = _accelerator(tmp_path)
    data = _data()
    model = _model(0)
    before = _loss(model, data.tensors).item()
    cfg = TrainConfig(steps=40, batch_size=8, lr=3e-2, checkpoint_every=10, keep_checkpoints=2)
    trained = train_stage(
        acc, name="fit", model=model, dataset=data, loss_fn=_loss, cfg=cfg, checkpoint_root=tmp_path
    )
    assert _loss(trained, data.tensors).item() < 0.5 * before
    assert sorted(p.name for p in tmp_path.glob("step_*")) == ["step_00000030", "step_00000040"]
    assert (
        not list(tmp_path.rglob("*.pkl"))
        and not list(tmp_path.rglob("*.bin"))
        and not list(tmp_path.rglob("*.pt"))
    )


def test_lr_factor_warms_up_then_follows_the_schedule() -> None:
    const = TrainConfig(steps=10, warmup_steps=4)
    assert [lr_factor(s, const) for s in range(6)] == [0.25, 0.5, 0.75, 1.0, 1.0, 1.0]
    cos = dataclasses.replace(const, lr_schedule="cosine")
    assert [lr_factor(s, cos) for s in range(4)] == [0.25, 0.5, 0.75, 1.0]
    assert lr_factor(4, cos) == 1.0  # decay starts after the warm-up
    assert math.isclose(lr_factor(7, cos), 0.5)  # half-way through the 6 post-warm-up steps
    assert math.isclose(lr_factor(10, cos), 0.0, abs_tol=1e-12)
    factors = [lr_factor(s, cos) for s in range(4, 11)]
    assert all(a > b for a, b in zip(factors, factors[1:]))


def test_unknown_lr_schedule_fails_before_training(tmp_path: Path) -> None:
    cfg = dataclasses.replace(CFG, lr_schedule="linear")
    with pytest.raises(ValueError, match="lr_schedule"):
        _train(_accelerator(tmp_path), tmp_path / "c", cfg, name="bad")
    assert not (tmp_path / "c").exists()


def test_sigterm_writes_a_checkpoint_then_raises(tmp_path: Path) -> None:
    acc = _accelerator(tmp_path)
    before = signal.getsignal(signal.SIGTERM)
    calls = {"n": 0}

    def loss_then_sigterm(model: nn.Module, batch: list[torch.Tensor]) -> torch.Tensor:
        calls["n"] += 1
        if calls["n"] == 6:  # during optimizer step 3 (grad_accum 2)
            os.kill(os.getpid(), signal.SIGTERM)
        return _loss(model, batch)

    with pytest.raises(Preempted, match="--resume") as err:
        _train(acc, tmp_path, name="pre", loss_fn=loss_then_sigterm)
    assert err.value.checkpoint.name == "step_00000003"
    assert (err.value.checkpoint / "model.safetensors").is_file()
    assert signal.getsignal(signal.SIGTERM) is before  # the caller's handler is restored


def test_resume_with_completed_stage_trains_nothing(tmp_path: Path) -> None:
    acc = _accelerator(tmp_path)
    cfg = TrainConfig(steps=4, batch_size=4)
    first = _train(acc, tmp_path, cfg, name="s")
    calls = {"n": 0}

    def counting(model: nn.Module, batch: list[torch.Tensor]) -> torch.Tensor:
        calls["n"] += 1
        return _loss(model, batch)

    again = _train(acc, tmp_path, cfg, name="s", model_seed=5, loss_fn=counting, resume=True)
    assert calls["n"] == 0
    assert all(torch.equal(a, b) for a, b in zip(first.parameters(), again.parameters()))


def test_dataset_smaller_than_a_batch_is_a_clear_error(tmp_path: Path) -> None:
    small = TensorDataset(torch.zeros(2, 3), torch.zeros(2, 1))
    with pytest.raises(ValueError, match="dataset has 2 items, fewer than one batch"):
        train_stage(
            _accelerator(tmp_path),
            name="x",
            model=_model(0),
            dataset=small,
            loss_fn=_loss,
            cfg=TrainConfig(batch_size=4),
            checkpoint_root=tmp_path,
        )


def test_state_flattening_round_trips_nested_optimizer_state() -> None:
    state = {
        "state": {0: {"step": torch.tensor(3.0), "exp_avg": torch.ones(2)}},
        "param_groups": [{"lr": 0.1, "betas": (0.9, 0.99), "params": [0]}],
        "flag": None,
    }
    skeleton, tensors = flatten_state(state)
    again = unflatten_state(skeleton, tensors)
    assert again["param_groups"][0]["betas"] == (0.9, 0.99)
    assert torch.equal(again["state"][0]["exp_avg"], torch.ones(2)) and 0 in again["state"]
    with pytest.raises(TypeError, match="without pickle"):
        flatten_state({"bad": object()})


def test_rng_capture_restore() -> None:
    import random

    import numpy as np

    saved = capture_rng()
    a = (torch.rand(3), np.random.rand(3), random.random())
    restore_rng(saved)
    b = (torch.rand(3), np.random.rand(3), random.random())
    assert torch.equal(a[0], b[0]) and np.array_equal(a[1], b[1]) and a[2] == b[2]


def test_map_gathered_returns_each_item_once_in_order(tmp_path: Path) -> None:
    acc = _accelerator(tmp_path)
    out = map_gathered(acc, list(range(10, 17)), lambda batch: [i * 2 for i in batch], batch_size=3)
    assert out == [i * 2 for i in range(10, 17)]


def test_run_context_remembers_derived_values_per_key_and_forgets_the_oldest(tmp_path: Path) -> None:
    from momu.engine.context import REMEMBERED, RunContext

    ctx = RunContext(
        accelerator=make_accelerator(RunConfig(tracker="none"), tmp_path, "t", {}), out_dir=tmp_path
    )
    builds: list[int] = []

    def build(k: int) -> list[int]:
        builds.append(k)
        return [k]

    first = ctx.remember({"split": "train", "k": 0}, lambda: build(0))
    assert ctx.remember({"k": 0, "split": "train"}, lambda: build(0)) is first  # key order does not matter
    assert builds == [0]
    for k in range(1, REMEMBERED + 1):  # REMEMBERED newer keys push key 0 out
        ctx.remember({"split": "train", "k": k}, lambda k=k: build(k))
    ctx.remember({"split": "train", "k": REMEMBERED}, lambda: build(-1))  # still there
    assert builds == list(range(REMEMBERED + 1))
    assert ctx.remember({"split": "train", "k": 0}, lambda: build(0)) == [0]
    assert builds == [*range(REMEMBERED + 1), 0]
