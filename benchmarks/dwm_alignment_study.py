"""Why real Dance-with-Melody pairs do not beat shuffled pairs on BAS / harmony (issue 4 acceptance).

Measures, on the 8-dance subset in ``../shared/data/dance_with_melody`` (loaded with momu's
``dance_with_melody`` loader: 21 points, 25 fps, metres, audio from ``start_position / 25`` s):

1. **Tempo**: the song's beat period (least-squares slope of ``librosa.beat.beat_track`` beat times on
   the dance's audio) against the motion's own periodicity (autocorrelation of the foot speed: first
   peak in 0.25-3 s, and the bar period — 3 beats for waltz, 4 otherwise — from the peaks at k bars up
   to 20 s, parabolic interpolation) and the metadata ratio ``T / (end − start)``. A wrong frame-rate
   convention (30 or 24 fps data read as 25 fps) would show as one common ratio of 0.83 / 1.04.
2. **Phase locking**: vector strength ``R = |mean exp(2πi φ)|`` of the motion beats (minima of the
   σ = 2-frame smoothed mean joint speed) at their phase φ inside the song's beat intervals — GT pairs
   against every motion with every other song; ``R`` is insensitive to a constant offset, so it tests
   whether the motion follows the beat at all (chance level ≈ 1/√N).
3. **Metrics** GT vs shuffled (every motion with every other song, both cut to the shorter):
   BAS (Bailando and mint variants, motion resampled to 60 fps, mint-recipe music beats), harmony h
   and hit rate (HarmoGAN defaults at 25 fps, at HarmoGAN's 15 fps, and on global positions =
   skeleton + ``center``); "stretched" = the T frames spread over ``end − start`` (fps 25·T/(end−start)).
4. **Control**: BAS and harmony when each song's beats are replaced by a constant-tempo beat grid
   tracked on the motion itself (``beat_track`` on its kinetic envelope; clicks for harmony) — tests
   whether the speed minima carry a pulse that a constant-tempo grid can follow at all.
5. **Time base**: a time scale ``a`` (motion time × a, 0.97-1.04) fitted for every pair alike by a
   phase-insensitive beat coherence of the foot-speed envelope with the song's beat grid; then BAS
   with the warped motion at the best shift within ±1 beat (again for every pair alike).
6. **Offset scan**: GT BAS for audio offsets of −8..8 s around ``start_position / 25``.

Every GT-vs-shuffled line gives the permutation p-value over all 14 833 derangements of the 8 songs
(row and column effects cancel in it; shuffled pairs of different tempi are also reported apart).

    python benchmarks/dwm_alignment_study.py [--root ../shared/data/dance_with_melody] [--out study.json]

Takes about 1 minute on the shared 2-core machine. Numbers are written to docs/metrics_beats.md
("Real-data calibration").
"""

from __future__ import annotations

import argparse
import logging
import sys
from dataclasses import dataclass
from pathlib import Path

import librosa
import numpy as np
from dwm_signals import (  # benchmarks/dwm_signals.py
    SR,
    acf_period,
    beat_coherence,
    gt_vs_shuffled,
    long_lag_period,
    motion_beat_grid,
    motion_beat_times,
    pair_matrix,
    resample,
    song_beats,
    speed,
    to_60fps,
    vector_strength,
)
from scipy.ndimage import gaussian_filter1d
from scipy.signal import argrelextrema

from momu.data.dance_with_melody import DanceWithMelodyConfig, DanceWithMelodyDataset
from momu.metrics import bas, harmony_from_beats, music_beats
from momu.metrics._audio import read_audio
from momu.metrics.beat_align import beat_align_score
from momu.metrics.beats import MUSIC_FPS, motion_beats
from momu.metrics.harmony import audio_beats, motion_beats_harmogan

logger = logging.getLogger("dwm_alignment_study")

DEFAULT_ROOT = Path(__file__).resolve().parents[1].parent / "shared" / "data" / "dance_with_melody"
FEET = [9, 10, 11, 18, 19, 20]  # ankles and the two foot points of each leg (dwm21)


@dataclass
class Dance:
    id: str
    motion: np.ndarray  # (T, 21, 3) metres, root-centred, 25 fps
    trajectory: np.ndarray  # (T, 3) global root
    fps: float
    audio: np.ndarray  # the dance's part of the song, mono, SR Hz
    song: np.ndarray  # the whole song, mono, SR Hz
    offset: float  # start_position / 25, seconds
    stretch: float  # T / (end_position - start_position)


def load_dances(root: Path) -> list[Dance]:
    ds = DanceWithMelodyDataset(DanceWithMelodyConfig(root=str(root), sample_rate=SR))
    out = []
    for i in range(len(ds)):
        clip = ds[i]
        song, sr = read_audio(Path(clip.meta["audio_source"]))
        song = np.asarray(librosa.resample(song, orig_sr=sr, target_sr=SR, res_type="soxr_hq"))
        assert clip.audio is not None and clip.trajectory is not None
        motion = np.asarray(clip.motion, np.float64)
        out.append(
            Dance(
                clip.id,
                motion,
                np.asarray(clip.trajectory, np.float64),
                clip.fps,
                np.asarray(clip.audio, np.float32).reshape(-1),
                song,
                float(clip.meta["audio_offset_seconds"]),
                motion.shape[0] / (clip.meta["end_position"] - clip.meta["start_position"]),
            )
        )
    return out


# ------------------------------------------------------------------------------------------------ study
def tempo_table(dances: list[Dance], beats: list[np.ndarray]) -> list[dict[str, float | str]]:
    """Per dance: song beat period (least-squares slope of the beat times: finer than the 23-ms hop),
    the motion's periodicity (first autocorrelation peak, and the long-lag estimate at the multiple of
    the beat with the clearest peaks), their ratio, and the metadata ratio ``T / (end − start)``."""
    rows: list[dict[str, float | str]] = []
    for d, bt in zip(dances, beats):
        ibi = float(np.polyfit(np.arange(len(bt)), bt, 1)[0])
        feet = gaussian_filter1d(
            np.linalg.norm(np.diff(d.motion[:, FEET], axis=0), axis=-1).mean(axis=1), 1.0
        )
        first, first_r = acf_period(feet, d.fps, 0.25, 3.0)
        m = 3 if d.id.split("_")[1] == "W" else 4  # beats per bar: waltz 3/4, the others 4/4
        period, r = long_lag_period(feet, d.fps, m * ibi)
        rows.append(
            {
                "id": d.id,
                "bpm": 60.0 / ibi,
                "beat_s": ibi,
                "motion_first_acf_s": first,
                "motion_first_acf_r": first_r,
                "motion_first_over_beats": first / ibi,
                "beats_per_motion_period": float(m),
                "motion_period_s": period,
                "motion_period_r": r,
                "motion_over_music": period / (m * ibi) if m else float("nan"),
                "t_over_end_minus_start": d.stretch,
            }
        )
    return rows


def windowed_strength(
    mb: list[np.ndarray], beats: list[np.ndarray], seconds: float = 10.0
) -> tuple[np.ndarray, list[list[tuple[float, float]]]]:
    """Vector strength in ``seconds``-long windows: matrix (motion i, song j) of the mean over i's windows,
    and for the GT pairs each window's (R, phase in beats)."""
    n = len(mb)
    mat = np.zeros((n, n))
    gt: list[list[tuple[float, float]]] = []
    for i, t in enumerate(mb):
        starts = np.arange(0.0, t[-1] - seconds + 1e-9, seconds)
        for j, bt in enumerate(beats):
            vals = []
            for t0 in starts:
                w = t[(t >= t0) & (t < t0 + seconds)]
                k = np.searchsorted(bt, w) - 1
                ok = (k >= 0) & (k < len(bt) - 1)
                if ok.sum() < 3:
                    continue
                ph = (w[ok] - bt[k[ok]]) / (bt[k[ok] + 1] - bt[k[ok]])
                z = np.exp(2j * np.pi * ph).mean()
                vals.append((float(abs(z)), float(np.angle(z) / (2 * np.pi))))
            mat[i, j] = float(np.mean([v[0] for v in vals])) if vals else float("nan")
            if i == j:
                gt.append(vals)
    return mat, gt


def run(root: Path) -> dict[str, object]:
    dances = load_dances(root)
    n = len(dances)
    logger.info("loaded %d dances", n)
    result: dict[str, object] = {"dances": [d.id for d in dances]}
    beats = [song_beats(d.audio) for d in dances]
    tempo = tempo_table(dances, beats)
    result["tempo"] = tempo
    bpm = np.array([float(t["bpm"]) for t in tempo])
    ratio = bpm[:, None] / bpm[None, :]
    diff_tempo = np.abs(np.log(ratio)) > np.log(1.05)  # tempi more than 5 % apart
    result["different_tempo_pairs"] = int(diff_tempo.sum())

    # 2. phase locking (vector strength) GT vs shuffled: whole dance and 10-s windows
    mb = [motion_beat_times(d.motion, d.fps) for d in dances]
    vs = pair_matrix(n, lambda i, j: vector_strength(mb[i], beats[j])[0])
    win, gt_windows = windowed_strength(mb, beats)
    result["vector_strength"] = {
        "whole": gt_vs_shuffled(vs, diff_tempo),
        "windows_10s": gt_vs_shuffled(win, diff_tempo),
        "chance_whole": float(np.mean([np.sqrt(np.pi) / 2 / np.sqrt(len(t)) for t in mb])),
        "gt_windows": {d.id: w for d, w in zip(dances, gt_windows)},
        "matrix": vs.tolist(),
    }
    # stretched: frame k at k·(end − start)/T / 25 s, i.e. the T frames spread over end − start
    vs_s = pair_matrix(n, lambda i, j: vector_strength(mb[i] / dances[i].stretch, beats[j])[0])
    result["vector_strength"]["whole_stretched"] = gt_vs_shuffled(vs_s, diff_tempo)  # type: ignore[index]
    # foot plants: minima of the σ = 2-frame smoothed foot speed
    plants = [
        (argrelextrema(gaussian_filter1d(speed(d.motion[:, FEET]), 2.0), np.less)[0] + 0.5) / d.fps
        for d in dances
    ]
    vs_f = pair_matrix(n, lambda i, j: vector_strength(plants[i], beats[j])[0])
    result["vector_strength"]["foot_plants"] = gt_vs_shuffled(vs_f, diff_tempo)  # type: ignore[index]

    # 3. metrics GT vs shuffled
    def cut(i: int, j: int, t: np.ndarray, motions: list[np.ndarray], fps: list[float]) -> np.ndarray:
        """Beats before the end of the shorter of motion i and song j."""
        end = min(motions[i].shape[0] / fps[i], len(dances[j].audio) / SR)
        return t < end

    ab = [audio_beats(d.audio, SR) for d in dances]

    def harmony_matrix(
        motions: list[np.ndarray], fps: list[float], audio: list[tuple[np.ndarray, np.ndarray]]
    ) -> dict[str, object]:
        vis = [motion_beats_harmogan(m, f) for m, f in zip(motions, fps)]
        h = np.zeros((n, n))
        hit = np.zeros((n, n))
        for i in range(n):
            tv, sv, j0 = vis[i]
            for j in range(n):
                ta, sa = audio[j]
                ka, kv = cut(i, j, ta, motions, fps), cut(i, j, tv, motions, fps)
                r = harmony_from_beats(ta[ka], sa[ka], tv[kv], sv[kv], j0)
                h[i, j], hit[i, j] = r.h, r.hit_rate
        rate = float(np.mean([len(v[0]) / (m.shape[0] / f) for v, m, f in zip(vis, motions, fps)]))
        return {
            "h": gt_vs_shuffled(h, diff_tempo),
            "hit_rate": gt_vs_shuffled(hit, diff_tempo),
            "visual_beats_per_s": rate,
            "h_matrix": h.tolist(),
            "hit_matrix": hit.tolist(),
        }

    root_centred = [d.motion for d in dances]
    global_pos = [d.motion + d.trajectory[:, None] for d in dances]
    fps25 = [d.fps for d in dances]
    fps_stretch = [d.fps * d.stretch for d in dances]  # T frames spread over end − start
    metrics: dict[str, object] = {}
    metrics["harmony_25fps"] = harmony_matrix(root_centred, fps25, ab)
    metrics["harmony_15fps"] = harmony_matrix([resample(m, 25.0, 15.0) for m in root_centred], [15.0] * n, ab)
    metrics["harmony_global_25fps"] = harmony_matrix(global_pos, fps25, ab)
    metrics["harmony_stretched"] = harmony_matrix(root_centred, fps_stretch, ab)

    mus = [music_beats(d.audio, SR, recipe="mint") for d in dances]
    cases = {
        "root": [to_60fps(m, f) for m, f in zip(root_centred, fps25)],
        "global": [to_60fps(m, f) for m, f in zip(global_pos, fps25)],
        "root_stretched": [to_60fps(m, f) for m, f in zip(root_centred, fps_stretch)],
    }
    for name, motions in cases.items():
        for variant in ("bailando", "mint"):
            if name == "root_stretched" and variant == "mint":
                continue
            mat = pair_matrix(
                n,
                lambda i, j, ms=motions, v=variant: bas(ms[i], mus[j], variant=v),  # type: ignore[misc]
            )
            metrics[f"bas_{variant}_{name}"] = {"bas": gt_vs_shuffled(mat, diff_tempo)}
    result["metrics"] = metrics
    m60 = cases["root"]

    # 4. control: beats tracked on the motion itself (a constant-tempo song locked to the dance)
    grids = [motion_beat_grid(d.motion, d.fps) for d in dances]
    control: dict[str, object] = {
        "grid_over_song_bpm": [
            float(np.median(np.diff(b)) / np.median(np.diff(g))) for g, b in zip(grids, beats)
        ],
    }
    grid60 = [np.unique(np.round(g * MUSIC_FPS).astype(np.int64)) for g in grids]
    mat = pair_matrix(n, lambda i, j: bas(m60[i], grid60[j], variant="bailando"))
    control["bas_bailando_root"] = gt_vs_shuffled(mat)
    rng = np.random.default_rng(0)
    clicks = []
    for d, g in zip(dances, grids):
        y = librosa.clicks(times=g, sr=SR, length=len(d.audio))
        clicks.append(audio_beats(y + 1e-3 * rng.standard_normal(len(y)), SR))
    ctl = harmony_matrix(root_centred, fps25, clicks)
    control["harmony_25fps"] = {"h": ctl["h"], "hit_rate": ctl["hit_rate"]}
    result["control_motion_beat_grid"] = control

    # 5. time base: fit a time scale a (motion time × a) for EVERY pair by the phase-insensitive beat
    # coherence (2-, 3- or 4-beat period), then Bailando BAS with the warped motion beats at the best
    # shift within ±1 beat — the same search for GT and shuffled pairs.
    scales = np.round(np.arange(0.97, 1.04, 0.001), 3)
    feet = [
        gaussian_filter1d(np.linalg.norm(np.diff(d.motion[:, FEET], axis=0), axis=-1).mean(axis=1), 1.0)
        for d in dances
    ]
    coh = np.zeros((n, n))
    fitted = np.zeros((n, n))
    bas_fit = np.zeros((n, n))
    dance_beats = [motion_beats(m, variant="bailando") for m in m60]
    for i, d in enumerate(dances):
        tk = (np.arange(len(feet[i])) + 0.5) / d.fps
        for j in range(n):
            c = [max(beat_coherence(feet[i], a * tk, beats[j], pb) for pb in (2, 3, 4)) for a in scales]
            k = int(np.argmax(c))
            coh[i, j], fitted[i, j] = c[k], scales[k]
            warped = np.round(dance_beats[i] * scales[k]).astype(np.int64)
            end = min(m60[i].shape[0] * scales[k], len(dances[j].audio) / SR * MUSIC_FPS) - 1
            ibi = float(np.median(np.diff(beats[j])))
            best = 0.0
            for shift in np.arange(-ibi, ibi + 1e-9, 1.0 / MUSIC_FPS):
                grid = np.round((beats[j] - shift) * MUSIC_FPS).astype(np.int64)
                grid = grid[(grid >= 0) & (grid < end)]
                if len(grid):
                    best = max(best, beat_align_score(grid, warped))
            bas_fit[i, j] = best
    result["time_base"] = {
        "fitted_scale_gt": np.diag(fitted).tolist(),
        "coherence": gt_vs_shuffled(coh, diff_tempo),
        "coherence_matrix": coh.tolist(),
        "bas_fitted_scale_best_shift": gt_vs_shuffled(bas_fit, diff_tempo),
    }

    # 6. offset scan of the GT pairs (audio offset relative to start_position / 25)
    shifts = np.round(np.arange(-8.0, 8.0001, 0.04), 2)
    scan_bas = np.zeros((n, len(shifts)))
    scan_vs = np.zeros((n, len(shifts)))
    for i, d in enumerate(dances):
        bt = song_beats(d.song) - d.offset
        for k, s in enumerate(shifts):
            b = bt - s
            b = b[(b >= 0) & (b < d.motion.shape[0] / d.fps)]
            scan_vs[i, k] = vector_strength(mb[i], b)[0] if len(b) > 2 else np.nan
            scan_bas[i, k] = bas(m60[i], np.round(b * MUSIC_FPS).astype(np.int64)) if len(b) else np.nan
    zero = int(np.argmin(np.abs(shifts)))
    result["offset_scan"] = {
        "shifts_s": shifts.tolist(),
        "bas_at_0": scan_bas[:, zero].tolist(),
        "bas_max": np.nanmax(scan_bas, 1).tolist(),
        "bas_median": np.nanmedian(scan_bas, 1).tolist(),
        "bas_at_0_rank": [int((row > row[zero]).sum()) for row in scan_bas],
        "best_shift_bas": [float(shifts[int(np.nanargmax(r))]) for r in scan_bas],
        "n_shifts": len(shifts),
    }
    return result


def report(r: dict) -> None:
    out = sys.stdout.write

    def pair(x: list) -> str:
        return (
            f"GT {x[0]:.4f} vs shuffled {x[1]:.4f} (different tempi {x[3]:.4f}; own song best {x[2]}/8; "
            f"p {x[4]:.3f})"
        )

    out("== 1. tempo: song beat period (slope of beat times) vs the motion's periodicity (foot speed acf)\n")
    out(
        f"{'dance':10s} {'bpm':>6s} {'1st acf s':>9s} {'/beat':>6s} {'beats':>5s} {'period s':>8s} {'r':>5s}"
        f" {'motion/music':>12s} {'T/(end-start)':>13s}\n"
    )
    for t in r["tempo"]:
        out(
            f"{t['id']:10s} {t['bpm']:6.1f} {t['motion_first_acf_s']:9.3f}"
            f" {t['motion_first_over_beats']:6.2f}"
            f" {t['beats_per_motion_period']:5.0f} {t['motion_period_s']:8.4f} {t['motion_period_r']:5.2f}"
            f" {t['motion_over_music']:12.4f} {t['t_over_end_minus_start']:13.4f}\n"
        )
    out(f"pairs with tempi > 5 % apart: {r['different_tempo_pairs']} of 56\n")
    v = r["vector_strength"]
    out("== 2. phase locking: vector strength of motion beats (speed minima) in the song's beat intervals\n")
    out(f"  whole dance          {pair(v['whole'])}  chance ~{v['chance_whole']:.3f}\n")
    out(f"  whole, stretched     {pair(v['whole_stretched'])}\n")
    out(f"  10-s windows (mean)  {pair(v['windows_10s'])}\n")
    out(f"  foot-speed minima    {pair(v['foot_plants'])}\n")
    for k, w in v["gt_windows"].items():
        out(f"    {k:10s} R@phase: " + " ".join(f"{a:.2f}@{b:+.2f}" for a, b in w) + "\n")
    out("== 3. metrics\n")
    for name, m in r["metrics"].items():
        if name.startswith("harmony"):
            out(
                f"  {name:22s} h   {pair(m['h'])}\n  {'':22s} hit {pair(m['hit_rate'])}; "
                f"visual beats/s {m['visual_beats_per_s']:.2f}\n"
            )
        else:
            out(f"  {name:22s} BAS {pair(m['bas'])}\n")
    c = r["control_motion_beat_grid"]
    out("== 4. control: song beats replaced by a beat grid tracked on the motion\n")
    out("  grid bpm / song bpm: " + " ".join(f"{x:.3f}" for x in c["grid_over_song_bpm"]) + "\n")
    out(f"  BAS bailando root      {c['bas_bailando_root'][0]:.4f} vs {c['bas_bailando_root'][1]:.4f}\n")
    h = c["harmony_25fps"]
    out(
        f"  harmony (clicks)       h {h['h'][0]:.4f} vs {h['h'][1]:.4f}; hit {h['hit_rate'][0]:.3f} vs "
        f"{h['hit_rate'][1]:.3f}\n"
    )
    tb = r["time_base"]
    out("== 5. time base: scale a fitted per pair (motion time × a) by phase-insensitive beat coherence\n")
    out("  fitted a (GT): " + " ".join(f"{x:.3f}" for x in tb["fitted_scale_gt"]) + "\n")
    out(f"  coherence              {pair(tb['coherence'])}\n")
    out(f"  BAS, a fitted, best shift within ±1 beat: {pair(tb['bas_fitted_scale_best_shift'])}\n")
    s = r["offset_scan"]
    out(f"== 6. offset scan ±8 s, 40-ms steps ({s['n_shifts']} shifts), GT BAS (Bailando, root)\n")
    out("  at 0: " + " ".join(f"{x:.3f}" for x in s["bas_at_0"]) + "\n")
    out("  median: " + " ".join(f"{x:.3f}" for x in s["bas_median"]) + "\n")
    out("  max: " + " ".join(f"{x:.3f}" for x in s["bas_max"]) + f"  at shifts {s['best_shift_bas']}\n")
    out(f"  rank of shift 0 (0 = best): {s['bas_at_0_rank']}\n")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--root", type=Path, default=DEFAULT_ROOT)
    parser.add_argument("--out", type=Path, default=None, help="write all numbers as JSON")
    args = parser.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(message)s")
    if not args.root.is_dir():
        raise FileNotFoundError(f"--root {args.root}: no Dance-with-Melody folder")
    result = run(args.root)
    report(result)
    if args.out is not None:
        from momu.io import write_json

        write_json(args.out, result)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
