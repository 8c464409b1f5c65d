"""Does the cpu preset need 1000 DDPM steps? The same trained Table 7 #7 model sampled with fewer.

Sampling dominates a Table 7 run at the cpu preset (θ_a with 1000 DDPM steps and classifier-free
guidance costs seconds per 4-s clip on one core), so the preset's step count decides whether three
training seeds fit in an hour. This study trains (or reuses) row #7's stages for one seed and
generates the 32 evaluation clips' music and motion with DDPM at each step count, every clip with
its own sampling seed (the same across step counts), from its own condition and from another
clip's. It reports per direction the F1 cell, the paired difference to the 1000-step sampler
(clip-level bootstrap, :func:`momu.engine.statistics.paired_bootstrap`) and the margins over the
shuffled calibration and over another clip's condition, with CPU seconds per sample.

    python benchmarks/momu_sampler_steps_study.py --out outputs/reproduce --steps 1000 250 100

``--out`` is a table output folder: the stages land in the tables' shared stage folder
(``<out>/momu_shared/parts``) under the same keys a ``recipes/momu_table7.py`` run uses, so either
reuses the other's.
"""

from __future__ import annotations

import argparse
import json
import logging
import time
from pathlib import Path

import numpy as np
import torch

from momu.config import to_container
from momu.engine.accelerate_setup import RunConfig, finish_accelerator, make_accelerator
from momu.engine.context import RunContext
from momu.engine.scores import ROW
from momu.engine.statistics import paired_bootstrap, reduce_components
from momu.engine.table import parse_table_args, resolve_row_configs, shared_parts_root
from momu.methods.momu.data import eval_crops
from momu.methods.momu.evaluate import fit_momu
from momu.methods.momu.generation import OTHER, generate_motion, generate_music
from momu.methods.momu.recipes import table7_spec
from momu.methods.momu.scoring import beat_components, derangement, eval_lengths, replace_clip

log = logging.getLogger("sampler_steps_study")


def _row7_config(steps: int, spacing: str) -> object:
    spec = table7_spec()
    overrides = [
        f"method.sampler.scheduler.num_inference_steps={steps}",
        f"method.sampler.scheduler.timestep_spacing={spacing}",
    ]
    args = parse_table_args(spec, ["--preset", "cpu", "--rows", "#7", *overrides])
    return resolve_row_configs(spec, args)["#7"]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("outputs/reproduce"))
    parser.add_argument("--steps", type=int, nargs="+", default=[1000, 250, 100])
    parser.add_argument("--spacing", default="trailing", help="timestep spacing of the strided samplers")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--results", type=Path, default=Path("outputs/sampler_steps_study.json"))
    args = parser.parse_args()
    logging.basicConfig(level=logging.INFO, format="%(levelname)s %(name)s: %(message)s")
    torch.set_num_threads(1)
    spec = table7_spec()
    out = args.out / spec.name
    accelerator = make_accelerator(RunConfig(tracker="none", seed=args.seed), out, "study", {})
    ctx = RunContext(accelerator=accelerator, out_dir=out, parts_root=shared_parts_root(spec, args.out))
    report: dict[str, object] = {"seed": args.seed, "steps": {}}
    components: dict[int, dict[str, dict[str, np.ndarray]]] = {}
    for steps in args.steps:
        cfg = _row7_config(steps, "leading" if steps == 1000 else args.spacing)
        _, model, dataset, _, _ = fit_momu(ctx, cfg, args.seed)
        ev = model.cfg.evaluation
        truth = eval_crops(dataset, ev.split, ev.num_clips, eval_lengths(ev, args.seed))
        perm = derangement(len(truth))
        shuffled = [
            replace_clip(truth[i], "/s", motion=truth[perm[i]].motion, audio=truth[perm[i]].audio)
            for i in range(len(truth))
        ]
        cpu = time.process_time()
        music = generate_music(ctx, model, truth, args.seed, ev.batch_size)
        music_cpu = (time.process_time() - cpu) / (2 * len(truth))
        cpu = time.process_time()
        motion = generate_motion(ctx, model, truth, args.seed, ev.batch_size)
        motion_cpu = (time.process_time() - cpu) / (2 * len(truth))
        bins = float(ev.beat_bin_seconds)
        comps = {
            "music": {v: beat_components("music", c, truth, bins) for v, c in music.items()},
            "motion": {v: beat_components("motion", c, truth, bins) for v, c in motion.items()},
        }
        comps["music"]["shuffled"] = beat_components("music", shuffled, truth, bins)
        comps["motion"]["shuffled"] = beat_components("motion", shuffled, truth, bins)
        components[steps] = comps
        entry: dict[str, object] = {
            "cpu_s_per_music_sample": music_cpu,
            "cpu_s_per_motion_sample": motion_cpu,
        }
        for direction, by_variant in comps.items():
            row = by_variant[ROW]
            entry[direction] = {
                "f1": float(reduce_components(row, "f1")[0]),
                "vs_shuffled": paired_bootstrap(row, by_variant["shuffled"], reducer="f1").as_dict(),
                "vs_other_condition": paired_bootstrap(row, by_variant[OTHER], reducer="f1").as_dict(),
            }
            if steps != args.steps[0]:
                ref = components[args.steps[0]][direction][ROW]
                entry[direction]["vs_first_steps"] = paired_bootstrap(row, ref, reducer="f1").as_dict()  # type: ignore[index]
        report["steps"][str(steps)] = entry  # type: ignore[index]
        log.info("%d steps: %s", steps, json.dumps(entry, indent=1))
        args.results.parent.mkdir(parents=True, exist_ok=True)
        args.results.write_text(json.dumps({**report, "config": to_container(cfg)}, indent=1))
    finish_accelerator(accelerator)


if __name__ == "__main__":
    main()
