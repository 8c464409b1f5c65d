"""Training fast paths (docs/performance.md): each changes no number beyond a tolerance, keys stay put."""

from __future__ import annotations

import dataclasses
import os
import sys
from collections.abc import Callable, Iterator
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import pytest
import torch
import torch.nn.functional as F
from torch import nn
from torch.utils.data import Dataset, TensorDataset

from momu.backbones.dit import DiT, DiTConfig
from momu.engine import RunConfig, TrainConfig, make_accelerator, train_stage
from momu.engine.context import stage_identity, stage_key_hash
from momu.engine.fast_paths import compile_backbones, fused_supported, loader_options, make_adamw
from momu.engine.trainer import without_later_defaults

# Stage-key hashes (a default TrainConfig, and one with non-default fields) as they were when stages
# became seeded from (seed, stage name) (issue 34, which renamed every stage folder on purpose: the
# weights changed): a fast-path field at its default must not rename a long run's cached stages.
BEFORE = {"default": "c793340928d8", "custom": "7dda9416de2a"}
CUSTOM = {"steps": 7, "batch_size": 3, "lr": 3e-4, "num_workers": 2, "log_every": 5}


def _hash(name: str, cfg: TrainConfig, extra: dict | None = None) -> str:
    acc = SimpleNamespace(num_processes=1, device=torch.device("cpu"), mixed_precision="no")
    key = {"name": name, **(extra or {}), "train": dataclasses.asdict(cfg)}
    return stage_key_hash(stage_identity(key, acc, cfg))  # type: ignore[arg-type]


def test_stage_keys_of_existing_configs_keep_their_hashes(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(torch, "get_num_threads", lambda: 1)
    assert _hash("x", TrainConfig()) == BEFORE["default"]
    assert _hash("y", TrainConfig(**CUSTOM), {"model": {"a": 1}}) == BEFORE["custom"]
    assert _hash("x", TrainConfig(pin_memory=False)) == BEFORE["default"]  # weight-neutral
    for change in ({"compile": "eager"}, {"fused_optimizer": True}, {"attention": "math"}):
        assert _hash("x", TrainConfig(**change)) != BEFORE["default"], change  # type: ignore[arg-type]
    assert _hash("x", TrainConfig(num_workers=2)) != BEFORE["default"]  # workers draw their own RNG


def test_later_fields_leave_config_hashes_only_at_their_defaults() -> None:
    node = {"train_music_vae": dataclasses.asdict(TrainConfig()), "other": {"compile": "none"}}
    view = without_later_defaults(node)
    assert "compile" not in view["train_music_vae"] and "pin_memory" not in view["train_music_vae"]
    assert view["other"] == {"compile": "none"}  # not a TrainConfig: untouched
    changed = without_later_defaults({"t": dataclasses.asdict(TrainConfig(compile="eager"))})
    assert changed["t"]["compile"] == "eager"


@pytest.mark.parametrize(
    ("field", "value"),
    [("attention", "fastest"), ("compile", "turbo"), ("fused_optimizer", "yes"), ("num_workers", -1)],
)
def test_bad_fast_path_values_name_their_key(tmp_path: Path, field: str, value: object) -> None:
    cfg = dataclasses.replace(TrainConfig(steps=1, batch_size=2), **{field: value})
    acc = make_accelerator(RunConfig(tracker="none"), tmp_path, "t", {})
    with pytest.raises(ValueError, match=f"train.{field}"):
        train_stage(
            acc,
            name="s",
            model=nn.Linear(3, 1),
            dataset=_toy(),
            loss_fn=_mse,
            cfg=cfg,
            checkpoint_root=tmp_path,
        )


def _toy() -> TensorDataset:
    gen = torch.Generator().manual_seed(0)
    x = torch.randn(32, 3, generator=gen)
    return TensorDataset(x, x.sum(dim=1, keepdim=True))


def _mse(model: nn.Module, batch: list[torch.Tensor]) -> torch.Tensor:
    x, y = batch
    return F.mse_loss(model(x), y)


def test_loader_options_pin_only_on_cuda_and_persist_only_with_workers() -> None:
    cfg = TrainConfig(persistent_workers=True)
    assert loader_options(cfg, torch.device("cpu")) == {
        "num_workers": 0,
        "pin_memory": False,
        "persistent_workers": False,
    }
    on_gpu = loader_options(dataclasses.replace(cfg, num_workers=2), torch.device("cuda"))
    assert on_gpu == {"num_workers": 2, "pin_memory": True, "persistent_workers": True}


def test_fused_adamw_on_cpu_matches_the_default() -> None:
    results = []
    for fused in (False, True):
        torch.manual_seed(0)
        model = nn.Linear(4, 2)
        opt = make_adamw(list(model.parameters()), TrainConfig(lr=1e-2, fused_optimizer=fused))
        assert opt.defaults.get("fused") is (True if fused and fused_supported(model.parameters()) else None)
        for _ in range(5):
            model(torch.ones(3, 4)).square().mean().backward()
            opt.step()
            opt.zero_grad()
        results.append(model.weight.detach().clone())
    torch.testing.assert_close(results[0], results[1], rtol=1e-6, atol=1e-7)


def test_fused_adamw_falls_back_for_unsupported_parameters() -> None:
    p = nn.Parameter(torch.zeros(2, dtype=torch.complex64))
    assert not fused_supported([p])
    assert make_adamw([p], TrainConfig(fused_optimizer=True)).defaults.get("fused") is None


def _tiny_dit() -> DiT:
    torch.manual_seed(0)
    return DiT(
        DiTConfig(
            in_channels=4,
            cond_channels=4,
            cond_embed_dim=16,
            hidden=16,
            heads=2,
            depth=1,
            max_length=64,
            time_freq_dim=16,
        )
    )


class _DiTData(Dataset[dict[str, torch.Tensor]]):
    def __init__(self) -> None:
        gen = torch.Generator().manual_seed(1)
        self.x, self.c = torch.randn(16, 8, 4, generator=gen), torch.randn(16, 8, 4, generator=gen)

    def __len__(self) -> int:
        return 16

    def __getitem__(self, i: int) -> dict[str, torch.Tensor]:
        return {"x": self.x[i], "c": self.c[i]}


def _dit_loss(
    model: nn.Module, batch: dict[str, torch.Tensor]
) -> tuple[torch.Tensor, dict[str, torch.Tensor]]:
    b = batch["x"].shape[0]
    dev = batch["x"].device
    t = torch.randint(0, 100, (b,), device=dev)
    drop = torch.rand(b, device=dev) < 0.5
    eps = model(batch["x"], t, batch["c"], drop_cond=drop)
    loss = F.mse_loss(eps, batch["x"])
    return loss, {"half": (loss / 2).detach()}


def _trained_dit(tmp: Path, mixed: str = "no", **fields: object) -> nn.Module:
    cfg = TrainConfig(steps=3, batch_size=4, lr=1e-3, log_every=1, checkpoint_minutes=0, **fields)  # type: ignore[arg-type]
    acc = make_accelerator(RunConfig(tracker="none", mixed_precision=mixed), tmp, "t", {})
    return train_stage(
        acc,
        name="dit",
        model=_tiny_dit(),
        dataset=_DiTData(),
        loss_fn=_dit_loss,
        cfg=cfg,
        checkpoint_root=tmp / "ck",
    )


def _train_dit(tmp: Path, mixed: str = "no", **fields: object) -> dict[str, torch.Tensor]:
    model = _trained_dit(tmp, mixed, **fields)
    return {k: v.detach().float().clone() for k, v in model.state_dict().items()}


# 3 AdamW steps at lr 1e-3 move a weight by up to 3e-3; kernels that round differently may differ
# by 1 % of that (Adam divides by the gradient's own scale, so tiny rounding is not tiny after it).
KERNEL_TOL = 3e-5


@pytest.mark.parametrize(
    ("fields", "tol"),
    [
        ({"compile": "eager"}, 0.0),  # the dynamo wiring; inductor code generation is the GPU test
        ({"attention": "math"}, KERNEL_TOL),
        ({"attention": "flash"}, KERNEL_TOL),  # PyTorch's CPU flash kernel, with the key-padding mask
        ({"fused_optimizer": True}, KERNEL_TOL),
    ],
)
def test_fast_paths_train_to_the_same_weights(
    tmp_path: Path, fields: dict, tol: float, monkeypatch: pytest.MonkeyPatch
) -> None:
    from momu.engine import trainer

    ref = _train_dit(tmp_path / "ref")
    used: dict[str, tuple] = {}  # what the trainer hands each fast path (equal weights alone would not
    # show that a fast path ran)

    def spy(name: str, real: Callable[..., Any]) -> Callable[..., Any]:
        def call(*args: Any) -> Any:
            used[name] = args
            return real(*args)

        return call

    for name in ("compile_backbones", "attention_kernels", "make_adamw"):
        monkeypatch.setattr(trainer, name, spy(name, getattr(trainer, name)))
    fast = _train_dit(tmp_path / "fast", **fields)
    assert used["compile_backbones"][1] == fields.get("compile", "none")
    assert used["attention_kernels"][0] == fields.get("attention", "auto")
    assert used["make_adamw"][1].fused_optimizer is fields.get("fused_optimizer", False)
    for name, value in ref.items():
        if name.endswith("to_k.bias"):  # its true gradient is 0 (softmax ignores a key bias): Adam
            continue  # turns the kernels' 1e-9 rounding of that 0 into lr-sized steps
        torch.testing.assert_close(fast[name], value, rtol=tol, atol=tol, msg=lambda m, n=name: f"{n}: {m}")


@pytest.fixture
def fresh_accelerate_state() -> Iterator[None]:
    """accelerate keeps one process-wide state; a test that changes mixed precision resets it."""
    from accelerate.state import AcceleratorState

    AcceleratorState._reset_state(reset_partial_state=True)
    yield
    AcceleratorState._reset_state(reset_partial_state=True)


@pytest.mark.usefixtures("fresh_accelerate_state")
def test_bf16_autocast_trains_on_cpu_close_to_fp32(tmp_path: Path) -> None:
    ref = _train_dit(tmp_path / "fp32")
    from accelerate.state import AcceleratorState

    AcceleratorState._reset_state(reset_partial_state=True)
    bf16 = _train_dit(tmp_path / "bf16", mixed="bf16")
    for name, value in ref.items():
        if name.endswith("to_k.bias"):  # zero true gradient (see above)
            continue
        assert torch.isfinite(bf16[name]).all(), name
        torch.testing.assert_close(
            bf16[name], value, rtol=0.05, atol=2e-3, msg=lambda m, n=name: f"{n}: {m}"
        )  # 3 steps at lr 1e-3


@pytest.mark.usefixtures("fresh_accelerate_state")
def test_a_stage_trained_under_bf16_autocast_evaluates_like_one_reloaded_from_disk(tmp_path: Path) -> None:
    # Mixed precision is a training setting: the returned module has its plain forward back, so a
    # table samples a stage it just trained exactly as it samples the same stage reused from disk.
    trained = _trained_dit(tmp_path, mixed="bf16")
    reloaded = _tiny_dit().eval()
    reloaded.load_state_dict(trained.state_dict())
    x, t, c = torch.randn(2, 8, 4), torch.tensor([3, 7]), torch.randn(2, 6, 4)
    out = trained(x, t, c)
    assert out.dtype == torch.float32
    torch.testing.assert_close(out, reloaded(x, t, c), rtol=0.0, atol=0.0)


def test_attention_runs_in_fp32_under_a_cpu_bf16_autocast(monkeypatch: pytest.MonkeyPatch) -> None:
    # PyTorch's bf16 CPU flash-attention backward is several times slower than fp32 (momu.attention).
    seen: list[torch.dtype] = []
    sdpa = F.scaled_dot_product_attention

    def spy(q, k, v, **kw):  # type: ignore[no-untyped-def]
        seen.append(q.dtype)
        return sdpa(q, k, v, **kw)

    monkeypatch.setattr(F, "scaled_dot_product_attention", spy)
    model = _tiny_dit().train()
    x, t, c = torch.randn(2, 8, 4), torch.tensor([3, 7]), torch.randn(2, 6, 4)
    with torch.autocast("cpu", dtype=torch.bfloat16):
        out = model(x, t, c)
    out.float().square().mean().backward()
    assert seen and set(seen) == {torch.float32}
    grads = {n: p.grad for n, p in model.named_parameters() if "to_q" in n}
    assert grads and all(
        g is not None and torch.isfinite(g).all() and g.abs().sum() > 0 for g in grads.values()
    )
    seen.clear()
    model(x, t, c)  # without autocast nothing is cast
    assert set(seen) == {torch.float32}


def test_compile_backbones_compiles_in_place_and_keeps_state_dict_keys() -> None:
    holder = nn.ModuleDict({"head": nn.Linear(2, 2), "dit": _tiny_dit()})
    keys = list(holder.state_dict())
    assert compile_backbones(holder, "eager") == ["dit"]
    assert list(holder.state_dict()) == keys and compile_backbones(nn.Linear(2, 2), "none") == []


def test_dense_dit_call_passes_no_attention_mask(monkeypatch: pytest.MonkeyPatch) -> None:
    seen: list[object] = []
    sdpa = F.scaled_dot_product_attention

    def spy(q, k, v, attn_mask=None, **kw):  # type: ignore[no-untyped-def]
        seen.append(attn_mask)
        return sdpa(q, k, v, attn_mask=attn_mask, **kw)

    monkeypatch.setattr(F, "scaled_dot_product_attention", spy)
    model = _tiny_dit().eval()
    x, t, c = torch.randn(2, 8, 4), torch.tensor([3, 7]), torch.randn(2, 6, 4)
    dense = model(x, t, c)
    masked = model(x, t, c, x_mask=torch.ones(2, 8, dtype=torch.bool))
    assert seen[0] is None and isinstance(seen[1], torch.Tensor) and seen[1].shape == (2, 1, 1, 15)
    torch.testing.assert_close(dense, masked, rtol=1e-6, atol=1e-6)


def _count_reads(monkeypatch: pytest.MonkeyPatch) -> dict[str, int]:
    """Count host reads of tensor values (``item``, ``float``, ``int``, ``bool``, ``tolist``).

    Reads from inside ``torch.optim`` are not counted: AdamW's step counters are host tensors
    (unless fused or capturable), so reading them never waits for a GPU.
    """
    counts = {"n": 0}
    for attr in ("item", "__float__", "__int__", "__bool__", "tolist"):
        original = getattr(torch.Tensor, attr)

        def counted(self, *a, _orig=original, **kw):  # type: ignore[no-untyped-def]
            caller = sys._getframe(1).f_code.co_filename.replace(os.sep, "/")
            counts["n"] += "torch/optim/" not in caller
            return _orig(self, *a, **kw)

        monkeypatch.setattr(torch.Tensor, attr, counted)
    return counts


def test_training_steps_between_log_steps_read_nothing_back(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    acc = make_accelerator(RunConfig(tracker="none"), tmp_path, "t", {})
    reads = []
    for steps in (2, 6):
        cfg = TrainConfig(steps=steps, batch_size=4, log_every=1000, checkpoint_minutes=0, lr=1e-2)
        with monkeypatch.context() as m:
            counts = _count_reads(m)
            train_stage(
                acc,
                name=f"s{steps}",
                model=nn.Linear(3, 1),
                dataset=_toy(),
                loss_fn=_mse,
                cfg=cfg,
                checkpoint_root=tmp_path / str(steps),
            )
        reads.append(counts["n"])
    assert reads[0] == reads[1] > 0  # four more steps, no more reads: they happen at the log step


def test_non_finite_loss_still_fails_naming_the_first_bad_step(tmp_path: Path) -> None:
    calls = {"n": 0}

    def loss_fn(model: nn.Module, batch: list[torch.Tensor]) -> torch.Tensor:
        calls["n"] += 1
        loss = _mse(model, batch)
        return loss * float("nan") if calls["n"] == 3 else loss

    acc = make_accelerator(RunConfig(tracker="none"), tmp_path, "t", {})
    cfg = TrainConfig(steps=6, batch_size=4, log_every=5, checkpoint_minutes=0)
    with pytest.raises(FloatingPointError, match=r"loss is nan at step 2"):
        train_stage(
            acc,
            name="s",
            model=nn.Linear(3, 1),
            dataset=_toy(),
            loss_fn=loss_fn,
            cfg=cfg,
            checkpoint_root=tmp_path / "ck",
        )
    assert not (tmp_path / "ck").exists()  # nothing saved from NaN weights


@pytest.mark.gpu
@pytest.mark.usefixtures("fresh_accelerate_state")
def test_gpu_fast_paths_together_match_fp32_eager(tmp_path: Path) -> None:
    from accelerate.state import AcceleratorState

    ref = _train_dit(tmp_path / "ref")
    AcceleratorState._reset_state(reset_partial_state=True)
    fast = _train_dit(
        tmp_path / "fast", mixed="bf16", compile="inductor", fused_optimizer=True, attention="auto"
    )
    for name, value in ref.items():
        if not name.endswith("to_k.bias"):  # zero true gradient (see above)
            torch.testing.assert_close(
                fast[name], value, rtol=0.05, atol=2e-3, msg=lambda m, n=name: f"{n}: {m}"
            )


@pytest.mark.gpu
def test_gpu_dense_dit_runs_on_the_flash_kernel() -> None:
    model = _tiny_dit().cuda().to(torch.bfloat16)
    x = torch.randn(2, 8, 4, device="cuda", dtype=torch.bfloat16)
    c = torch.randn(2, 6, 4, device="cuda", dtype=torch.bfloat16)
    from torch.nn.attention import SDPBackend, sdpa_kernel

    with sdpa_kernel([SDPBackend.FLASH_ATTENTION]):  # raises if the call needed another kernel
        model(x, torch.tensor([3, 7], device="cuda"), c)
    with sdpa_kernel([SDPBackend.EFFICIENT_ATTENTION]):  # the key-padding mask: memory-efficient
        model(
            x,
            torch.tensor([3, 7], device="cuda"),
            c,
            x_mask=torch.ones(2, 8, dtype=torch.bool, device="cuda"),
        )


@pytest.mark.gpu
def test_gpu_training_step_does_not_synchronise(tmp_path: Path) -> None:
    cfg = TrainConfig(steps=4, batch_size=4, log_every=1000, checkpoint_minutes=0)
    acc = make_accelerator(RunConfig(tracker="none"), tmp_path, "t", {})
    model = nn.Linear(3, 1)
    train_stage(
        acc, name="warm", model=model, dataset=_toy(), loss_fn=_mse, cfg=cfg, checkpoint_root=tmp_path / "a"
    )
    calls = {"n": 0}

    def watched(model: nn.Module, batch: list[torch.Tensor]) -> torch.Tensor:
        calls["n"] += 1
        if calls["n"] == 2:  # from the second step on, any synchronising call raises
            torch.cuda.set_sync_debug_mode("error")
        return _mse(model, batch)

    try:
        with pytest.raises(RuntimeError, match="synchroniz"):  # the first read is the final log step
            train_stage(
                acc,
                name="s",
                model=model,
                dataset=_toy(),
                loss_fn=watched,
                cfg=dataclasses.replace(cfg, steps=3),
                checkpoint_root=tmp_path / "b",
            )
        assert calls["n"] == 3  # every step ran without a sync; the one at the log step raised
    finally:
        torch.cuda.set_sync_debug_mode("default")
