"""momu's sensitivity study of HarmoGAN's harmony score (not the paper's analysis).

    python benchmarks/harmogan_metric_sensitivity.py --data ../shared/data/dance_with_melody [--out FILE.json]

On every 6-s window (the paper's clip length) of the dances at 15 fps — the real Dance with Melody
subset with ``--data``, and synth_dance (dwm21, 15 fps, exactly beat-aligned motion) always — it
measures h and the hit rate of ground truth against:

* phase: the audio shifted by ¼ and ½ of the song's beat and by whole seconds (−3 … +3 s);
* tempo: the motion played ×0.8, ×0.9, ×1.1, ×1.25 against unchanged music;
* jitter: a static mean pose plus Gaussian noise (0.01 mm … 1 cm), and ground truth plus 2 cm noise;
* T_delay: for T_delay 0.05 … 0.25 s, ground truth minus its half-beat-shifted copy (where phase
  starts to matter);
* clip length: h and hit rate on 2-, 4-, 6-, 10- and 20-s windows.

Differences come with 95 % paired bootstrap intervals over windows
(:func:`momu.engine.statistics.paired_bootstrap`).
Prints a Markdown report (docs/papers/harmogan.md quotes it) and writes the numbers as JSON.
"""

from __future__ import annotations

import argparse
import json
import logging
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

from momu.data.types import Clip
from momu.engine.statistics import paired_bootstrap
from momu.features.audio import MfccConfig
from momu.methods.harmogan.data import Dance, Window, eval_windows, prepare_dances, window_clip
from momu.methods.harmogan.perturb import beat_period, shifted_audio, static_pose, time_warped
from momu.metrics.harmony import harmony
from momu.registry import DATASETS

log = logging.getLogger("harmogan_metric_sensitivity")
FPS = 15.0


def _scores(
    pairs: list[tuple[np.ndarray, int, np.ndarray]], t_delay: float = 0.25
) -> tuple[np.ndarray, np.ndarray]:
    h, hr = [], []
    for audio, sr, motion in pairs:
        r = harmony(audio, sr, motion, FPS, t_delay=t_delay)
        h.append(r.h)
        hr.append(r.hit_rate)
    return np.asarray(h), np.asarray(hr)


def _line(
    name: str, base: tuple[np.ndarray, np.ndarray], other: tuple[np.ndarray, np.ndarray]
) -> dict[str, object]:
    out: dict[str, object] = {"condition": name}
    for key, a, b in (("h", base[0], other[0]), ("hit_rate", base[1], other[1])):
        iv = paired_bootstrap(a[:, None], b[:, None], seed=0)
        out[key] = float(b.mean())
        out[f"{key}_gt_minus"] = [iv.estimate, iv.low, iv.high]
    return out


def study(dances: list[Dance], label: str) -> dict[str, object]:
    windows: list[Window] = eval_windows(dances, "all", 6.0)
    clips: list[Clip] = [window_clip(dances[w.dance], w) for w in windows]
    gt_pairs = [(c.audio, c.sample_rate, c.motion) for c in clips]
    gt = _scores(gt_pairs)  # type: ignore[arg-type]
    periods = {i: beat_period(d) for i, d in enumerate(dances)}
    rows: list[dict[str, object]] = []

    def add(
        name: str, make: Callable[..., tuple[np.ndarray, int, np.ndarray]], t_delay: float = 0.25
    ) -> None:
        pairs = [make(w, c, i) for i, (w, c) in enumerate(zip(windows, clips))]
        base = gt if t_delay == 0.25 else _scores(gt_pairs, t_delay)  # type: ignore[arg-type]
        rows.append({**_line(name, base, _scores(pairs, t_delay)), "t_delay": t_delay})

    n = len(clips)
    add(
        "shuffled (next window's motion)", lambda w, c, i: (c.audio, c.sample_rate, clips[(i + 1) % n].motion)
    )
    for frac in (0.25, 0.5):
        add(
            f"audio shifted {frac} beat",
            lambda w, c, i, f=frac: (
                shifted_audio(dances[w.dance], w, f * periods[w.dance]),
                c.sample_rate,
                c.motion,
            ),
        )
    for sec in (-3.0, -1.0, 1.0, 3.0):
        add(
            f"audio shifted {sec:+.0f} s",
            lambda w, c, i, s=sec: (shifted_audio(dances[w.dance], w, s), c.sample_rate, c.motion),
        )
    for factor in (0.8, 0.9, 1.1, 1.25):
        add(
            f"motion ×{factor}",
            lambda w, c, i, f=factor: (c.audio, c.sample_rate, time_warped(dances[w.dance], w, f)),
        )
    rng = np.random.default_rng(0)
    for noise in (1e-5, 1e-4, 1e-3, 1e-2):
        add(
            f"static pose + {noise * 1000:g} mm noise",
            lambda w, c, i, s=noise: (c.audio, c.sample_rate, static_pose(c.motion, s, rng)),
        )
    add(
        "ground truth + 2 cm noise",
        lambda w, c, i: (c.audio, c.sample_rate, c.motion + rng.normal(0, 0.02, c.motion.shape)),
    )
    for delay in (0.05, 0.1, 0.15, 0.2):
        add(
            f"audio shifted 0.5 beat, T_delay {delay}",
            lambda w, c, i: (
                shifted_audio(dances[w.dance], w, 0.5 * periods[w.dance]),
                c.sample_rate,
                c.motion,
            ),
            t_delay=delay,
        )
    lengths = []
    for seconds in (2.0, 4.0, 6.0, 10.0, 20.0):
        ws = eval_windows(dances, "all", seconds)
        h, hr = _scores(
            [(c.audio, c.sample_rate, c.motion) for c in (window_clip(dances[w.dance], w) for w in ws)]
        )  # type: ignore[misc]
        lengths.append(
            {"seconds": seconds, "windows": len(ws), "h": float(h.mean()), "hit_rate": float(hr.mean())}
        )
    return {
        "data": label,
        "windows": n,
        "ground_truth": {"h": float(gt[0].mean()), "hit_rate": float(gt[1].mean())},
        "conditions": rows,
        "clip_length": lengths,
    }


def _markdown(result: dict[str, object]) -> str:
    gt = result["ground_truth"]  # type: ignore[index]
    lines = [f"### {result['data']} ({result['windows']} windows of 6 s, 15 fps)", "",
             f"Ground truth: h {gt['h']:.3f}, hit rate {gt['hit_rate']:.3f}.", "",  # type: ignore[index]
             "| condition | T_delay | h | GT − it [95 % CI] | hit rate | GT − it [95 % CI] |",
             "|---|---|---|---|---|---|"]  # fmt: skip
    for r in result["conditions"]:  # type: ignore[attr-defined]
        dh, dr = r["h_gt_minus"], r["hit_rate_gt_minus"]
        lines.append(
            f"| {r['condition']} | {r['t_delay']} | {r['h']:.3f} | "
            f"{dh[0]:+.3f} [{dh[1]:+.3f}, {dh[2]:+.3f}] | "
            f"{r['hit_rate']:.3f} | {dr[0]:+.3f} [{dr[1]:+.3f}, {dr[2]:+.3f}] |"
        )
    lines += ["", "| window | windows | h | hit rate |", "|---|---|---|---|"]
    lines += [
        f"| {r['seconds']:g} s | {r['windows']} | {r['h']:.3f} | {r['hit_rate']:.3f} |"
        for r in result["clip_length"]
    ]  # type: ignore[attr-defined]
    return "\n".join(lines) + "\n"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--data", type=Path, default=None, help="the Dance with Melody root (optional)")
    parser.add_argument("--out", type=Path, default=None, help="write the numbers as JSON here")
    args = parser.parse_args()
    logging.basicConfig(level=logging.INFO, format="%(message)s")
    start = time.time()
    sources = []
    if args.data is not None:
        real = DATASETS.build("dance_with_melody", {"root": str(args.data), "target_fps": FPS})
        sources.append(("Dance with Melody, 8 dances", real))
    synth = DATASETS.build("synth_dance", {"num_clips": 8, "skeleton": "dwm21", "fps": FPS,
                                           "root_centred": True,
                                           "min_seconds": 60.0, "max_seconds": 60.0})  # fmt: skip
    sources.append(("synth_dance (beat-aligned by construction)", synth))
    results = []
    for label, dataset in sources:
        dances = prepare_dances(dataset, FPS, 0.2, MfccConfig())
        results.append(study(dances, label))
        print(_markdown(results[-1]))
    log.info("%.0f s", time.time() - start)
    if args.out is not None:
        args.out.write_text(json.dumps(results, indent=2))


if __name__ == "__main__":
    main()
