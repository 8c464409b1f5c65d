"""Every trainable parameter of a stage receives a gradient each step (zeros where a step did not use it).

Why a stage wants this: under DistributedDataParallel every parameter must receive a gradient each
step, and AdamW treats a parameter with no gradient differently from one with a zero gradient (it
skips the first; it decays the second's weights and moments). A backbone's learned null condition
is unused in a batch where no condition was dropped, and a plugin part may have parameters a step
does not use, so a stage whose step leaves some parameters out would train differently on one
process and on several.

:func:`with_every_parameter` gives the same gradients both ways:

* on several processes it returns ``loss + 0 · Σ params``, so DDP sees every parameter in the graph;
* on one process it returns ``loss`` itself and, at the end of the backward pass, gives each
  trainable parameter left without a gradient a zero one.

The two are bit for bit the same update: ``x + 0`` is ``x`` for every finite gradient element (up to
the sign of a zero, which neither gradient clipping nor AdamW's moments can see), and the unused
parameters get exact zeros either way. The single-process form skips one ``sum`` per parameter in
the forward pass and one gradient addition per parameter in the backward pass: about 0.96× the
step time of row #4's 1D U-Net (434 parameter tensors) and 0.97–0.98× of the DiT rows at the cpu
preset (``benchmarks/bench_momu_training_flops.py --every-parameter --pairs 150``,
docs/performance.md).
"""

from __future__ import annotations

import torch
from torch import nn

__all__ = ["with_every_parameter"]


def _several_processes() -> bool:
    dist = torch.distributed
    return bool(dist.is_available() and dist.is_initialized() and dist.get_world_size() > 1)


def with_every_parameter(module: nn.Module, loss: torch.Tensor) -> torch.Tensor:
    """``loss``, with every trainable parameter of ``module`` given a gradient by its backward pass.

    Call it on a stage's total loss; ``loss.backward()`` then leaves a gradient (zeros where unused)
    on every parameter of ``module`` that requires one.
    """
    params = [p for p in module.parameters() if p.requires_grad]
    if not params:
        return loss
    if _several_processes() or not loss.requires_grad:
        return loss + 0.0 * torch.stack([p.sum() for p in params]).sum()

    def fill_unused() -> None:
        for p in params:
            if p.grad is None:
                p.grad = torch.zeros_like(p)

    def at_backward_start(grad: torch.Tensor) -> torch.Tensor:
        # runs once the backward pass reaches the loss; the callback runs when the pass ends
        torch.autograd.Variable._execution_engine.queue_callback(fill_unused)  # type: ignore[attr-defined]
        return grad

    loss = loss.view_as(loss)  # a fresh node, so the hook belongs to this call only
    loss.register_hook(at_backward_start)
    return loss
