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


def tiny_mofusion_model(folder: Path, task: str = "music") -> Path:
    """A MoFusion model with random weights (a tiny 1D U-Net; ``task`` ``music`` on smpl24 or ``text`` on
    humanml22), saved to ``folder``: built, not trained, so it takes well under a second."""
    import numpy as np
    import torch

    from momu.config import build_component
    from momu.encoders.text_transformer import WordTokenizer
    from momu.features.preprocess import Normalizer
    from momu.methods.mofusion.data import MoFusionNormalizers
    from momu.methods.mofusion.model import MoFusionModel
    from momu.registry import METHODS

    torch.manual_seed(0)
    ddim = {"name": "ddim", "num_inference_steps": 2}
    unet = {"name": "unet1d", "base_channels": 8, "heads": 2, "cross_attention_dim": 16, "norm_groups": 4}
    if task == "text":
        unet |= {"cond_proj": "mlp", "context_positions": False}
    method = METHODS.build(
        "mofusion",
        {
            "task": task,
            "backbone": unet,
            "text_encoder": {"name": "text_transformer", "width": 8, "heads": 2, "depth": 1},
            "sampler": {"name": "cfg", "guidance_scale": 1.0, "scheduler": ddim},
            "inpainting_sampler": {"name": "inpainting", "guidance_scale": 1.0, "scheduler": ddim},
        },
    )
    skeleton = "humanml22" if task == "text" else "smpl24"
    text_node, text_encoder, width = None, None, 0
    if task == "text":
        vocab = WordTokenizer.from_texts(["a person walks forward and jumps"], 16).vocab
        text_node = {"name": "text_transformer", "width": 8, "heads": 2, "depth": 1, "vocab": vocab}
        text_encoder = build_component(text_node, "encoders")
        width = int(text_encoder.width)
    backbone_node, _ = method.nodes(skeleton, text_node, width)
    channels = int(backbone_node["in_channels"])
    rng = np.random.default_rng(0)
    pose = Normalizer(rng.normal(0, 0.1, channels), np.full(channels, 0.2))
    mel = Normalizer(np.full(80, -4.0), np.full(80, 2.0)) if task == "music" else None
    model = MoFusionModel(
        cfg=method.cfg,
        backbone=build_component(backbone_node, "backbones"),
        norms=MoFusionNormalizers(pose, mel),
        skeleton=skeleton,
        backbone_node=backbone_node,
        text_encoder=text_encoder,
        text_encoder_node=text_node,
    )
    return model.save(folder)


def tiny_harmogan_model(folder: Path) -> Path:
    """A HarmoGAN model (dwm21, 15 fps) with a tiny random generator, saved to ``folder``."""
    import numpy as np
    import torch

    from momu.features.skeletons import get_skeleton
    from momu.methods.harmogan.config import HarmoGANConfig
    from momu.methods.harmogan.data import MfccStats
    from momu.methods.harmogan.model import HarmoGANModel
    from momu.registry import ENCODERS

    torch.manual_seed(0)
    cfg = HarmoGANConfig()
    generator = ENCODERS.build("harmogan_generator", {"hidden": 16, "noise_dim": 4})
    stats = MfccStats(np.zeros(cfg.mfcc.n_mfcc), np.full(cfg.mfcc.n_mfcc, 50.0))
    joints = get_skeleton("dwm21").num_joints
    mean_pose = np.random.default_rng(0).normal(0, 0.3, (joints, 3)).astype(np.float32)
    return HarmoGANModel(cfg, generator, stats, mean_pose).save(folder)
