"""Achieved FLOP/s of the MoMu cpu-preset training steps against a matmul peak measured in the same run.

The machines are shared, so absolute seconds mean little: this script measures, in one process
and one thread, (1) the dense fp32 matmul throughput of this core (the ceiling), and (2) for each
trainable stage of the cpu preset (music VAE, motion VAE + RCL, θ_a + θ_m diffusion) the FLOPs of
one training step (forward + backward, counted by ``torch.utils.flop_counter``) divided by its
step time, and prints their ratio. It also prints the per-stage profile of a finished table run
when given its ``results.json`` (``provenance.timings``: wall and CPU seconds per category), and how
much of the jobs' wall time the CPU seconds fill (the rest is packing and waiting on shared stages).

With ``--bf16`` it also times every step under a CPU bf16 autocast (what ``mixed_precision: bf16``
trains with), in rounds that alternate with the fp32 steps so a shared machine slows both alike, and
prints the median bf16 / fp32 ratio of the step times with the bf16 matmul peak beside it.
With ``--fused`` it times the steps with ``AdamW(fused=True)`` (``train.fused_optimizer``) against
PyTorch's CPU default AdamW (the single-tensor loop) the same way, and with ``--foreach``
``AdamW(foreach=True)`` (bit for bit the single-tensor result on a CPU) against it, and with
``--every-parameter`` the several-process form of ``momu.engine.every_parameter`` (``loss + 0 · Σ
params``) against the one-process form a single process trains with (bit for bit the same). The
steps are the θ_a + θ_m diffusion step of row #7 (DiT) on the full window and as the table trains
it, the music VAE step, and row #4's 1D U-Net diffusion step as the table trains it.

    python benchmarks/bench_momu_training_flops.py [--bf16] [--fused] [--foreach] [--every-parameter] \\
        [--rounds N | --pairs N] \\
        [--results outputs/reproduce/momu_table7/results.json]

Measured 2026-12-03 on the 2-core machine (``--fused --rounds 21``): the fused step is 0.97× the
default on the full window, 0.94× as the table trains and 0.89× for the music VAE; AdamW's own step
goes from 6.1 ms (the default, single-tensor on a CPU; ``foreach=True`` 6.4) to 2.4 ms.
``--foreach --rounds 15`` (2026-12-03, a second 2-core machine): 0.98× on the full window, 1.00× as
the table trains, 0.97× for the music VAE and 1.00× for row #4's U-Net: no gain.
``--every-parameter --pairs 150`` (2026-12-03, a third 2-core machine): 0.99× on the full window,
0.98× as the table trains and 0.96× for row #4's U-Net; the music VAE step, which the option does
not touch, measured 0.99× (the noise of the method). ``--bf16 --pairs 100`` (2026-12-03, 2-core AMD
EPYC with AVX512-BF16, bf16 matmul peak 219 against 92 GFLOP/s fp32): 0.72× on the full window,
0.77× as the table trains, 0.97× for the music VAE and 1.18× for row #4's U-Net. ``--fused --pairs
100`` (2026-12-04, a 2-core machine with a 103.8 GFLOP/s fp32 peak): 0.96× on the full window, 0.95×
as the table trains, 0.92× for the music VAE and 0.90× for row #4's U-Net. With
``--results``: the committed Table 7 run's CPU seconds fill 84 % of its two jobs' wall time (one worker
waited 562 s for the extractors); after workers started the extractors early (commit 7c70883) a
complete from-scratch rerun at 297ec16, on a slower machine, filled 92 % (97 % counting the CPU
seconds outside ``provenance.timings`` that ``time`` reports).
"""

from __future__ import annotations

import argparse
import json
import statistics
from collections.abc import Callable
from pathlib import Path
from typing import Any

import torch
from perf_common import matmul_peak, step_flops_and_time, time_train_steps  # benchmarks/perf_common.py

from momu.config import build_component
from momu.engine import every_parameter
from momu.engine.table import parse_table_args, resolve_row_configs
from momu.methods.momu.config import backbone_node
from momu.methods.momu.recipes import table7_spec
from momu.methods.momu.stages import DiffusionStage


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--results", type=Path, default=None, help="a table's results.json (stage profile)")
    parser.add_argument("--bf16", action="store_true", help="also time each step under a CPU bf16 autocast")
    parser.add_argument("--fused", action="store_true", help="also time each step with AdamW(fused=True)")
    parser.add_argument("--foreach", action="store_true", help="also time each step with AdamW(foreach=True)")
    parser.add_argument(
        "--every-parameter",
        action="store_true",
        help="also time each step with loss + 0 · Σ params (with_every_parameter on several processes)",
    )
    parser.add_argument(
        "--rounds",
        type=int,
        default=5,
        help="alternating rounds of the variants",
    )
    parser.add_argument(
        "--pairs", type=int, default=0, help="time N interleaved pairs of single steps instead of rounds"
    )
    args = parser.parse_args()
    torch.set_num_threads(1)
    torch.manual_seed(0)
    spec = table7_spec()
    configs = resolve_row_configs(spec, parse_table_args(spec, ["--preset", "cpu", "--rows", "#4,#7"]))
    m = configs["#7"].method
    peak = matmul_peak()
    print(f"matmul peak (fp32, 512², one thread): {peak / 1e9:.1f} GFLOP/s")
    d = int(m.encoder.motion.latent_channels)
    frames = 62  # 4 s at 15.6 Hz latents
    stage = diffusion_stage(m, None)
    batch = int(m.train_diffusion.batch_size)
    data = {"z_music": torch.randn(batch, frames, d), "z_motion": torch.randn(batch, frames, d)}
    steps: list[tuple[str, torch.nn.Module, Callable[[], torch.Tensor]]] = [
        ("diffusion (θ_a + θ_m)", stage, lambda: stage(data)[0])
    ]
    vae = build_component(m.encoder, "encoders").train()
    mel = torch.randn(int(m.train_music_vae.batch_size), 80, 250)  # 4 s of MoMu mel frames
    music_loss = build_component(m.vae_loss, "losses")

    def music_step() -> torch.Tensor:
        out = vae.music_vae(mel)
        return music_loss(out.reconstruction, out.target, out.posterior)["loss"]

    steps.append(("music VAE", vae.music_vae, music_step))
    rows = [(name, *step_flops_and_time(module, step)) for name, module, step in steps]
    # As the table trains it: one random length per batch between train_min_seconds and the window.
    min_frames = round(frames * float(m.train_min_seconds) / float(m.window_seconds))
    as_trained = diffusion_stage(m, min_frames)
    steps.append((f"diffusion, {min_frames}-{frames} frames", as_trained, lambda: as_trained(data)[0]))
    unet = diffusion_stage(configs["#4"].method, min_frames)  # row #4: the 1D U-Net denoisers
    steps.append((f"#4 U-Net, {min_frames}-{frames} fr.", unet, lambda: unet(data)[0]))
    for name, flops, seconds in rows:
        achieved = flops / seconds
        print(
            f"{name:24s} {flops / 1e9:7.2f} GFLOP/step  {seconds * 1e3:7.1f} ms/step  "
            f"{achieved / 1e9:6.1f} GFLOP/s  = {100 * achieved / peak:5.1f} % of the matmul peak"
        )
    how = f"({args.pairs} pairs of steps)" if args.pairs else f"(median of {args.rounds} rounds)"
    if args.bf16:
        bf16_peak = matmul_peak(dtype=torch.bfloat16)
        print(f"\nmatmul peak (bf16, 512², one thread): {bf16_peak / 1e9:.1f} GFLOP/s")
        for name, module, step in steps:
            ratio = step_ratio(module, step, args.rounds, pairs=args.pairs, bf16=True)
            print(f"{name:24s} bf16 autocast step / fp32 step = {ratio:.2f} {how}")
    for variant in ("fused", "foreach"):
        if getattr(args, variant):
            print()
            for name, module, step in steps:
                ratio = step_ratio(module, step, args.rounds, pairs=args.pairs, optimizer=variant)
                print(f"{name:24s} {variant}-AdamW step / single-tensor AdamW step = {ratio:.2f} {how}")
    if args.every_parameter:
        print()
        for name, module, step in steps:
            ratio = 1.0 / step_ratio(module, step, args.rounds, pairs=args.pairs, zero_term=True)
            print(f"{name:24s} one-process step / loss + 0 · Σ params step = {ratio:.2f} {how}")
    if args.results is not None:
        prov = json.loads(args.results.read_text())["provenance"]
        total = sum(v["cpu_s"] for v in prov.get("timings", {}).values()) or 1.0
        print(
            f"\nprofile of {args.results} (wall {prov['wall_time_s']:.0f} s, {prov.get('jobs', 1)} job(s)):"
        )
        for key, rec in sorted(prov.get("timings", {}).items(), key=lambda kv: -kv[1]["cpu_s"]):
            share = 100 * rec["cpu_s"] / total
            print(f"  {key:24s} cpu {rec['cpu_s']:8.0f} s ({share:4.1f} %)  wall {rec['wall_s']:8.0f} s")
        jobs, wall = int(prov.get("jobs", 1)), float(prov["wall_time_s"])
        print(
            f"  the CPU seconds fill {100 * total / (jobs * wall):.0f} % of {jobs} job(s) x {wall:.0f} s "
            f"of wall; perfectly packed they would take {total / jobs / 60:.0f} min"
        )


def diffusion_stage(method: Any, min_frames: int | None) -> DiffusionStage:
    """Row ``method``'s θ_a + θ_m training module (``min_frames``: variable lengths as the table trains)."""
    d = int(method.encoder.motion.latent_channels)
    return DiffusionStage(
        build_component(backbone_node(method.music_backbone, d), "backbones"),
        build_component(backbone_node(method.motion_backbone, d), "backbones"),
        build_component(
            method.diffusion_loss, "losses", scheduler=build_component(method.scheduler, "schedulers")
        ),
        d,
        min_frames,
        per_batch=min_frames is not None and method.train_lengths == "batch",
    ).train()


def step_ratio(
    module: torch.nn.Module,
    step: Callable[[], torch.Tensor],
    rounds: int,
    *,
    pairs: int = 0,
    bf16: bool = False,
    optimizer: str = "single",
    zero_term: bool = False,
) -> float:
    """Median over ``rounds`` of (variant step time) / (fp32 step with the single-tensor AdamW),
    back to back.

    The variant runs ``step`` under a CPU bf16 autocast (``bf16``) and/or steps AdamW with
    ``optimizer`` = ``fused`` (``fused=True``) or ``foreach`` (``foreach=True``), and/or gives every
    parameter its gradient through ``loss + 0 · Σ params`` as on several processes (``zero_term``)
    instead of the one-process callback. Both sides of a round draw the same random lengths.
    With ``pairs`` it times that many pairs of single steps instead, the two in alternating order,
    and returns the ratio of the summed times: finer interleaving, for effects of a few percent on
    a machine whose speed drifts.
    """
    params = [p for p in module.parameters() if p.requires_grad]
    plain = torch.optim.AdamW(params, lr=1e-4, foreach=False)
    variant_opt = plain
    if optimizer != "single":
        variant_opt = torch.optim.AdamW(params, lr=1e-4, **{optimizer: True})

    def variant_step() -> torch.Tensor:
        several = every_parameter._several_processes
        every_parameter._several_processes = lambda: zero_term or several()  # type: ignore[assignment]
        try:
            with torch.autocast("cpu", dtype=torch.bfloat16, enabled=bf16):
                return step()
        finally:
            every_parameter._several_processes = several  # type: ignore[assignment]

    if pairs:  # one step each, in alternating order, the same random draws within a pair
        seconds = {False: 0.0, True: 0.0}
        for k in range(pairs):
            for variant in (False, True) if k % 2 else (True, False):
                torch.manual_seed(k)
                seconds[variant] += time_train_steps(
                    variant_step if variant else step, variant_opt if variant else plain, 1, warmup=0
                )
        return seconds[True] / seconds[False]
    ratios = []
    for k in range(rounds):
        torch.manual_seed(k)
        fp32 = time_train_steps(step, plain, 5)
        torch.manual_seed(k)
        ratios.append(time_train_steps(variant_step, variant_opt, 5) / fp32)
    return statistics.median(ratios)


if __name__ == "__main__":
    main()
