"""Which music → dance sampler settings should the shipped model use? Validation split, every training seed.

    python benchmarks/shipped_motion_sampler_study.py --models SEED0_DIR SEED1_DIR SEED2_DIR \
        --variants 8:0 5:0 8:0.7 8:0:500-999 8:0:eta=0 5:0:ddim:tau=0.5 \
        --data ../shared/data/dance_with_melody --out OUT

For each model folder (one per training seed of ``recipes/pretrain.py``) and each variant
``SCALE:RESCALE[:LOW-HIGH][:eta=ETA][:ddim][:tau=TAU]`` — the motion sampler's ``guidance_scale``,
``guidance_rescale`` (rescaled guidance, Lin et al. 2024 §3.4, :func:`momu.samplers.base.rescale_guided`)
and, when given, its ``guidance_interval`` (training timesteps), ``guidance_parallel`` (η of projected
guidance, Sadat et al. 2025, :func:`momu.samplers.base.project_guided`), a deterministic DDIM scheduler
(``ddim``: η = 0, the shipped steps and spacing) and ``noise_temperature`` (``tau``: z_T ~ N(0, τ²I));
everything else as shipped — a copy
of the folder with that ``motion_sampler`` is scored by the music-following benchmark
(``recipes/music_following.py``, music → dance, the **validation** split, 15-s excerpts, generation
seeds 0 1 2, no controls) into ``OUT/<variant>_seed<k>/music_following``. ``OUT/summary.{json,md}``
collects, per variant and training seed, the verdicts and intervals of input sensitivity and tempo
following, the outputs' spread over seeds (D_seed, m) and the realism statistics, and per variant the
study's rule (``benchmarks/results/shipped_motion_sampler_val/README.md``): whether it passes every
test and check at every training seed, and its mean foot speed's |log ratio| to the real dances' median.
"""

from __future__ import annotations

import argparse
import json
import logging
import shutil
import tempfile
from pathlib import Path
from typing import Any

import numpy as np

from momu.following.run import main as benchmark

log = logging.getLogger("shipped_motion_sampler_study")
TESTS = ("input_sensitivity", "tempo_following")
REALISM = ("root_travel_m_per_min", "foot_speed", "joint_speed", "bone_length_cv")


def _variant(text: str) -> tuple[str, dict[str, Any]]:
    """``SCALE:RESCALE[:LOW-HIGH][:eta=ETA][:ddim][:tau=TAU]`` as a run name and the ``motion_sampler``
    fields it sets (``ddim``: the ``scheduler`` fields that differ from the shipped DDPM's)."""
    scale, _, rest = text.partition(":")
    rescale, *extra = rest.split(":") if rest else [""]
    fields: dict[str, Any] = {"guidance_scale": float(scale), "guidance_rescale": float(rescale or 0.0)}
    name = f"scale{fields['guidance_scale']:g}_rescale{fields['guidance_rescale']:g}"
    for part in extra:
        if part.startswith("eta="):
            fields["guidance_parallel"] = float(part[4:])
            name += f"_parallel{fields['guidance_parallel']:g}"
        elif part.startswith("tau="):
            fields["noise_temperature"] = float(part[4:])
            name += f"_tau{fields['noise_temperature']:g}"
        elif part == "ddim":
            fields["scheduler"] = {"name": "ddim", "eta": 0.0}
            name += "_ddim"
        else:
            low, high = (int(v) for v in part.split("-"))
            fields["guidance_interval"] = [low, high]
            name += f"_interval{low}-{high}"
    return name, fields


def _with_sampler(model: Path, fields: dict[str, Any], into: Path) -> Path:
    """A copy of ``model`` whose ``motion_sampler`` has ``fields``."""
    dst = into / model.name
    shutil.copytree(model, dst)
    meta = json.loads((dst / "momu.json").read_text())
    sampler = meta["config"]["motion_sampler"]
    if "scheduler" in fields:  # ddim: the shipped scheduler's steps, spacing, clipping and prediction
        shipped = {k: v for k, v in sampler["scheduler"].items() if k not in ("name", "variance_type")}
        fields = {**fields, "scheduler": {**shipped, **fields["scheduler"]}}
    sampler.update(fields)
    (dst / "momu.json").write_text(json.dumps(meta, indent=2) + "\n")
    return dst


def _results(run: Path) -> Path:
    """A run's ``results.json``: as the benchmark writes it, or moved up as committed."""
    written = run / "music_following" / "results.json"
    return written if written.exists() else run / "results.json"


def _cell(d: dict[str, Any]) -> str:
    return f"{d['estimate']:.3f} [{d['low']:.3f}, {d['high']:.3f}] {d.get('verdict', '')}"


def _summary(out: Path, names: list[str], seeds: int) -> None:
    rows: list[dict[str, Any]] = []
    variants: list[dict[str, Any]] = []
    for name in names:
        passes, feet, sensitivity, spreads, median = True, [], [], [], float("nan")
        for k in range(seeds):
            res = json.loads(_results(out / f"{name}_seed{k}").read_text())
            direction = res["directions"]["dance"]
            row = next(r for r in direction["rows"] if r["kind"] == "generator")
            checks = [row["tests"][t] for t in TESTS] + [row["realism"][m] for m in REALISM]
            passes = passes and all(d.get("verdict") == "passes" for d in checks)
            feet.append(row["realism"]["foot_speed"]["estimate"])
            sensitivity.append(row["tests"]["input_sensitivity"]["estimate"])
            median = direction["reference_realism"]["foot_speed"]["median"]
            cells = {t: _cell(row["tests"][t]) for t in TESTS}
            spread = row["tests"]["input_sensitivity"].get("seed_distance")
            cells["seed_distance_m"] = _cell(spread) if spread else "n/a"
            spreads.append(spread["estimate"] if spread else float("nan"))
            cells.update({m: _cell(row["realism"][m]) for m in REALISM})
            rows.append({"variant": name, "training_seed": k, **cells})
        foot = float(np.mean(feet))
        variants.append(
            {
                "variant": name,
                "passes_at_every_seed": passes,
                "mean_input_sensitivity": round(float(np.mean(sensitivity)), 3),
                "mean_foot_speed": round(foot, 3),
                "mean_seed_distance_m": round(float(np.mean(spreads)), 4),
                "real_median_foot_speed": round(median, 3),
                "abs_log_ratio": round(abs(float(np.log(foot / median))), 4),
            }
        )
    (out / "summary.json").write_text(json.dumps({"runs": rows, "variants": variants}, indent=2) + "\n")
    lines = []
    for table in (rows, variants):
        head = list(table[0])
        lines += ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
        lines += ["| " + " | ".join(str(r[h]) for h in head) + " |" for r in table] + [""]
    (out / "summary.md").write_text("\n".join(lines))


def main() -> None:
    logging.basicConfig(level=logging.INFO, format="%(message)s")
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--models", type=Path, nargs="+", required=True, help="model folders, training seed order")
    p.add_argument(
        "--variants",
        nargs="+",
        default=["8:0"],
        help="SCALE:RESCALE[:LOW-HIGH][:eta=ETA][:ddim][:tau=TAU]: motion sampler",
    )
    p.add_argument("--data", default="../shared/data/dance_with_melody")
    p.add_argument("--out", type=Path, required=True)
    p.add_argument("--summary-only", action="store_true", help="only rewrite OUT/summary.{json,md}")
    args = p.parse_args()
    names = []
    for text in args.variants:
        name, fields = _variant(text)
        names.append(name)
        for k, model in enumerate(args.models):
            run = args.out / f"{name}_seed{k}"
            if args.summary_only or _results(run).exists():
                continue
            with tempfile.TemporaryDirectory() as tmp:
                folder = _with_sampler(model, fields, Path(tmp))
                log.info("%s, training seed %d", name, k)
                code = benchmark(
                    ["--generator", str(folder), "--direction", "dance", "--data", args.data]
                    + ["--split", "val", "--songs", "8", "--seconds", "15", "--seeds", "0", "1", "2"]
                    + ["--no-controls", "--quiet", "--out", str(run)]
                )
            if code:
                raise SystemExit(code)
    _summary(args.out, names, len(args.models))


if __name__ == "__main__":
    main()
