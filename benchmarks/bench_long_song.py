"""Wall time, CPU time and peak memory of a dance for a 3-minute song, the old way timed in the same run,
and the seam statistic of the stitched windows.

    python benchmarks/bench_long_song.py [--model DIR] [--seconds 180] [--threads 2] [--quick] [--out F.json]

The song is a ``synth_dance`` song of the data the model was trained on (its ``training_data.json``;
seed 1, not a training clip's seed). Every
measurement runs in a fresh process (its own peak memory; OpenMP reads its settings when torch loads):

``two_pass``
    what ``momu generate dance`` does: windows in two batched passes (anchors, then bridges;
    :mod:`momu.generation.windows`) with ``OMP_WAIT_POLICY=PASSIVE`` (set by the ``momu`` command). Run
    first and again last, to show how the machine's load drifted during the benchmark; the first run also
    times writing the BVH, npz and mp4 as ``momu generate dance`` does.
``sequential``
    the same-run baseline: one window after another (the schedule before), same OpenMP setting.
``sequential_openmp_default`` / ``two_pass_openmp_default``
    ``OMP_WAIT_POLICY`` unset (libgomp's default: waiting threads spin). The first is ``momu generate
    dance`` as it was before this benchmark's changes (``--quick`` skips it: minutes on a loaded machine).
``two_pass_bf16``
    the two-pass schedule under CPU bf16 autocast, with its largest and mean deviation from fp32.

Timed (``generate``): ``music_to_motion_long`` — encoding the song, the windows, decoding. CPU time is
the process's (all its threads); on a machine shared with other jobs wall time depends on their load,
so the JSON records the load averages and, before each run, the fp32 matmul throughput of ``--threads``
threads (GFLOP/s; a machine-share probe), and states speed-ups as same-run ratios. Peak memory is the
process's maximum resident set size.

Seam statistic (per schedule): the joint-velocity jump (:func:`momu.generation.velocity_jumps`, m/s²) at
every window boundary — where newly generated frames meet known ones — against the 95th percentile of
the same statistic on its training data (synth_dance clips of the same config, at their own frame rate)
and on the generated dance away from the boundaries; and the largest jump anywhere across the known
frames a window was inpainted on (a soft-masked edge spreads its transition over them). One song says
little about the tails, so ``seams_over_songs`` repeats both schedules (and two-pass with hard bridge
edges, the ablation of the soft mask) on ``--seam-songs`` more songs (same length; untimed) and compares
them per song with 95 % t-intervals.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np

RUNS: dict[str, dict[str, Any]] = {
    "two_pass": {"schedule": "two_pass", "policy": "PASSIVE", "write": True},
    "sequential": {"schedule": "sequential", "policy": "PASSIVE"},
    "sequential_openmp_default": {"schedule": "sequential", "policy": None},
    "two_pass_openmp_default": {"schedule": "two_pass", "policy": None},
    "two_pass_bf16": {"schedule": "two_pass", "policy": "PASSIVE", "bf16": True},
    "two_pass_again": {"schedule": "two_pass", "policy": "PASSIVE"},
}


def _matmul_gflops(seconds: float = 0.5) -> float:
    import torch

    a, b = torch.randn(512, 512), torch.randn(512, 512)
    a @ b
    n, start = 0, time.perf_counter()
    while time.perf_counter() - start < seconds:
        a @ b
        n += 1
    return round(2 * 512**3 * n / (time.perf_counter() - start) / 1e9, 1)


def _synth_config(folder: Path, model: Any, **changes: Any) -> Any:
    """The synth_dance config the model was trained on (its ``training_data.json``; the default styles
    of the model's skeleton for a folder without one), with ``changes``."""
    import dataclasses
    import json

    from momu.config import build_component
    from momu.data.synth.dataset import SynthConfig

    record = folder / "training_data.json"
    if record.is_file():
        base = build_component(json.loads(record.read_text()), "datasets").cfg
    else:
        base = SynthConfig(skeleton=model.skeleton)
    return dataclasses.replace(base, **changes)


def _seam_statistic(
    folder: Path, model: Any, motion: np.ndarray, schedule: str, seconds: float
) -> dict[str, Any]:
    from momu.data.synth.dataset import generate_clip
    from momu.generation import seam_jumps, velocity_jumps
    from momu.generation.momu_long import plan_for_seconds

    fps, per_latent = model.rates.motion_fps, model.rates.motion_frames_per_latent
    plan = plan_for_seconds(model, seconds, schedule=schedule)
    frames = [b * per_latent for b in plan.boundaries]
    seams = seam_jumps(motion, frames, fps)
    jumps = velocity_jumps(motion, fps)  # index i belongs to frame i + 1
    away = np.ones(len(jumps), dtype=bool)
    for b in frames:
        away[max(0, b - 3) : b + 2] = False
    zone = np.zeros(len(jumps), dtype=bool)
    for k, (s, e) in enumerate(zip(plan.starts, plan.ends)):
        head, tail = plan.known(k)
        if head:
            zone[max(0, s * per_latent - 1) : (s + head + 1) * per_latent - 1] = True
        if tail:
            zone[max(0, (e - tail - 1) * per_latent - 1) : e * per_latent - 1] = True
    clips = [generate_clip(_synth_config(folder, model, num_clips=8, seed=9), i) for i in range(8)]
    p95 = float(np.percentile(np.concatenate([velocity_jumps(c.motion, c.fps) for c in clips]), 95))
    return {
        "seams": len(seams),
        "median": round(float(np.median(seams)), 3),
        "max": round(float(seams.max()), 3),
        "data_p95": round(p95, 3),
        "fraction_of_seams_above_data_p95": round(float(np.mean(seams > p95)), 4),
        "generated_away_from_seams_p95": round(float(np.percentile(jumps[away], 95)), 3),
        "inpainted_frames_max": round(float(jumps[zone].max()), 3),
        "inpainted_frames_p95": round(float(np.percentile(jumps[zone], 95)), 3),
        "elsewhere_p95": round(float(np.percentile(jumps[~zone], 95)), 3),
    }


def _zone_maxima(plan: Any, jumps: np.ndarray, per_latent: int) -> list[float]:
    """The largest jump across each run of known frames (+ the first new frame) of every window."""
    out = []
    for k, (s, e) in enumerate(zip(plan.starts, plan.ends)):
        head, tail = plan.known(k)
        if head:
            out.append(float(jumps[max(0, s * per_latent - 1) : (s + head + 1) * per_latent - 1].max()))
        if tail:
            out.append(float(jumps[(e - tail - 1) * per_latent - 1 : e * per_latent - 1].max()))
    return out


def _seams_over_songs(args: argparse.Namespace) -> dict[str, Any]:
    """Both schedules, and two-pass with hard bridge edges (the soft mask's ablation), on ``--seam-songs``
    more songs (synth seeds 200…, dance seeds 0…): pooled seam and edge-zone statistics, and per-song
    differences from the sequential schedule with 95 % t-intervals."""
    import torch

    torch.set_num_threads(args.threads)
    from momu.cli.generate_io import default_model_dir
    from momu.data.synth.dataset import generate_clip
    from momu.generation import seam_jumps, stitched_sample, velocity_jumps
    from momu.generation.follows_music import interval
    from momu.generation.momu_long import music_to_motion_long, plan_for_seconds, window_frames
    from momu.methods.momu import MoMuModel

    folder = Path(args.model or default_model_dir("dance"))
    model = MoMuModel.load(folder)
    fps, per_latent = model.rates.motion_fps, model.rates.motion_frames_per_latent
    clips = [generate_clip(_synth_config(folder, model, num_clips=8, seed=9), i) for i in range(8)]
    p95 = float(np.percentile(np.concatenate([velocity_jumps(c.motion, c.fps) for c in clips]), 95))

    def dance(song: Any, seed: int, variant: str) -> np.ndarray:
        if variant != "two_pass_hard_edges":
            return music_to_motion_long(model, [song.audio], song.sample_rate, [seed], schedule=variant)[0]
        window, overlap = window_frames(model, "motion")  # the ablation: bridges keep known frames exactly
        cond = model.condition_from_music(song.audio, song.sample_rate)
        (z,) = stitched_sample(
            model.sampler_for("motion"), model.motion_backbone, [cond], [seed], model.latent_channels,
            window=window, overlap=overlap, soft_edges=False,
        )  # fmt: skip
        return model.decode_motion(z)

    per_song: dict[str, list[dict[str, float]]] = {
        "two_pass": [],
        "two_pass_hard_edges": [],
        "sequential": [],
    }
    pooled: dict[str, dict[str, list[float]]] = {k: {"seams": [], "zones": []} for k in per_song}
    for i in range(args.seam_songs):
        cfg = _synth_config(
            folder, model, num_clips=1, min_seconds=args.seconds, max_seconds=args.seconds, seed=200 + i
        )
        song = generate_clip(cfg, 0)
        for variant in per_song:
            motion = dance(song, i, variant)
            plan = plan_for_seconds(model, args.seconds, schedule=variant.replace("_hard_edges", ""))
            seams = seam_jumps(motion, [b * per_latent for b in plan.boundaries], fps)
            zones = _zone_maxima(plan, velocity_jumps(motion, fps), per_latent)
            pooled[variant]["seams"] += seams.tolist()
            pooled[variant]["zones"] += zones
            per_song[variant].append(
                {"seam_median": float(np.median(seams)), "zone_median": float(np.median(zones))}
            )
    out: dict[str, Any] = {"songs": args.seam_songs, "data_p95": round(p95, 3)}
    for schedule, d in pooled.items():
        seams, zones = np.asarray(d["seams"]), np.asarray(d["zones"])
        out[schedule] = {
            "seams": len(seams),
            "seam_median": round(float(np.median(seams)), 3),
            "seam_max": round(float(seams.max()), 3),
            "seams_above_data_p95": round(float(np.mean(seams > p95)), 4),
            "zone_max_median": round(float(np.median(zones)), 3),
            "zone_max_p90": round(float(np.percentile(zones, 90)), 3),
            "zone_max_max": round(float(zones.max()), 3),
            "zones_above_data_p95": round(float(np.mean(zones > p95)), 4),
            "zones_above_1.5x_data_p95": round(float(np.mean(zones > 1.5 * p95)), 4),
        }
    for key in ("seam_median", "zone_median"):
        for variant in ("two_pass", "two_pass_hard_edges"):
            diff = np.asarray([a[key] - b[key] for a, b in zip(per_song[variant], per_song["sequential"])])
            out[f"per_song_{key}_{variant}_minus_sequential"] = {
                k: round(v, 3) for k, v in interval(diff).items()
            }
    return out


def _child(name: str, args: argparse.Namespace) -> dict[str, Any]:
    import torch

    torch.set_num_threads(args.threads)
    from momu.cli.generate_io import default_model_dir
    from momu.cli.generate_write import write_dance_outputs
    from momu.data.synth.dataset import generate_clip
    from momu.generation import stitched_sample
    from momu.generation.momu_long import music_to_motion_long, plan_for_seconds, window_frames
    from momu.methods.momu import MoMuModel

    run = RUNS[name]
    folder = Path(args.model or default_model_dir("dance"))
    model = MoMuModel.load(folder)
    song = generate_clip(
        _synth_config(folder, model, num_clips=1, min_seconds=args.seconds, max_seconds=args.seconds, seed=1),
        0,
    )
    assert song.audio is not None and song.sample_rate is not None
    gflops = _matmul_gflops()
    rss0 = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    load0 = os.getloadavg()[0]
    wall, cpu = time.perf_counter(), time.process_time()
    if run.get("bf16"):  # music_to_motion_long with the denoising (not the VAE) under bf16 autocast
        cond = model.condition_from_music(song.audio, song.sample_rate)
        window, overlap = window_frames(model, "motion")
        with torch.autocast("cpu", dtype=torch.bfloat16):
            (z,) = stitched_sample(
                model.sampler_for("motion"), model.motion_backbone, [cond], [0], model.latent_channels,
                window=window, overlap=overlap, schedule=run["schedule"],
            )  # fmt: skip
        motion = model.decode_motion(z)
    else:
        (motion,) = music_to_motion_long(model, [song.audio], song.sample_rate, [0], schedule=run["schedule"])
    wall, cpu = time.perf_counter() - wall, time.process_time() - cpu
    result: dict[str, Any] = {
        "schedule": run["schedule"],
        "omp_wait_policy": os.environ.get("OMP_WAIT_POLICY"),
        "bf16_autocast": bool(run.get("bf16")),
        "windows": len(plan_for_seconds(model, args.seconds, schedule=run["schedule"]).starts),
        "generate_s": round(wall, 2),
        "generate_cpu_s": round(cpu, 2),
        "load_average_1min_at_start": round(load0, 2),
        "matmul_gflops_before": gflops,
        "rss_before_generation_mib": round(rss0, 1),
    }
    if run.get("bf16"):
        (fp32,) = music_to_motion_long(model, [song.audio], song.sample_rate, [0], schedule=run["schedule"])
        diff = np.abs(motion - fp32)
        result["deviation_from_fp32_m"] = {
            "max": round(float(diff.max()), 4),
            "mean": round(float(diff.mean()), 5),
        }
    if run.get("write"):
        with tempfile.TemporaryDirectory() as tmp:
            times = {}
            for fmt in ("npz", "bvh", "mp4"):
                path = Path(tmp) / f"dance.{fmt}"
                start = time.perf_counter()
                write_dance_outputs(
                    {fmt: path},
                    motion,
                    model.rates.motion_fps,
                    model.skeleton,
                    song.audio,
                    song.sample_rate,
                    {},
                )
                times[fmt] = round(time.perf_counter() - start, 2)
            result["write_outputs_s"] = times
    result["peak_rss_mib"] = round(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024, 1)
    result["seam_jump_m_s2"] = _seam_statistic(folder, model, motion, run["schedule"], args.seconds)
    return result


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--model", type=Path)
    p.add_argument("--seconds", type=float, default=180.0)
    p.add_argument("--threads", type=int, default=2)
    p.add_argument("--quick", action="store_true", help="skip sequential_openmp_default (the slowest run)")
    p.add_argument("--out", type=Path)
    p.add_argument("--seam-songs", type=int, default=6, help="more songs for the seam comparison (0: none)")
    p.add_argument("--child", choices=[*sorted(RUNS), "seams"], help=argparse.SUPPRESS)
    args = p.parse_args()
    if args.child:
        print(json.dumps(_seams_over_songs(args) if args.child == "seams" else _child(args.child, args)))
        return

    names = [n for n in RUNS if not (args.quick and n == "sequential_openmp_default")]
    names += ["seams"] if args.seam_songs > 1 else []
    runs: dict[str, Any] = {}
    load_before = os.getloadavg()
    for name in names:
        env = {k: v for k, v in os.environ.items() if k != "OMP_WAIT_POLICY"}
        policy = RUNS[name]["policy"] if name in RUNS else "PASSIVE"
        if policy:
            env["OMP_WAIT_POLICY"] = policy
        env["OMP_NUM_THREADS"] = str(args.threads)
        cmd = [sys.executable, __file__, "--child", name, "--seconds", str(args.seconds)]
        cmd += ["--threads", str(args.threads), "--seam-songs", str(args.seam_songs)]
        cmd += ["--model", str(args.model)] if args.model else []
        out = subprocess.run(cmd, env=env, check=True, capture_output=True, text=True).stdout
        runs[name] = json.loads(out.strip().splitlines()[-1])
        print(name, json.dumps(runs[name]), file=sys.stderr, flush=True)
    seams_over_songs = runs.pop("seams", None)
    new, again, seq = runs["two_pass"], runs["two_pass_again"], runs["sequential"]

    def ratio(old: dict[str, Any], key: str) -> float:
        return round(old[key] / min(new[key], again[key]), 1)

    result: dict[str, Any] = {
        "model": str(args.model or "shipped (momu-dwm21)"),
        "song_seconds": args.seconds,
        "threads": args.threads,
        "machine": {
            "cpus": os.cpu_count(),
            "processor": platform.processor() or platform.machine(),
            "load_average_before": [round(x, 2) for x in load_before],
            "load_average_after": [round(x, 2) for x in os.getloadavg()],
        },
        "runs": runs,
        "seams_over_songs": seams_over_songs,
        "same_run_ratios": {
            "sequential_over_two_pass_wall": ratio(seq, "generate_s"),
            "sequential_over_two_pass_cpu": ratio(seq, "generate_cpu_s"),
        },
    }
    if "sequential_openmp_default" in runs:
        old = runs["sequential_openmp_default"]
        result["same_run_ratios"]["before_over_now_wall"] = ratio(old, "generate_s")
        result["same_run_ratios"]["before_over_now_cpu"] = ratio(old, "generate_cpu_s")
    text = json.dumps(result, indent=2)
    print(text)
    if args.out:
        args.out.write_text(text + "\n")


if __name__ == "__main__":
    main()
