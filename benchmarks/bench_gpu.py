"""Training throughput, memory, FLOP utilisation and generation latency of the paper-size models.

Models (random weights: cost does not depend on them), from the ``paper`` configs:

* ``momu_dit`` — θ_a and θ_m of MoMu-Diffusion (Table 9 DiT, both trained in one step by
  :class:`~momu.methods.momu.stages.DiffusionStage`, batch 16, 25 s windows of aligned latents);
* ``bicor_vae`` — the music VAE of the BiCoR-VAE (Table 8; L1 + KL, batch 16, 25 s of mel);
* ``mofusion_unet`` — MoFusion's U-Net (supp. B; ε-prediction with the music condition, batch 32,
  20 s at 20 fps).

For each it measures training steps/s, tokens (latent or pose frames) per second, peak memory
(CUDA: ``max_memory_allocated``; CPU: the process's peak RSS), and model FLOP utilisation: FLOPs of
a step counted by ``torch.utils.flop_counter`` divided by the step time, against the device's
data-sheet bf16 peak (``mfu_nominal``, GPUs it knows) and against a dense matmul in the run's dtype
measured in the same process (``mfu_matmul``). For the two denoisers it times 50-step DDIM
generation of a 30 s clip with classifier-free guidance batched (one forward of 2B per step) at
batch 1 and 32.

Fast paths are the training engine's own (:mod:`momu.engine.fast_paths`): ``--compile BACKEND``,
``--fused``, ``--attention KERNEL``; ``--dtype bf16`` runs under ``torch.autocast`` as accelerate's
``mixed_precision=bf16`` does.

    python benchmarks/bench_gpu.py --out results/gpu.json            # on a CUDA machine
    python benchmarks/bench_gpu.py --tiny --out results/gpu_cpu.json  # anywhere (the default on CPU)

``--tiny`` uses the ``cpu``-preset model sizes, short clips, small batches and few DDIM steps, so
it runs in about a minute on a 2-core CPU; its numbers say nothing about a GPU.
"""

from __future__ import annotations

import argparse
import json
import resource
import sys
import time
from collections.abc import Callable
from contextlib import AbstractContextManager, nullcontext
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import torch
import torch.nn.functional as F
from bench_mofusion_generation import backbone_node as unet_node  # benchmarks/
from perf_common import counted_flops, matmul_peak, nominal_peak, sync, time_train_steps

from momu.config import build_component
from momu.engine.fast_paths import attention_kernels, compile_backbones, make_adamw
from momu.engine.table import parse_table_args, resolve_row_configs
from momu.engine.trainer import TrainConfig
from momu.methods.momu.config import backbone_node
from momu.methods.momu.recipes import table7_spec
from momu.methods.momu.stages import DiffusionStage

ROOT = Path(__file__).resolve().parents[1]
MEL_RATE = 16000 / 256  # MoMu mel frames per second (App. B.2)


@dataclass
class Sizes:
    """What ``--tiny`` shrinks: clip lengths, batches, DDIM steps, repeats."""

    train_seconds_momu: float = 25.0
    train_seconds_mofusion: float = 20.0
    batch_momu: int = 16
    batch_mofusion: int = 32
    gen_seconds: float = 30.0
    gen_batches: tuple[int, ...] = (1, 32)
    ddim_steps: int = 50
    repeats: int = 10
    matmul_n: int = 8192


TINY = Sizes(2.0, 2.0, 2, 2, 2.0, (1, 32), 5, 2, 256)


def peak_memory_mib(device: torch.device) -> float:
    if device.type == "cuda":
        return torch.cuda.max_memory_allocated(device) / 2**20
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def momu_config(tiny: bool) -> Any:
    """The MoMu method config of Table 7 row #7 at the ``cpu`` (tiny) or ``paper`` preset."""
    spec = table7_spec()
    preset = "cpu" if tiny else "paper"
    rows = resolve_row_configs(spec, parse_table_args(spec, ["--preset", preset, "--rows", "#7"]))
    return rows["#7"].method


def measure_training(
    name: str,
    module: torch.nn.Module,
    step: Callable[[], torch.Tensor],
    tokens: int,
    args: argparse.Namespace,
    sizes: Sizes,
    autocast: Callable[[], AbstractContextManager[Any]],
    peak: dict[str, float | None],
) -> dict[str, Any]:
    """Steps/s, tokens/s, peak memory and MFU of ``step`` (the loss of one batch) for ``module``."""
    device = args.device
    compile_backbones(module, args.compile)
    params = [p for p in module.parameters() if p.requires_grad]
    opt = make_adamw(params, TrainConfig(lr=1e-4, fused_optimizer=args.fused))

    def amp_step() -> torch.Tensor:
        with autocast():
            return step()

    if device.type == "cuda":
        torch.cuda.reset_peak_memory_stats(device)
    flops = counted_flops(amp_step)  # eager count (FlopCounterMode does not see inside compiled graphs)
    opt.zero_grad(set_to_none=True)
    clock = time.perf_counter if device.type == "cuda" else time.process_time
    with attention_kernels(args.attention):
        seconds = time_train_steps(amp_step, opt, sizes.repeats, warmup=3, device=device, clock=clock)
    achieved = flops / seconds
    return {
        "model": name,
        "params_M": round(sum(p.numel() for p in params) / 1e6, 2),
        "tokens_per_step": tokens,
        "steps_per_s": round(1.0 / seconds, 3),
        "tokens_per_s": round(tokens / seconds, 1),
        "step_ms": round(1e3 * seconds, 2),
        "gflop_per_step": round(flops / 1e9, 2),
        "achieved_tflop_s": round(achieved / 1e12, 4),
        "mfu_nominal": None if peak["nominal"] is None else round(achieved / peak["nominal"], 4),
        "mfu_matmul": round(achieved / float(peak["matmul"] or 1.0), 4),
        "peak_memory_mib": round(peak_memory_mib(device), 1),
    }


def measure_generation(
    name: str,
    backbone: torch.nn.Module,
    frames: int,
    channels: int,
    cond_shape: tuple[int, int],
    args: argparse.Namespace,
    sizes: Sizes,
    autocast: Callable[[], AbstractContextManager[Any]],
) -> list[dict[str, Any]]:
    """Latency of DDIM generation with batched CFG (the library's ``cfg`` sampler) per batch size."""
    from momu.registry import SAMPLERS

    sampler = SAMPLERS.build("cfg", {"guidance_scale": 3.0, "scheduler": {"name": "ddim"}})
    backbone.eval()
    out = []
    for batch in sizes.gen_batches:
        cond = torch.randn(batch, *cond_shape, device=args.device)

        def run(b: int = batch, c: torch.Tensor = cond) -> None:
            with autocast(), attention_kernels(args.attention):
                sampler.sample(
                    backbone,
                    (b, frames, channels),
                    c,
                    generator=torch.Generator(args.device).manual_seed(0),
                    num_inference_steps=sizes.ddim_steps,
                )
            sync(args.device)

        run()  # warm-up (compilation, kernel choice)
        if args.device.type == "cuda":
            torch.cuda.reset_peak_memory_stats(args.device)
        t0 = time.perf_counter()
        run()
        latency = time.perf_counter() - t0
        out.append(
            {
                "model": name,
                "batch": batch,
                "clip_seconds": sizes.gen_seconds,
                "frames": frames,
                "ddim_steps": sizes.ddim_steps,
                "cfg_forward_batch": 2 * batch,
                "latency_s": round(latency, 3),
                "ms_per_step": round(1e3 * latency / sizes.ddim_steps, 2),
                "peak_memory_mib": round(peak_memory_mib(args.device), 1),
            }
        )
    return out


def momu_parts(args: argparse.Namespace) -> tuple[Any, Any, DiffusionStage, int, float]:
    """MoMu's method config, BiCoR-VAE, diffusion stage, latent width and latent frames per second."""
    m = momu_config(args.tiny)
    d = int(m.encoder.motion.latent_channels)
    vae = build_component(m.encoder, "encoders").to(args.device)
    with torch.no_grad():  # the latent rate of this encoder: encode 4 s of mel
        probe = vae.encode_music(torch.zeros(1, 80, int(round(MEL_RATE * 4.0)), device=args.device))
    stage = DiffusionStage(
        build_component(backbone_node(m.music_backbone, d), "backbones"),
        build_component(backbone_node(m.motion_backbone, d), "backbones"),
        build_component(m.diffusion_loss, "losses", scheduler=build_component(m.scheduler, "schedulers")),
        d,
        min_frames=None,
    ).to(args.device)
    return m, vae, stage, d, probe.shape[1] / 4.0


def run(args: argparse.Namespace) -> dict[str, Any]:
    sizes = TINY if args.tiny else Sizes()
    device = args.device
    dtype = torch.bfloat16 if args.dtype == "bf16" else torch.float32

    def autocast() -> AbstractContextManager[Any]:
        return torch.autocast(device.type, dtype=torch.bfloat16) if args.dtype == "bf16" else nullcontext()

    torch.manual_seed(0)
    clock = time.perf_counter if device.type == "cuda" else time.process_time
    peak = {
        "matmul": matmul_peak(sizes.matmul_n, 2.0, device=device, dtype=dtype, clock=clock),
        "nominal": nominal_peak(device),
    }
    m, vae, stage, d, latent_rate = momu_parts(args)
    train, gen = [], []

    frames = int(sizes.train_seconds_momu * latent_rate)
    b = sizes.batch_momu
    data = {
        "z_music": torch.randn(b, frames, d, device=device),
        "z_motion": torch.randn(b, frames, d, device=device),
    }
    train.append(
        measure_training(
            "momu_dit",
            stage.train(),
            lambda: stage(data)[0],
            2 * b * (2 * frames + 1),
            args,
            sizes,
            autocast,
            peak,
        )
    )
    mel = torch.randn(b, 80, int(sizes.train_seconds_momu * MEL_RATE), device=device)
    vae_loss = build_component(m.vae_loss, "losses")
    music_vae = vae.music_vae.train()

    def vae_step() -> torch.Tensor:
        out = music_vae(mel)
        return vae_loss(out.reconstruction, out.target, out.posterior)["loss"]

    train.append(
        measure_training("bicor_vae", music_vae, vae_step, b * mel.shape[-1], args, sizes, autocast, peak)
    )

    unet = build_component(unet_node("cpu" if args.tiny else "paper"), "backbones").to(device).train()
    fps = 20.0  # MoFusion §4.4
    pose_frames = int(sizes.train_seconds_mofusion * fps)
    bu = sizes.batch_mofusion
    x0 = torch.randn(bu, pose_frames, 72, device=device)
    cond = torch.randn(bu, pose_frames, 80, device=device)  # mel resampled to the pose frame rate

    def unet_step() -> torch.Tensor:
        t = torch.randint(0, 1000, (bu,), device=device)
        noise = torch.randn_like(x0)
        return F.mse_loss(unet(x0 + noise, t, cond), noise)  # cost of an ε-prediction step

    train.append(
        measure_training("mofusion_unet", unet, unet_step, bu * pose_frames, args, sizes, autocast, peak)
    )

    gen_frames = int(sizes.gen_seconds * latent_rate)
    gen += measure_generation(
        "momu_dit", stage.motion_backbone, gen_frames, d, (gen_frames, d), args, sizes, autocast
    )
    unet_frames = int(sizes.gen_seconds * fps)
    gen += measure_generation(
        "mofusion_unet", unet, unet_frames, 72, (unet_frames, 80), args, sizes, autocast
    )
    return {
        "label": f"{device.type.upper()}{' (tiny sizes)' if args.tiny else ''}",
        "device": torch.cuda.get_device_name(device) if device.type == "cuda" else "cpu",
        "torch": torch.__version__,
        "dtype": args.dtype,
        "threads": torch.get_num_threads(),
        "tiny": args.tiny,
        "fast_paths": {"compile": args.compile, "fused_optimizer": args.fused, "attention": args.attention},
        "matmul_peak_tflop_s": round(peak["matmul"] / 1e12, 4),
        "nominal_peak_tflop_s": None if peak["nominal"] is None else peak["nominal"] / 1e12,
        "training": train,
        "generation": gen,
    }


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--out", type=Path, required=True, help="JSON file to write")
    p.add_argument("--tiny", action="store_true", default=None, help="tiny sizes (default without CUDA)")
    p.add_argument("--full", dest="tiny", action="store_false", help="paper sizes even on CPU")
    p.add_argument("--device", default=None, help="torch device (default: cuda if available, else cpu)")
    p.add_argument(
        "--dtype", choices=["bf16", "fp32"], default=None, help="default: bf16 on CUDA, fp32 on CPU"
    )
    p.add_argument("--compile", default="none", help="torch.compile backend of the backbones (train.compile)")
    p.add_argument("--fused", action="store_true", help="fused AdamW (train.fused_optimizer)")
    p.add_argument("--attention", default="auto", help="SDPA kernels (train.attention)")
    args = p.parse_args(argv)
    args.device = torch.device(args.device or ("cuda" if torch.cuda.is_available() else "cpu"))
    if args.tiny is None:
        args.tiny = args.device.type != "cuda"
    args.dtype = args.dtype or ("bf16" if args.device.type == "cuda" else "fp32")
    from momu.engine.fast_paths import validate_fast_paths

    validate_fast_paths(
        TrainConfig(compile=args.compile, attention=args.attention, fused_optimizer=args.fused)
    )
    result = run(args)
    args.out.parent.mkdir(parents=True, exist_ok=True)
    args.out.write_text(json.dumps(result, indent=2) + "\n")
    sys.stdout.write(json.dumps(result, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
