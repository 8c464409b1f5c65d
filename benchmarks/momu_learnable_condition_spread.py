"""Does the Table 3-4 learnable encoder's condition vary with its motion, and does θ_a use it?

A diagnostic for ``benchmarks/momu_learnable_steps_study.py`` (issue 12, item 7). It trains (or
reuses, from the same ``--out``) the learnable-encoder model of Table 3's Floor Exercise 25-s
stand-in (``fe25``) for one seed, encodes the first ``--clips`` **validation** crops and prints

* the spread of the condition ``learnable_motion(m)`` ``(N, n_z, d)``: its standard deviation across
  clips (per latent frame and channel, averaged) and over time within a clip — an encoder that has
  learned nothing about the motion varies over time (its positional input) but not across clips;
* θ_a's ε-prediction error on the same crops' music latents, noised at fixed timesteps with fixed
  noise, given the right motion's condition, another crop's, and the null condition.

    python benchmarks/momu_learnable_condition_spread.py --out OUT [key=value ...]

Overrides are the table's (``learnable_encoder.standardize=false``, ``learnable_train.steps=1200``).
"""

from __future__ import annotations

import argparse
import logging
from pathlib import Path

import torch

from momu.config import build_component, to_container
from momu.encoders.bicor_vae import align_frames
from momu.engine.accelerate_setup import RunConfig, finish_accelerator, make_accelerator
from momu.engine.context import RunContext
from momu.engine.table import parse_table_args, resolve_row_configs, shared_parts_root
from momu.methods.momu.data import WindowDataset, eval_crops
from momu.methods.momu.learnable import _encode_music_windows, fit_learnable_motion_to_music
from momu.methods.momu.tables import table3_spec
from momu.methods.momu.tables_eval import _train_config
from momu.methods.momu.tables_setup import subset_config

log = logging.getLogger("learnable_condition_spread")
CONFIGS = Path(__file__).resolve().parents[1] / "recipes" / "configs"
TIMESTEPS = (50, 200, 400, 600, 800, 950)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, required=True)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--clips", type=int, default=32)
    parser.add_argument("overrides", nargs="*", help="key=value overrides of the table config")
    args = parser.parse_args()
    logging.basicConfig(level=logging.WARNING, format="%(name)s: %(message)s")
    log.setLevel(logging.INFO)
    spec = table3_spec(CONFIGS / "momu.yaml", CONFIGS / "momu_tables.yaml")
    table_args = parse_table_args(spec, ["--preset", "cpu", "--data", "synth", *args.overrides])
    cfg = next(iter(resolve_row_configs(spec, table_args).values()))
    out = args.out / spec.name
    accelerator = make_accelerator(RunConfig(tracker="none", seed=args.seed), out, "spread", {})
    parts = shared_parts_root(spec, args.out)
    ctx = RunContext(accelerator=accelerator, out_dir=out, resume=True, parts_root=parts)
    scfg = subset_config(cfg, "fe25")
    method = build_component(scfg.method, "methods")
    dataset = build_component(scfg.dataset, "datasets")
    model = fit_learnable_motion_to_music(
        ctx, method, scfg.learnable_encoder, _train_config(scfg.learnable_train), dataset,
        to_container(scfg.dataset), args.seed, frames_per_latent=int(scfg.learnable_frames_per_latent),
    )  # fmt: skip
    seconds = float(method.cfg.evaluation.seconds)
    crops = eval_crops(dataset, "val", args.clips, [seconds])
    windows = WindowDataset(crops, model.norms, model.rates, seconds, seconds, need_mel=True, need_wave=False)
    stage = model.stage
    z = (_encode_music_windows(model.vae, windows) - stage.music_mean) / stage.music_std  # (N, n_z, d)
    motion = align_frames(torch.stack([it["motion"] for it in windows.items]), z.shape[1], dim=1)
    with torch.no_grad():
        cond = stage.condition(motion)
        log.info(
            "condition %s: std across clips %.4f, over time within a clip %.4f",
            tuple(cond.shape), float(cond.std(0).mean()), float(cond.std(1).mean()),
        )  # fmt: skip
        n = z.shape[0]
        other = torch.roll(torch.arange(n), 1)
        scheduler = stage.loss.scheduler
        for t in TIMESTEPS:
            eps = torch.randn(z.shape, generator=torch.Generator().manual_seed(t))
            steps = torch.full((n,), t, dtype=torch.long)
            noisy = scheduler.add_noise(z, eps, steps)
            errors = {
                name: float(((stage.backbone(noisy, steps, c) - eps) ** 2).mean())
                for name, c in (("right", cond), ("other", cond[other]), ("null", None))
            }
            log.info("t=%4d ε-MSE right %.4f other %.4f null %.4f", t, *errors.values())
    finish_accelerator(accelerator)


if __name__ == "__main__":
    main()
