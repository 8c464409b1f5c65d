"""A tiny 3D MoMu model for tests that need one (seconds to train on a CPU; its output means nothing)."""

from __future__ import annotations

from pathlib import Path


def tiny_3d_model(folder: Path) -> Path:
    """A tiny dwm21 (3D) MoMu model trained for a few steps on synth_dance (seconds on a CPU)."""
    import torch

    from momu.config import build_component, load_config, to_container
    from momu.engine import RunConfig, make_accelerator
    from momu.engine.context import RunContext

    torch.set_num_threads(1)
    vae = {"latent_channels": 4, "base_channels": 8, "channel_mult": [1, 2], "num_res_blocks": 1}
    vae |= {"attention_layers": 0, "attention_heads": 2, "norm_groups": 4}
    dit = {"name": "dit", "hidden": 16, "heads": 2, "depth": 1, "cond_embed_dim": 16, "max_length": 128}
    steps = {"steps": 2, "batch_size": 4}
    cfg = load_config(
        {
            "seed": 0,
            "dataset": {"name": "synth_dance", "skeleton": "dwm21", "num_clips": 6, "min_seconds": 2.0},
            "method": {
                "name": "momu",
                "encoder": {
                    "name": "bicor_vae",
                    "num_joints": 21,
                    "joint_dims": 3,
                    "motion": vae,
                    "music": vae,
                },
                "discriminator_encoder": None,
                "contrastive_loss": None,
                "music_backbone": dit,
                "motion_backbone": dit,
                "sampler": {"name": "cfg", "num_inference_steps": 3},
                "vocoder": {"name": "griffin_lim", "n_iter": 2},
                "window_seconds": 1.0,
                "window_hop_seconds": 0.5,
                "train_music_vae": steps,
                "train_motion_vae": steps,
                "train_diffusion": steps,
            },
        }
    )
    ctx = RunContext(accelerator=make_accelerator(RunConfig(tracker="none"), folder, "t", {}), out_dir=folder)
    dataset = build_component(cfg.dataset, "datasets")
    model = build_component(cfg.method, "methods").fit(ctx, dataset, to_container(cfg.dataset), 0)
    return model.save(folder / "model")
