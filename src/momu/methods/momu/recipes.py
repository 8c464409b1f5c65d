"""What the MoMu-Diffusion table recipes share: base config, presets, columns, table specs.

``recipes/momu_table7.py`` and ``recipes/momu_table10.py`` are thin scripts over
:func:`table7_spec` / :func:`table10_spec` and :func:`momu.engine.table.run_table`.

Presets (overrides over ``recipes/configs/momu.yaml``, whose values are the ``cpu`` preset):

* ``smoke`` — every row end-to-end in seconds: a dozen 3 s clips, tiny VAEs and DiTs, a few
  optimiser steps, 4 sampling steps, 1-epoch extractors. The numbers mean nothing.
* ``cpu`` — ``recipes/configs/momu.yaml`` as is: synth_dance (openpose14, 640 clips of 8 s, moves
  starting sharply on the beat; 64 evaluation clips), 4 s windows with 2–4 s variable-length
  diffusion items (one length per batch), small VAEs (latent 16, no attention, latent rate 15.6 Hz,
  replicate padding, no GAN term; sum-reduced reconstruction with a velocity term for the motion
  VAE) and DiTs (θ_m width 64, depth 2; θ_a width 128, depth 4), 120 music-VAE, 1200 motion-VAE and
  4000 diffusion steps (cosine learning-rate decay) per row; θ_a and θ_m with the frame-aligned
  condition shortcut (``cond_add``, aligned positions); CFG sampling with DDPM clipped to ±4,
  guidance scale 5 for motion→music and 8 for music→motion, and the joint rows sampled the same way;
  F1 columns in 0.25-s beat bins (one-second bins saturate on this music); 16-d FID/FAD features.
* ``paper`` — its own complete file, ``recipes/configs/momu_paper.yaml``: every value of MoMu
  Tables 8–9, §4–5 and App. A–E pinned explicitly (nothing inherited from the cpu preset), the
  paper's silences marked as choices. ``docs/presets.md`` lists every departure of the cpu preset.
"""

from __future__ import annotations

from pathlib import Path

from momu.engine.table import Column, Row, TableSpec
from momu.methods.momu.evaluate import calibrate_momu, check_rows, evaluate_momu

__all__ = ["BASE_CONFIG", "PRESETS", "PRESET_CONFIGS", "COLUMNS", "table7_spec", "table10_spec"]

SHARED_DIR = "momu_shared"
"""Folder under ``--out`` whose ``parts/`` caches the stages every MoMu table trains (Tables 2–7, 10)."""

BASE_CONFIG = Path(__file__).resolve().parents[4] / "recipes" / "configs" / "momu.yaml"
"""The ``cpu`` preset (``smoke`` overrides it); :func:`paper_config` is the ``paper`` preset."""


def paper_config(base_config: str | Path = BASE_CONFIG) -> Path:
    """The ``paper`` preset's YAML beside ``base_config`` (``momu_paper.yaml``)."""
    return Path(base_config).with_name("momu_paper.yaml")


_TINY_VAE = (
    "{latent_channels: 8, base_channels: 8, channel_mult: [1, 2], num_res_blocks: 1, attention_layers: 1,"
    " attention_heads: 2, norm_groups: 4}"
)
_TINY_DIT = (
    "{name: dit, hidden: 32, heads: 2, depth: 1, cond_embed_dim: 32, max_length: 256, cond_add: true, "
    "cond_tokens: false, positions: aligned}"
)

PRESETS: dict[str, list[str]] = {
    "smoke": [
        "dataset.num_clips=9",
        "dataset.min_seconds=3.0",
        "dataset.max_seconds=3.0",
        "method.window_seconds=1.0",
        "method.window_hop_seconds=0.5",
        "method.train_min_seconds=0.5",
        f"method.encoder.motion={_TINY_VAE}",
        f"method.encoder.music={_TINY_VAE}",
        "method.discriminator_encoder={name: mel_discriminator, channels: 4, num_layers: 1, norm_groups: 4}",
        "method.contrastive_loss.num_clips=4",
        "method.contrastive_loss.num_categories=2",
        "method.contrastive_loss.num_samples=2",
        "method.contrastive_loss.clip_length=2",
        f"method.music_backbone={_TINY_DIT}",
        f"method.motion_backbone={_TINY_DIT}",
        "method.sampler.num_inference_steps=4",
        "method.music_sampler=null",  # both directions sample with `sampler`
        "method.joint_sampler.music_guidance_scale=null",
        "method.vocoder.n_iter=2",
        "method.train_music_vae.steps=2",
        "method.train_music_vae.batch_size=4",
        "method.train_motion_vae.steps=2",
        "method.train_motion_vae.batch_size=4",
        "method.train_diffusion.steps=3",
        "method.train_diffusion.batch_size=4",
        "method.evaluation.num_clips=3",
        "method.evaluation.seconds=2.0",
        "method.evaluation.min_seconds=1.0",
        "method.evaluation.extractor_epochs=1",
        "method.evaluation.extractor_samples_per_clip=1",
    ],
    "cpu": [],
    # the paper preset is its own complete file (paper_config()): every value pinned, nothing inherited
    "paper": [],
}

PRESET_CONFIGS: dict[str, Path] = {"paper": paper_config()}
"""Presets that are complete files of their own (``momu train --preset paper`` as the tables)."""

COLUMNS = [
    Column("music_fad", "Music FAD↓", False),
    Column("music_f1", "Music F1↑", True, reducer="f1"),
    Column("motion_fid", "Motion FID↓", False),
    Column("motion_f1", "Motion F1↑", True, reducer="f1"),
]

_JOINT = ("method.evaluation.task=joint",)
# 0.46M parameters per denoiser (the cpu preset's DiTs have 0.95M (θ_a) and 0.17M (θ_m); at base
# width 32 the U-Net had 1.7M and trained 3x slower per step than the small DiT on a CPU)
_UNET = "{base_channels: 16, channel_mults: [1, 2, 4], heads: 4, cross_attention_dim: 64, norm_groups: 8}"

_TABLE7_NOTES = (
    "F1 is in percent like the paper; FAD/FID use feature extractors trained on this run's data "
    "(the paper uses VGGish and a MotionBERT classifier on its datasets), so only their ordering is "
    "comparable. At the cpu preset FID compares 64 clips' 16-d features and FAD 256 segments' 16-d "
    "embeddings (N >= 2d: full-rank covariances).",
    "Cross rows (#1–#4, #7): music F1 = beat scores of music generated from clip i's motion vs clip i's "
    "music; "
    "motion F1 = kinematic beats of motion generated from clip i's music vs that music.",
    "Joint rows (#5, #6): both modalities come from noise, so both F1 columns score the jointly generated "
    "music against the jointly generated motion (they agree up to truncation); compare them with the "
    "calibration motion F1 (ground-truth music vs its own motion).",
    "Verdicts: every F1 cell is compared, clip by clip on the same clips, with the shuffled calibration, "
    "with ground truth, and with the same model given another clip's condition (cross rows) or with "
    "mismatched generated pairs (joint rows); FAD/FID with this seed's real-vs-real floor. "
    "`rows[].comparisons` in results.json holds every interval.",
)


def table7_spec(base_config: str | Path = BASE_CONFIG) -> TableSpec:
    """MoMu Table 7: ablations on AIST++ (ours: synth_dance unless ``--data``)."""
    return TableSpec(
        name="momu_table7",
        title="MoMu-Diffusion Table 7: ablation study (motion→music and music→motion)",
        base_config=base_config,
        presets=PRESETS,
        preset_configs={"paper": paper_config(base_config)},
        columns=COLUMNS,
        rows=[
            Row(
                "#1",
                "Ours w/ directional vectors",
                (
                    "method.encoder.motion_encoder={name: directional_vector}",
                    "method.encoder.motion_encoder.vae=${method.encoder.motion}",
                ),
                {"music_fad": 10.9, "music_f1": 91.4, "motion_fid": 14.7, "motion_f1": 38.0},
            ),
            Row(
                "#2",
                "Ours w/o mel-spectrogram (waveform)",
                (
                    "method.encoder.music_encoder={name: waveform}",
                    "method.encoder.music_encoder.vae=${method.encoder.music}",
                ),
                {"music_fad": 12.8, "music_f1": 95.6, "motion_fid": 9.5, "motion_f1": 41.6},
            ),
            Row(
                "#3",
                "Ours w/o RCL",
                ("method.contrastive_loss=null",),
                {"music_fad": 8.5, "music_f1": 93.1, "motion_fid": 8.1, "motion_f1": 37.9},
            ),
            Row(
                "#4",
                "Ours w/o FFT (1D U-Net)",
                (
                    "method.music_backbone=unet1d",  # a bare name replaces the whole node
                    f"method.music_backbone={_UNET}",
                    "method.motion_backbone=unet1d",
                    f"method.motion_backbone={_UNET}",
                ),
                {"music_fad": 11.0, "music_f1": 95.8, "motion_fid": 11.6, "motion_f1": 41.4},
                # the paper gives no U-Net size: the registered unet1d (MoFusion's) at the paper preset
                preset_overrides={"paper": ("method.music_backbone=unet1d", "method.motion_backbone=unet1d")},
            ),
            Row(
                "#5",
                "Ours (joint generation)",
                _JOINT,
                {"music_fad": 8.1, "music_f1": 96.5, "motion_fid": 8.8, "motion_f1": 45.4},
            ),
            Row(
                "#6",
                "Ours (joint generation & variable length)",
                (*_JOINT, "method.evaluation.variable_length=true"),
                {"music_fad": 9.1, "music_f1": 97.6, "motion_fid": 8.5, "motion_f1": 49.6},
            ),
            Row(
                "#7",
                "Ours (cross generation)",
                (),
                {"music_fad": 8.9, "music_f1": 98.1, "motion_fid": 7.3, "motion_f1": 46.2},
            ),
        ],
        evaluate=evaluate_momu,
        calibrate=calibrate_momu,
        check=check_rows,
        shared_parts=SHARED_DIR,
        notes=_TABLE7_NOTES,
    )


_TABLE10 = {
    0.9: (14.8, 82.4, 17.3, 25.8),
    0.7: (10.9, 95.9, 9.7, 37.8),
    0.5: (8.1, 96.5, 8.8, 45.4),
    0.3: (7.5, 90.4, 9.0, 42.1),
    0.1: (8.0, 85.5, 9.5, 32.6),
}


def table10_spec(base_config: str | Path = BASE_CONFIG) -> TableSpec:
    """MoMu Table 10 (App. D): the cross-guidance step T_c = γT of joint generation."""
    rows = []
    for gamma, (fad, f1a, fid, f1m) in _TABLE10.items():
        rows.append(
            Row(
                f"Tc={gamma}T",
                f"MoMu-Diffusion (T_c = {gamma}T)",
                (*_JOINT, f"method.joint_sampler.gamma={gamma}"),
                {"music_fad": fad, "music_f1": f1a, "motion_fid": fid, "motion_f1": f1m},
            )
        )
    return TableSpec(
        name="momu_table10",
        title="MoMu-Diffusion Table 10: choice of the cross-guidance step T_c (joint generation)",
        base_config=base_config,
        presets=PRESETS,
        preset_configs={"paper": paper_config(base_config)},
        columns=COLUMNS,
        rows=rows,
        evaluate=evaluate_momu,
        calibrate=calibrate_momu,
        check=check_rows,
        shared_parts=SHARED_DIR,
        notes=(
            "Every row shares the same trained models (one training per run); rows differ only in γ.",
            *_TABLE7_NOTES[:1],
            _TABLE7_NOTES[2],
        ),
    )
