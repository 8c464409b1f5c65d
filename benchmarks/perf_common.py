"""Shared measurement helpers of the performance benchmarks (bench_momu_training_flops, bench_gpu).

* :func:`matmul_peak` — dense ``n × n`` matmul FLOP/s measured in the running process (the
  achievable ceiling the achieved FLOP/s are compared with);
* :func:`counted_flops` — FLOPs of one training step (forward + backward) counted by
  :class:`torch.utils.flop_counter.FlopCounterMode` (matmuls, convolutions, attention: the
  analytic count of the model's dense arithmetic, independent of the kernels that run it);
* :func:`time_train_steps` — mean seconds of a training step after warm-up, with a CUDA
  synchronisation around the timed block so queued kernels are counted;
* :func:`nominal_peak` — the vendor's dense bf16 peak of a known GPU (``None`` elsewhere).

Clocks: CPU benchmarks on a shared machine use ``time.process_time`` (this process's CPU time);
GPU benchmarks use ``time.perf_counter`` (wall time; the host only launches work).
"""

from __future__ import annotations

import time
from collections.abc import Callable

import torch
from torch.utils.flop_counter import FlopCounterMode

__all__ = ["matmul_peak", "counted_flops", "time_train_steps", "step_flops_and_time", "nominal_peak", "sync"]

Clock = Callable[[], float]

# Dense (non-sparse) bf16 tensor-core peaks from the vendors' data sheets, FLOP/s.
_NOMINAL_BF16 = {
    "H200": 989e12,
    "H100 SXM": 989e12,
    "H100 PCIe": 756e12,
    "H100": 989e12,
    "A100": 312e12,
    "L40S": 362e12,
    "L4": 121e12,
    "A10G": 70e12,
    "RTX 4090": 165e12,
}


def sync(device: torch.device) -> None:
    """Wait for the queued kernels of ``device`` (no-op on CPU)."""
    if device.type == "cuda":
        torch.cuda.synchronize(device)


def nominal_peak(device: torch.device) -> float | None:
    """The data-sheet dense bf16 peak of ``device`` if it is a GPU this table knows, else ``None``."""
    if device.type != "cuda":
        return None
    name = torch.cuda.get_device_name(device)
    for key, peak in _NOMINAL_BF16.items():  # most specific names first
        if key in name:
            return peak
    return None


def matmul_peak(
    n: int = 512,
    seconds: float = 2.0,
    *,
    device: torch.device | str = "cpu",
    dtype: torch.dtype = torch.float32,
    clock: Clock = time.process_time,
) -> float:
    """Dense ``n × n`` matmul FLOP/s (best of bursts of 10) on ``device`` in ``dtype``."""
    dev = torch.device(device)
    a, b = torch.randn(n, n, device=dev, dtype=dtype), torch.randn(n, n, device=dev, dtype=dtype)
    a @ b  # warm-up (kernel selection, allocator)
    sync(dev)
    best = 0.0
    end = time.perf_counter() + seconds
    while time.perf_counter() < end:
        t0 = clock()
        for _ in range(10):
            a @ b
        sync(dev)
        dt = max(clock() - t0, 1e-9)
        best = max(best, 10 * 2 * n**3 / dt)
    return best


def counted_flops(step: Callable[[], torch.Tensor]) -> float:
    """FLOPs of ``step().backward()`` counted by ``FlopCounterMode`` (gradients are left in place)."""
    with FlopCounterMode(display=False) as counter:
        step().backward()
    return float(counter.get_total_flops())


def time_train_steps(
    step: Callable[[], torch.Tensor],
    optimizer: torch.optim.Optimizer,
    repeats: int = 10,
    *,
    warmup: int = 2,
    device: torch.device | str = "cpu",
    clock: Clock = time.process_time,
) -> float:
    """Mean seconds of one training step (``step().backward()``, optimizer step, zero grads)."""
    dev = torch.device(device)

    def one() -> None:
        step().backward()
        optimizer.step()
        optimizer.zero_grad(set_to_none=True)

    for _ in range(warmup):
        one()
    sync(dev)
    t0 = clock()
    for _ in range(repeats):
        one()
    sync(dev)
    return (clock() - t0) / repeats


def step_flops_and_time(
    module: torch.nn.Module, step: Callable[[], torch.Tensor], repeats: int = 10
) -> tuple[float, float]:
    """FLOPs of one ``step()`` (forward + backward) and its mean CPU seconds under a plain AdamW."""
    params = [p for p in module.parameters() if p.requires_grad]
    opt = torch.optim.AdamW(params, lr=1e-4)
    for _ in range(2):
        step().backward()
        opt.step()
        opt.zero_grad()
    flops = counted_flops(step)
    opt.zero_grad()
    return flops, time_train_steps(step, opt, repeats, warmup=0)
