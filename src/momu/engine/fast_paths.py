"""The training fast paths of :class:`~momu.engine.trainer.TrainConfig` (docs/performance.md).

Each is one config field, off (or at PyTorch's own choice) by default, and each is tested on CPU
not to change the numbers beyond a tolerance:

* ``train.attention`` — which :func:`torch.nn.functional.scaled_dot_product_attention` kernels may
  run (``auto``: PyTorch picks flash / memory-efficient / cuDNN / math; ``math`` forces the
  reference kernel; ``flash``, ``efficient``, ``cudnn`` allow only that one, so a run fails loudly
  instead of silently falling back to ``math``). :func:`attention_kernels` is the context manager.
* ``train.compile`` — ``none``, or a :func:`torch.compile` backend (``inductor`` on a GPU;
  ``eager`` / ``aot_eager`` check the wiring without code generation). :func:`compile_backbones`
  compiles every denoising backbone inside a stage module *in place* (``nn.Module.compile``), so
  parameter names, ``state_dict`` keys and checkpoints are unchanged.
* ``train.fused_optimizer`` — AdamW with ``fused=True`` where the device has fused kernels for
  every parameter's dtype, otherwise the default (foreach) implementation; :func:`make_adamw`.
* ``train.pin_memory`` / ``train.persistent_workers`` — :func:`loader_options`: page-locked batches
  only when the run is on CUDA (pinning does nothing useful for a CPU run), workers kept alive
  across epochs only when there are workers.

:class:`StepMeter` keeps the training loop free of host-device synchronisation between logging
steps (always on; it changes no number).

Which of them are part of a stage's key is decided in :mod:`momu.engine.trainer`
(``WEIGHT_NEUTRAL_FIELDS``, ``KEYED_WHEN_SET``).
"""

from __future__ import annotations

import logging
from collections.abc import Iterable, Iterator, Mapping
from contextlib import contextmanager
from typing import TYPE_CHECKING, Any

import torch
from torch import nn

if TYPE_CHECKING:
    from momu.engine.trainer import TrainConfig

__all__ = [
    "ATTENTION_KERNELS",
    "attention_kernels",
    "compile_backends",
    "compile_backbones",
    "make_adamw",
    "fused_supported",
    "loader_options",
    "validate_fast_paths",
    "StepMeter",
]

log = logging.getLogger(__name__)

ATTENTION_KERNELS = ("auto", "math", "flash", "efficient", "cudnn")
"""Values of ``train.attention``."""


def compile_backends() -> tuple[str, ...]:
    """Values of ``train.compile``: ``none`` and every :mod:`torch._dynamo` backend of this install."""
    import torch._dynamo

    return ("none", *sorted(torch._dynamo.list_backends(exclude_tags=())))


def validate_fast_paths(cfg: TrainConfig) -> None:
    """Raise ``ValueError`` naming the key of a bad fast-path setting."""
    if cfg.attention not in ATTENTION_KERNELS:
        raise ValueError(f"train.attention: expected one of {ATTENTION_KERNELS}, got {cfg.attention!r}")
    if cfg.compile != "none":
        backends = compile_backends()
        if cfg.compile not in backends:
            raise ValueError(f"train.compile: expected one of {backends}, got {cfg.compile!r}")
    for key in ("fused_optimizer", "pin_memory", "persistent_workers"):
        if not isinstance(getattr(cfg, key), bool):
            raise ValueError(f"train.{key}: expected true or false, got {getattr(cfg, key)!r}")
    if not isinstance(cfg.num_workers, int) or cfg.num_workers < 0:
        raise ValueError(f"train.num_workers: expected an integer >= 0, got {cfg.num_workers!r}")


@contextmanager
def attention_kernels(name: str) -> Iterator[None]:
    """Allow only the scaled-dot-product-attention kernels ``name`` selects (``auto``: all)."""
    from torch.nn.attention import SDPBackend, sdpa_kernel

    choice = {
        "math": [SDPBackend.MATH],
        "flash": [SDPBackend.FLASH_ATTENTION],
        "efficient": [SDPBackend.EFFICIENT_ATTENTION],
        "cudnn": [SDPBackend.CUDNN_ATTENTION],
    }
    if name == "auto":
        yield
        return
    if name not in choice:
        raise ValueError(f"train.attention: expected one of {ATTENTION_KERNELS}, got {name!r}")
    with sdpa_kernel(choice[name]):
        yield


def _backbone_types() -> tuple[type[nn.Module], ...]:
    from momu.backbones.dit import DiT
    from momu.backbones.unet1d import UNet1D

    return (DiT, UNet1D)


def compile_backbones(model: nn.Module, backend: str) -> list[str]:
    """Compile, in place, every built-in denoising backbone (DiT, U-Net) inside ``model``.

    A model holding no built-in backbone (a VAE stage, a plugin's module) is compiled as a whole,
    also in place. ``dynamic=None`` lets dynamo mark a dimension dynamic after it has changed once
    (variable-length windows), instead of recompiling for every length. Returns the names of the
    compiled modules (``""`` for ``model`` itself).
    """
    if backend == "none":
        return []
    found = [(n, m) for n, m in model.named_modules() if isinstance(m, _backbone_types())]
    targets = found or [("", model)]
    for _, module in targets:
        module.compile(backend=backend)
    names = [n for n, _ in targets]
    log.info("torch.compile (backend %s): %s", backend, ", ".join(n or "<stage>" for n in names))
    return names


def fused_supported(params: Iterable[torch.Tensor]) -> bool:
    """Whether ``torch.optim.AdamW(fused=True)`` accepts every parameter (device and dtype)."""
    from torch.optim.optimizer import _get_fused_kernels_supported_devices

    devices = set(_get_fused_kernels_supported_devices())
    floats = (torch.float64, torch.float32, torch.float16, torch.bfloat16)
    return all(p.device.type in devices and p.dtype in floats for p in params)


def make_adamw(params: list[nn.Parameter], cfg: TrainConfig) -> torch.optim.AdamW:
    """The stage's AdamW; fused kernels when ``cfg.fused_optimizer`` and the device has them."""
    kwargs: dict[str, Any] = {"lr": cfg.lr, "betas": (cfg.beta1, cfg.beta2), "weight_decay": cfg.weight_decay}
    if cfg.fused_optimizer:
        if fused_supported(params):
            kwargs["fused"] = True
        else:
            log.warning("train.fused_optimizer: no fused AdamW for these parameters; using the default")
    return torch.optim.AdamW(params, **kwargs)


def loader_options(cfg: TrainConfig, device: torch.device) -> dict[str, Any]:
    """DataLoader keyword arguments of the loading fast paths for a run on ``device``."""
    workers = cfg.num_workers
    return {
        "num_workers": workers,
        "pin_memory": bool(cfg.pin_memory and device.type == "cuda"),
        "persistent_workers": bool(cfg.persistent_workers and workers > 0),
    }


class StepMeter:
    """Running sums of the logged values and the first non-finite loss, kept on the device.

    Nothing here reads a tensor back to the host except :meth:`check` and :meth:`take`, which the
    loop calls at logging and checkpoint steps only: a training step on a GPU launches its kernels
    without waiting for the previous step (docs/performance.md, "no host-device syncs").
    """

    def __init__(self) -> None:
        self.sums: dict[str, torch.Tensor | float] = {}
        self.bad: tuple[torch.Tensor, torch.Tensor] | None = None  # (first bad step or -1, its loss)

    def watch(self, loss: torch.Tensor, step: int) -> None:
        """Remember ``step`` if ``loss`` is the first non-finite loss (no sync)."""
        value = loss.detach().float()
        if self.bad is None:
            self.bad = (torch.full((), -1, dtype=torch.long, device=value.device), value.clone())
        first, _ = self.bad
        new = ~torch.isfinite(value) & (first < 0)
        self.bad = (torch.where(new, step, first), torch.where(new, value, self.bad[1]))

    def check(self, name: str) -> None:
        """Raise ``FloatingPointError`` if a loss since the stage's start was NaN or infinite."""
        if self.bad is not None and int(self.bad[0]) >= 0:
            raise FloatingPointError(
                f"stage {name!r}: loss is {float(self.bad[1])} at step {int(self.bad[0])}"
            )

    def add(self, logs: Mapping[str, float | torch.Tensor]) -> None:
        for key, value in logs.items():
            v = value.detach().float() if isinstance(value, torch.Tensor) else float(value)
            self.sums[key] = self.sums.get(key, 0.0) + v

    def take(self) -> dict[str, float]:
        """The sums as floats (one read-back), then reset."""
        out = {k: float(v) for k, v in self.sums.items()}
        self.sums = {}
        return out
