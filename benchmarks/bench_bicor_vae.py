"""BiCoR-VAE on synth_dance: two-stage training with and without the rhythmic contrastive loss.

Trains a small BiCoR-VAE (Table 8 structure, base width 16) on ``synth_dance`` (2D ``openpose14``
keypoints at 60 fps, 16 kHz music -> MoMu mel at 62.5 frames/s):

* stage 1 (MoMu Eq. 10): the mel VAE with L1 + 1e-5 KL + 0.5 LSGAN (two-step update, App. A.2);
* stage 2 (Eq. 11): the motion VAE with the music VAE frozen, once with the rhythmic contrastive
  loss (lambda4 = 1) and once without it (lambda4 = 0, Table 7 #3 "w/o RCL"), same seed and steps.

It then reports, on held-out clips, the reconstruction errors and the temporal-alignment retrieval
accuracy of the latents: ``K`` non-overlapping clips per test pair are max-pooled (Eq. 3) and every
music clip must find its own motion clip among the ``K`` by cosine similarity (chance = 1/K). Also
the parameter counts of the default and ``paper`` configurations and the time per training step.

Usage: ``python benchmarks/bench_bicor_vae.py [--clips 24] [--steps1 200] [--steps2 300]``.
Numbers depend on the seed and are not a reproduction of any paper table.
"""

from __future__ import annotations

import argparse
import copy
import time

import numpy as np
import torch

from momu.data.synth import SynthConfig, SynthDance
from momu.encoders.bicor_vae import (
    BiCoRVAE,
    BiCoRVAEConfig,
    build_bicor_vae,
    paper_bicor_vae_config,
    stage2_loss,
)
from momu.encoders.discriminator import MelDiscriminator, MelDiscriminatorConfig
from momu.encoders.vae import VAE1dConfig
from momu.features.audio import momu_mel
from momu.losses.gan import GANLoss, two_step_update
from momu.losses.rhythmic_contrastive import RhythmicContrastiveConfig, RhythmicContrastiveLoss, clip_max_pool
from momu.losses.vae import VAELoss

MEL_RATE = 16000 / 256  # MoMu App. B.2


def load_pairs(num_clips: int, seconds: float, seed: int) -> list[tuple[np.ndarray, np.ndarray]]:
    """(mel (80, F), motion (T, 14, 2)) per clip, motion resampled onto the mel frames (60 -> 62.5/s)."""
    data = SynthDance(
        SynthConfig(
            num_clips=num_clips, min_seconds=seconds, max_seconds=seconds, skeleton="openpose14", seed=seed
        )
    )
    pairs = []
    for i in range(len(data)):
        clip = data[i]
        assert clip.audio is not None and clip.sample_rate is not None and clip.motion is not None
        mel = momu_mel(clip.audio, clip.sample_rate)
        # Motion frame for every mel frame (nearest in time), so crops can be taken in mel frames.
        t = np.minimum(
            np.round(np.arange(mel.shape[1]) / MEL_RATE * clip.fps).astype(int), clip.num_frames - 1
        )
        pairs.append((mel.astype(np.float32), clip.motion[t].astype(np.float32)))
    return pairs


def normalise(
    pairs: list[tuple[np.ndarray, np.ndarray]], n_train: int
) -> list[tuple[torch.Tensor, torch.Tensor]]:
    mels = np.concatenate([m for m, _ in pairs[:n_train]], axis=1)
    mel_mu, mel_sd = mels.mean(), mels.std() + 1e-6
    mot = np.concatenate([x for _, x in pairs[:n_train]])
    mot_mu, mot_sd = mot.mean(axis=(0, 1)), mot.std(axis=(0, 1)) + 1e-6
    return [
        (torch.from_numpy((m - mel_mu) / mel_sd), torch.from_numpy((x - mot_mu) / mot_sd).float())
        for m, x in pairs
    ]


def batch(
    data: list[tuple[torch.Tensor, torch.Tensor]], size: int, frames: int, rng: np.random.Generator
) -> tuple[torch.Tensor, torch.Tensor]:
    mels, motions = [], []
    for i in rng.integers(len(data), size=size):
        mel, motion = data[i]
        a = int(rng.integers(mel.shape[1] - frames + 1))
        mels.append(mel[:, a : a + frames])
        motions.append(motion[a : a + frames])
    return torch.stack(mels), torch.stack(motions)


def retrieval(model: BiCoRVAE, data: list[tuple[torch.Tensor, torch.Tensor]], k: int, length: int) -> float:
    """Top-1 accuracy of matching each music clip to its motion clip among k non-overlapping clips."""
    hits, total = 0, 0
    with torch.no_grad():
        for mel, motion in data:
            q_m, q_a, _ = model.encode_pair(motion[None], mel[None])
            za, zm = q_a.mean[0], q_m.mean[0]
            starts = torch.arange(k) * (za.shape[0] // k)
            ca = torch.nn.functional.normalize(clip_max_pool(za, starts, length), dim=-1)
            cm = torch.nn.functional.normalize(clip_max_pool(zm, starts, length), dim=-1)
            hits += int((torch.argmax(ca @ cm.T, dim=1) == torch.arange(k)).sum())
            total += k
    return hits / total


def recon_errors(model: BiCoRVAE, data: list[tuple[torch.Tensor, torch.Tensor]]) -> tuple[float, float]:
    mel_err, mot_err = [], []
    with torch.no_grad():
        for mel, motion in data:
            q_a = model.encode_music(mel[None])
            mel_err.append(float((model.decode_music(q_a.mean, mel.shape[1]) - mel[None]).abs().mean()))
            aligned = model.align_motion(motion[None], q_a.shape[1])
            q_m = model.motion_vae.encode(aligned)
            mot_err.append(float((model.decode_motion(q_m.mean, aligned.shape[1]) - aligned).abs().mean()))
    return float(np.mean(mel_err)), float(np.mean(mot_err))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--clips", type=int, default=24)
    ap.add_argument("--seconds", type=float, default=8.0)
    ap.add_argument("--steps1", type=int, default=200)
    ap.add_argument("--steps2", type=int, default=300)
    ap.add_argument("--batch", type=int, default=8)
    ap.add_argument("--frames", type=int, default=128, help="mel frames per training crop")
    ap.add_argument("--k", type=int, default=8, help="clips per test pair for retrieval")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--threads", type=int, default=1)
    args = ap.parse_args()
    torch.set_num_threads(args.threads)
    torch.manual_seed(args.seed)

    default = build_bicor_vae(BiCoRVAEConfig())
    paper = build_bicor_vae(paper_bicor_vae_config())
    print(
        f"parameters: default config {sum(p.numel() for p in default.parameters()) / 1e6:.2f}M, "
        f"paper preset {sum(p.numel() for p in paper.parameters()) / 1e6:.1f}M (Table 8: 213M)"
    )
    del default, paper

    t0 = time.perf_counter()
    raw = load_pairs(args.clips, args.seconds, args.seed)
    n_train = int(0.75 * len(raw))
    data = normalise(raw, n_train)
    train, test = data[:n_train], data[n_train:]
    print(
        f"data: {len(train)} train / {len(test)} test clips of {args.seconds:.0f} s "
        f"({time.perf_counter() - t0:.1f} s)"
    )

    small = VAE1dConfig(base_channels=16)
    model = build_bicor_vae(BiCoRVAEConfig(motion=small, music=small))
    rng = np.random.default_rng(args.seed)

    # Stage 1: mel VAE + GAN (Eq. 10).
    disc = MelDiscriminator(MelDiscriminatorConfig(channels=16))
    opt_v = torch.optim.AdamW(model.music_vae.parameters(), lr=1e-3)
    opt_d = torch.optim.AdamW(disc.parameters(), lr=1e-3)
    vae_loss, gan_loss = VAELoss(), GANLoss()
    t0 = time.perf_counter()
    for step in range(args.steps1):
        mel, _ = batch(train, args.batch, args.frames, rng)
        log = two_step_update(
            model.music_vae,
            disc,
            mel,
            vae_loss=vae_loss,
            gan_loss=gan_loss,
            vae_optimizer=opt_v,
            discriminator_optimizer=opt_d,
            step=step,
        )
    per1 = (time.perf_counter() - t0) / max(args.steps1, 1)
    print(
        f"stage 1: {args.steps1} steps, {per1 * 1e3:.0f} ms/step, last recon L1 {log['reconstruction']:.3f}, "
        f"D {log['discriminator']:.3f}, G {log['generator']:.3f}"
    )
    model.freeze_music()

    # Stage 2 (Eq. 11), with and without the rhythmic contrastive loss, from the same initial state.
    results = {}
    for name, weight in (("with RCL (lambda4=1)", 1.0), ("w/o RCL (lambda4=0)", 0.0)):
        m = copy.deepcopy(model)
        torch.manual_seed(args.seed + 1)
        rng2 = np.random.default_rng(args.seed + 1)
        contrastive = RhythmicContrastiveLoss(RhythmicContrastiveConfig(weight=weight))
        opt = torch.optim.AdamW(m.trainable_parameters(), lr=1e-3)
        g = torch.Generator().manual_seed(args.seed)
        t0 = time.perf_counter()
        for _ in range(args.steps2):
            mel, motion = batch(train, args.batch, args.frames, rng2)
            out = stage2_loss(m, motion, mel, vae_loss=vae_loss, contrastive=contrastive, generator=g)
            opt.zero_grad()
            out["loss"].backward()
            opt.step()
        per2 = (time.perf_counter() - t0) / max(args.steps2, 1)
        m.eval()
        acc = retrieval(m, test, args.k, length=8)
        mel_err, mot_err = recon_errors(m, test)
        results[name] = (acc, mel_err, mot_err, float(out["contrast"].detach()), per2)

    print(f"\nheld-out ({len(test)} clips, {args.k} clips each; retrieval chance = {1 / args.k:.3f})")
    print(
        f"{'stage 2':<22} {'retrieval top-1':>16} {'mel L1':>8} {'motion L1':>10} "
        f"{'train L_contrast':>17} {'ms/step':>8}"
    )
    for name, (acc, mel_err, mot_err, con, per2) in results.items():
        print(f"{name:<22} {acc:>16.3f} {mel_err:>8.3f} {mot_err:>10.3f} {con:>17.3f} {per2 * 1e3:>8.0f}")


if __name__ == "__main__":
    main()
