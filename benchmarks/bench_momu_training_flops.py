"""Achieved FLOP/s of the MoMu cpu-preset training steps against a matmul peak measured in the same run.

The machines are shared, so absolute seconds mean little: this script measures, in one process
and one thread, (1) the dense fp32 matmul throughput of this core (the ceiling), and (2) for each
trainable stage of the cpu preset (music VAE, motion VAE + RCL, θ_a + θ_m diffusion) the FLOPs of
one training step (forward + backward, counted by ``torch.utils.flop_counter``) divided by its
step time, and prints their ratio. It also prints the per-stage profile of a finished table run
when given its ``results.json`` (``provenance.timings``: wall and CPU seconds per category).

    python benchmarks/bench_momu_training_flops.py [--results outputs/reproduce/momu_table7/results.json]
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import torch
from perf_common import matmul_peak, step_flops_and_time  # benchmarks/perf_common.py

from momu.config import build_component
from momu.engine.table import parse_table_args, resolve_row_configs
from momu.methods.momu.config import backbone_node
from momu.methods.momu.recipes import table7_spec
from momu.methods.momu.stages import DiffusionStage


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--results", type=Path, default=None, help="a table's results.json (stage profile)")
    args = parser.parse_args()
    torch.set_num_threads(1)
    torch.manual_seed(0)
    spec = table7_spec()
    m = resolve_row_configs(spec, parse_table_args(spec, ["--preset", "cpu", "--rows", "#7"]))["#7"].method
    peak = matmul_peak()
    print(f"matmul peak (fp32, 512², one thread): {peak / 1e9:.1f} GFLOP/s")
    d = int(m.encoder.motion.latent_channels)
    frames = 62  # 4 s at 15.6 Hz latents
    stage = DiffusionStage(
        build_component(backbone_node(m.music_backbone, d), "backbones"),
        build_component(backbone_node(m.motion_backbone, d), "backbones"),
        build_component(m.diffusion_loss, "losses", scheduler=build_component(m.scheduler, "schedulers")),
        d,
        min_frames=None,
    ).train()
    batch = int(m.train_diffusion.batch_size)
    data = {"z_music": torch.randn(batch, frames, d), "z_motion": torch.randn(batch, frames, d)}
    rows = [("diffusion (θ_a + θ_m)", *step_flops_and_time(stage, lambda: stage(data)[0]))]
    vae = build_component(m.encoder, "encoders").train()
    mel = torch.randn(int(m.train_music_vae.batch_size), 80, 250)  # 4 s of MoMu mel frames
    music_loss = build_component(m.vae_loss, "losses")

    def music_step() -> torch.Tensor:
        out = vae.music_vae(mel)
        return music_loss(out.reconstruction, out.target, out.posterior)["loss"]

    rows.append(("music VAE", *step_flops_and_time(vae.music_vae, music_step)))
    for name, flops, seconds in rows:
        achieved = flops / seconds
        print(
            f"{name:24s} {flops / 1e9:7.2f} GFLOP/step  {seconds * 1e3:7.1f} ms/step  "
            f"{achieved / 1e9:6.1f} GFLOP/s  = {100 * achieved / peak:5.1f} % of the matmul peak"
        )
    if args.results is not None:
        prov = json.loads(args.results.read_text())["provenance"]
        total = sum(v["cpu_s"] for v in prov.get("timings", {}).values()) or 1.0
        print(
            f"\nprofile of {args.results} (wall {prov['wall_time_s']:.0f} s, {prov.get('jobs', 1)} job(s)):"
        )
        for key, rec in sorted(prov.get("timings", {}).items(), key=lambda kv: -kv[1]["cpu_s"]):
            share = 100 * rec["cpu_s"] / total
            print(f"  {key:24s} cpu {rec['cpu_s']:8.0f} s ({share:4.1f} %)  wall {rec['wall_s']:8.0f} s")


if __name__ == "__main__":
    main()
