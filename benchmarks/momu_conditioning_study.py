"""Study: does the ``cpu``-preset MoMu music→motion model follow its music? (issue 5 acceptance)

Trains ONLY what music→motion needs — the music VAE (stage 1), the motion VAE (stage 2) and the
denoisers (one diffusion stage trains θ_a and θ_m together, MoMu Eq. 6) — through the method's own
code path (:meth:`momu.methods.momu.MoMu.fit`) on a small ``synth_dance`` (openpose14, 2D pixels),
then generates motion for the held-out ``test`` clips twice: conditioned on the clip's own music
(*right*) and on another clip's music (*shuffled*, the derangement π(i) = i+1 of
:func:`momu.methods.momu.scoring.derangement`). Both motions are scored against clip i's music:

* ``bas`` — Beat Align Score (bailando variant, MoFusion Eq. 10, σ = 3 frames at the decoded rate),
  music beats from clip i's audio;
* ``f1`` — ``kinematic_beat_scores`` F1 (MoMu App. B.5, one-second bins, percent);
* ``f1_025s`` — the same with 0.25-s bins (``bin_seconds``; one-second bins saturate on this music);
* ``onset_f1`` — kinematic beats vs music onsets within ±50 ms (percent,
  :func:`momu.methods.momu.scoring.motion_onset_f1s`).

A model that follows its condition scores clearly higher with the right music. The ground-truth
motion (and the ground-truth motion of clip π(i)) give the ceiling and the chance level.

It also prints the motion VAE's reconstruction spread (mean per-joint standard deviation over
time, pixels) against the data's, the diagnostic for "the VAE decodes static motion".

Stages are cached in ``--out`` by their keys (:meth:`momu.engine.context.RunContext.stage`), so a
second setting that changes only the denoiser reuses the trained VAEs.

    OMP_NUM_THREADS=2 python benchmarks/momu_conditioning_study.py --out /tmp/momu_study \
        [--set method.motion_backbone.cond_add=true ...]

``--cpu-preset`` trains at the ``cpu`` preset's sizes instead of SMALL (the third and fourth rounds
below: ``--cpu-preset --eval-clips 18 --threads 1 --music``); ``--music`` also scores motion→music
(θ_a) from the right and from another clip's motion against the clips' music (beat scores in
0.25-s bins: F1, precision = BCS, recall = BHS, and detected onsets per clip).

Prints one line per number; nothing is asserted.

Findings at the SMALL size below (30 clips of 6 s, 6 held-out 4 s crops, CPU): ground truth BAS 0.680
vs 0.151 shuffled; no tried setting separated generated motion (right vs shuffled BAS within ±0.06
either way, latent MSE to clip i's latent equal). The motion VAE is the ceiling: its reconstructions
score BAS 0.37 and ±50 ms onset F1 0. With the paper's λ4 = 1 the contrastive term (~1) swamps the
mean-MSE reconstruction (~0.04 in the isotropically normalised units), so the VAE decodes damped
motion (13 px spread vs 19 px; 8.6 px with RCL). Plain 25-step DDIM diverges at this size
(standardised latent MSE ~125); ``clip_sample`` bounds it but collapses the motion to ~9 px.
``cond_add`` + aligned positions with 1000-step DDPM clipped to ±4 (now the cpu preset) makes the
latent follow its music (MSE to clip i's latent 1.38 right vs 3.11 shuffled) and, with a motion VAE
trained without RCL, BAS 0.236 vs 0.152 (mean of 3 noise seeds); with RCL (λ4 = 1 or 0.02) the
decoded motion does not separate (the VAE is the bottleneck).

Second round (12 held-out crops; ``f1_025s`` = kinematic-beat F1 in 0.25-s bins, percent):

* ``vae_loss.reduction=sum`` (RCL kept): BAS right 0.273 vs shuffled 0.158, VAE spread 13.8 px.
* With ``dataset.attack=0.3`` (moves start on the beat) ground truth scores f1_025s 83.8 vs 42.7
  shuffled, but the VAE's reconstructions only 34: the zero-padded decoder put a ~20 px/frame jump on
  the first and last frames, whose Q spike hides every other kinematic beat (``padding_mode=replicate``
  removes it), and nearest-frame alignment of 60 fps motion to 62.5 fps repeated a frame every 0.5 s
  (a one-frame stop = a spurious kinematic beat; ``align=linear`` now interpolates).
* Reconstruction f1_025s: 34.5 (sum, replicate) → 47.7 (+ ``velocity_weight=10``; 45.8 at 30);
  4000 instead of 1200 VAE steps 40.2; base width 32 with 2 residual blocks 35.4; latent rate
  31.25 Hz 47.2; linear alignment 43.3. The reconstructions stay far from ground truth (position
  error 5–11 px, velocity error 50–70 % of the speed): a sharp start is smeared over ~10 frames.
* Generated, right vs shuffled music (f1_025s): 46.3 vs 40.4 (velocity 10, 1500 diffusion steps;
  latent MSE 1.80 vs 2.07), 40.3 vs 40.9 without the velocity term, 43.7 vs 34.3 at lr 1e-3 / batch
  16; the shuffled ground truth scores 42.7. The latent follows its music; the decoded beats barely.
* Motion→music (music F1 in 0.25-s bins, same data): right 36.9 vs shuffled-condition 30.1 with the
  plain DiT, 36.7 vs 37.7 with ``cond_add``; shuffled real music scores 44.4, the music VAE's own
  reconstructions 100 (the mel VAE + Griffin-Lim keep every onset). With 4000 diffusion steps θ_a
  follows its motion (24.4 right vs 12.8 shuffled condition) but places fewer onsets overall.

Third round (full ``cpu`` preset data, Table 7 #7's stages, 18 held-out 4-s crops = 9 test + 9 val
clips; F1 in 0.25-s bins; shuffled ground truth: music 42.1, motion 45.0):

* θ_a with ``cond_add`` + aligned positions (as θ_m) and 4000 diffusion steps with cosine decay
  follows its motion: music F1 41.3 from the right motion vs 22.4 from another clip's motion
  (1500 steps, plain θ_a: 30.6 vs 23.7). Its music lands onsets in the right bins (precision 56-63)
  but only a third of them (recall 32; 3.6 detected onsets per clip vs 6.1): the hits it does not
  place are simply absent from the mel, not weak (Griffin-Lim 16 or 64 iterations: identical
  scores). CFG scale 1.5 / 3 / 5: 33.7 / 41.3 / 42.7.
* θ_m: 1000-step DDPM 45.0 and 47.1 (two noise seeds) vs 200-step DDIM clipped to ±4: 52.4 and 50.1
  (shuffled condition 45.3 and 46.2); DDIM keeps more kinematic beats (recall 69 vs 51-57).
  Motion→music with DDIM-200 drops to 28.0. But on the model of the Table 7 run that followed
  (same config, trained with two threads), DDIM-200 scored 41.0 vs 52.1 shuffled condition and
  DDPM 52.9 vs 41.0 (onset F1 30.2 vs 14.6): one model's sampler preference did not carry over,
  so the cpu preset keeps DDPM for both directions (``motion_sampler`` stays available).
* Evaluation noise: the same weights scored music F1 52.5 and 38.5 on the 9 test clips when the
  DDPM step noise came from the global RNG (it depended on what ran before); samples now depend on
  their seed only (per-item generators).
* The motion VAE's own reconstructions score 28-40 (ground truth 68): retraining the same config
  moves it by ±5, 2400 instead of 1200 steps 37.7, cosine decay 36.9, base width 32 27.7. No lag:
  the speed profiles correlate best at shift 0 and matched beats are 0 ms off (median).
* 160 instead of 80 clips (18 test clips): music 38.2 vs 38.3 shuffled, motion 46.6 vs 47.7.

Fourth round (2026-12-01; the same 18 crops, one thread per run; "shuffled" = another clip's real
music, 42.1 music F1 and 45.0 motion F1; "shuffled cond." = generated from another clip's motion):

* Where θ_a's missing hits go: its onsets sit 0.05-0.2 s off the real ones (often late), so many
  fall into a neighbouring 0.25-s bin, and it places 3.4 onsets per clip against the real 6.1; the
  onset-strength envelope of its music at the real onset frames is 1-6 % of its peak (real music:
  45-100 %). The music VAE's reconstructions keep every onset at the right time (F1 99.7), so the
  denoiser, not the VAE or the vocoder, loses them.
* Latent rate 31.25 Hz (one downsampling level, as MoMu's Table 8) with θ_a unchanged: music 40.9 vs
  37.4 shuffled cond. (4.3 onsets per clip), motion 45.9 vs 38.3: the finer latent does not help.
* θ_a at hidden 128, depth 4 (0.95 M parameters instead of 0.17 M; θ_m unchanged), 4000 steps:
  music F1 at guidance scale 3 / 5 (shuffled cond. in brackets):
  seed 0: 45.0 (32.8) / 50.2 (27.9); seed 1: 45.2 (35.4) / 46.4 (35.9); seed 2: 56.9 (29.9) /
  58.5 (28.2). Every seed beats the shuffled real music at scale 5 (mean 51.7), and follows its
  motion by 10-30 points: now the cpu preset (``music_backbone``, ``music_sampler`` with scale 5).
  The small θ_a on seed 0's stages: 39.4 (22.5) at scale 3.
* θ_m (hidden 64, depth 2) on the same three trainings: motion F1 56.0 (45.4), 43.3 (43.4) and 49.5
  (45.0): on seed 1 it ignores its music altogether. Guidance scale 5 instead of 3 on seed 2: 49.7
  (45.9), no change.
* θ_m also at hidden 128, depth 4 (seed 1's VAEs; diffusion 1.6x slower): motion 48.5 (41.2), it now
  follows its music, but θ_a, retrained in the same stage, fell to 41.7 (31.0) music F1. One seed
  only; not adopted (the cpu preset keeps θ_m at hidden 64, depth 2).

Fifth round (2026-12-02; ``--cpu-preset --music --eval-clips 32 --splits val --threads 1``: settings
are chosen on the 32 validation crops only, never on test; every run below reuses the same seed-0
VAEs, so only the denoisers differ; real shuffled: music F1 41.8, motion F1 42.5; ground truth motion
F1 72.0; "other" = generated from another clip's condition):

* the cpu preset as it stood (condition tokens + ``cond_add``, per-item masked lengths): motion F1
  43.9 (other 47.3): θ_m does not follow its music; music F1 44.3 (other 40.7).
* ``cond_tokens=false`` (the condition enters by the frame-aligned addition only) with one training
  length per batch (``train_lengths=batch``), 2.3x cheaper per step: motion 50.5 (other 39.1), music
  46.2 (other 41.4). Trained a second time (the same config; the reused VAEs leave the RNG in
  another state, so the denoisers differ): motion 46.3 (41.5) at guidance 3; guidance 5 for motion
  and 8 for music: motion 45.3 (42.2), music 39.2 (37.3); music guidance 3: 40.2 (37.6). θ_a at
  depth 6: music 45.4 (39.4), motion 43.1 (39.5). θ_m follows its music in every additive run
  (+3.1 to +11.4) and in none with tokens; music F1 stays 3-5 points above shuffled real music;
  retraining the same config moves a cell by up to 5 points, so one run decides nothing alone.
  Adopted: ``cond_tokens=false``, ``train_lengths=batch``, guidance 3 / 5, depth 4.
"""

from __future__ import annotations

import argparse
import dataclasses
import logging
import time
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import torch

from momu.config import build_component, load_config, to_container
from momu.data.types import Clip
from momu.engine import RunConfig, make_accelerator
from momu.engine.context import RunContext
from momu.methods.momu import MoMuModel
from momu.methods.momu.data import eval_crops
from momu.methods.momu.scoring import derangement, motion_onset_f1s
from momu.metrics.loris_scores import onset_times
from momu.registry import METRICS

ROOT = Path(__file__).resolve().parents[1]

# A small synth_dance and short training: every setting trains in a few CPU minutes.
SMALL = [
    "dataset.num_clips=30",  # 3 styles cycled: ~23 train / 3-4 val / 3-4 test clips
    "dataset.min_seconds=6.0",
    "dataset.max_seconds=6.0",
    "method.train_music_vae.steps=120",
    "method.train_motion_vae.steps=400",
    "method.train_diffusion.steps=500",
    "method.evaluation.split=test",
]


def alignment(truth: Sequence[Clip], motions: Sequence[np.ndarray], fps: float) -> dict[str, float]:
    """BAS, kinematic-beat F1 and ±50 ms onset F1 of ``motions[i]`` against ``truth[i]``'s music."""
    clips = [dataclasses.replace(t, motion=m, fps=fps, meta={}) for t, m in zip(truth, motions)]
    bas = METRICS.build("bas", {})(clips)["bas"]
    f1 = METRICS.build("kinematic_beat_scores", {})(clips, list(truth))
    f1_fine = METRICS.build("kinematic_beat_scores", {"bin_seconds": 0.25})(clips, list(truth))
    return {
        "bas": float(bas),
        "f1": 100.0 * float(f1["kinematic_beat_scores.f1"]),
        "f1_025s": 100.0 * float(f1_fine["kinematic_beat_scores.f1"]),
        "onset_f1": float(motion_onset_f1s(truth, clips).mean()),
    }


def music_alignment(truth: Sequence[Clip], music: Sequence[np.ndarray], sr: int) -> dict[str, float]:
    """Beat scores (0.25-s bins, percent) of ``music[i]`` against ``truth[i]``'s music; onsets per clip."""
    clips = [dataclasses.replace(t, audio=a, sample_rate=sr, meta={}) for t, a in zip(truth, music)]
    scores = METRICS.build("beat_scores", {"bin_seconds": 0.25})(clips, list(truth))
    onsets = np.mean([onset_times(np.asarray(a), sr).size for a in music])
    return {
        "f1": 100.0 * float(scores["beat_scores.f1"]),
        "precision": 100.0 * float(scores["beat_scores.bcs"]),
        "recall": 100.0 * float(scores["beat_scores.bhs"]),
        "onsets_per_clip": float(onsets),
    }


def spread(motions: Sequence[np.ndarray]) -> float:
    """Mean over clips and joints of the per-joint std over time (pixels, both axes pooled)."""
    return float(np.mean([np.asarray(m, dtype=np.float64).std(axis=0).mean() for m in motions]))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("/tmp/momu_conditioning_study"))
    parser.add_argument("--set", nargs="*", default=[], help="extra config overrides (after SMALL)")
    parser.add_argument(
        "--cpu-preset", action="store_true", help="train at the cpu preset's sizes (no SMALL overrides)"
    )
    parser.add_argument(
        "--music", action="store_true", help="also score motion→music (θ_a) against the clips' music"
    )
    parser.add_argument("--eval-clips", type=int, default=6)
    parser.add_argument(
        "--splits",
        default="test,val",
        help="held-out splits the crops come from, in order (rounds 1-4 used test,val; "
        "choose settings on val only: a setting picked on test is tuned on the evaluation split)",
    )
    parser.add_argument("--seconds", type=float, default=4.0)
    parser.add_argument("--threads", type=int, default=2)
    parser.add_argument("--gen-seed", type=int, default=0, help="offset of the per-clip noise seeds")
    args = parser.parse_args()
    torch.set_num_threads(args.threads)
    logging.basicConfig(level=logging.WARNING)
    small = [] if args.cpu_preset else SMALL
    cfg = load_config(ROOT / "recipes" / "configs" / "momu.yaml", [*small, *args.set])
    method = build_component(cfg.method, "methods")
    dataset = build_component(cfg.dataset, "datasets")
    ctx = RunContext(
        accelerator=make_accelerator(RunConfig(tracker="none"), args.out, "study", {}), out_dir=args.out
    )
    t0 = time.perf_counter()
    model: MoMuModel = method.fit(ctx, dataset, to_container(cfg.dataset), int(cfg.seed))
    print(f"overrides: {' '.join(args.set) or '(none)'}")
    print(f"train_seconds: {time.perf_counter() - t0:.0f} ({ctx.trained})")

    truth: list[Clip] = []
    for split in args.splits.split(","):  # held-out clips, in the order given
        try:
            truth += eval_crops(dataset, split, args.eval_clips - len(truth), [args.seconds])
        except ValueError:
            pass
        if len(truth) >= args.eval_clips:
            break
    n = len(truth)
    perm = derangement(n)
    sr = int(truth[0].sample_rate or 0)
    conds = [np.asarray(t.audio) for t in truth] + [np.asarray(truth[perm[i]].audio) for i in range(n)]
    seeds = [args.gen_seed * 1000 + i for i in range(n)] * 2
    t0 = time.perf_counter()
    # model.music_to_motion, split open to also score the latents (the same calls)
    z_cond = [model.encode_music(a, sr) for a in conds]
    z_gen = model._cfg_sample("motion", z_cond, seeds, None)
    gen = [model.decode_motion(z) for z in z_gen]
    fps = model.rates.motion_fps
    print(f"generate_seconds: {time.perf_counter() - t0:.0f} for {2 * n} clips of {args.seconds} s")

    true_motion = [np.asarray(t.motion) for t in truth]
    recon = []
    for t in truth:
        z = model.encode_motion(np.asarray(t.motion), t.fps)
        recon.append(model.decode_motion(z))
    print(
        f"spread_px: data {spread(true_motion):.1f}  vae_recon {spread(recon):.1f}  "
        f"generated {spread(gen[:n]):.1f}"
    )
    z_true = [model.encode_motion(np.asarray(t.motion), t.fps) for t in truth]

    def latent_mse(zs: Sequence[torch.Tensor]) -> float:
        return float(np.mean([float(((z[: len(r)] - r[: len(z)]) ** 2).mean()) for z, r in zip(zs, z_true)]))

    print(
        f"latent_mse_to_clip_i (standardised; 2.0 = independent): right {latent_mse(z_gen[:n]):.3f}  "
        f"shuffled {latent_mse(z_gen[n:]):.3f}"
    )
    rows = {
        "ground_truth": alignment(truth, true_motion, truth[0].fps),
        "gt_shuffled": alignment(truth, [true_motion[perm[i]] for i in range(n)], truth[0].fps),
        "vae_recon": alignment(truth, recon, fps),
        "right_cond": alignment(truth, gen[:n], fps),
        "shuffled_cond": alignment(truth, gen[n:], fps),
    }
    for name, row in rows.items():
        print(f"{name:14s} " + "  ".join(f"{k} {v:6.3f}" for k, v in row.items()))
    if args.music:
        real = [np.asarray(t.audio) for t in truth]
        conditions = true_motion + [true_motion[perm[i]] for i in range(n)]
        music = model.motion_to_music(conditions, truth[0].fps, seeds)
        music_rows = {
            "real_shuffled": music_alignment(truth, [real[perm[i]] for i in range(n)], sr),
            "right_cond": music_alignment(truth, music[:n], model.rates.sample_rate),
            "shuffled_cond": music_alignment(truth, music[n:], model.rates.sample_rate),
        }
        for name, row in music_rows.items():
            print(f"music {name:14s} " + "  ".join(f"{k} {v:6.2f}" for k, v in row.items()))


if __name__ == "__main__":
    main()
