"""The ``momu`` method: parts, stage keys, a tiny end-to-end train + generate, save/load, the CLI."""

from __future__ import annotations

import copy
import dataclasses
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest
import soundfile as sf
import torch
from safetensors.torch import load_file, save_file
from torch import nn

from momu.config import build_component, load_config, to_container
from momu.encoders.vae import VAE1dConfig
from momu.engine import RunConfig, make_accelerator
from momu.engine.context import RunContext
from momu.losses.gan import GANLoss, GANLossConfig, two_step_update
from momu.losses.vae import VAELoss
from momu.methods.momu import MoMu, MoMuModel, backbone_node
from momu.methods.momu.data import MoMuNormalizers, crop_clip, eval_crops
from momu.methods.momu.scoring import beat_onset_f1, derangement, eval_lengths
from momu.methods.momu.stages import MusicVAEStage
from momu.registry import BACKBONES

TINY_VAE = {
    "latent_channels": 4,
    "base_channels": 8,
    "channel_mult": [1, 2],
    "num_res_blocks": 1,
    "attention_layers": 0,
    "attention_heads": 2,
    "norm_groups": 4,
}
TINY_DIT = {"name": "dit", "hidden": 16, "heads": 2, "depth": 1, "cond_embed_dim": 16, "max_length": 128}
STEPS = {"steps": 2, "batch_size": 4}


def tiny_config(**method: object) -> dict:
    node = {
        "name": "momu",
        "encoder": {"name": "bicor_vae", "motion": TINY_VAE, "music": TINY_VAE},
        "discriminator_encoder": {
            "name": "mel_discriminator",
            "channels": 4,
            "num_layers": 1,
            "norm_groups": 4,
        },
        "contrastive_loss": {
            "name": "rhythmic_contrastive",
            "num_clips": 4,
            "num_categories": 2,
            "num_samples": 2,
            "clip_length": 2,
        },
        "music_backbone": TINY_DIT,
        "motion_backbone": TINY_DIT,
        "sampler": {"name": "cfg", "num_inference_steps": 3},
        "joint_sampler": {"name": "cross_guidance", "num_inference_steps": 3},
        "vocoder": {"name": "griffin_lim", "n_iter": 2},
        "window_seconds": 1.0,
        "window_hop_seconds": 1.0,
        "train_music_vae": STEPS,
        "train_motion_vae": STEPS,
        "train_diffusion": STEPS,
        **method,
    }
    return {
        "seed": 0,
        "dataset": {
            "name": "synth_dance",
            "skeleton": "openpose14",
            "num_clips": 9,
            "min_seconds": 2.0,
            "max_seconds": 2.0,
        },
        "method": node,
    }


@pytest.fixture(scope="module")
def trained(tmp_path_factory: pytest.TempPathFactory) -> tuple[RunContext, MoMuModel, object, dict]:
    torch.set_num_threads(1)
    out = tmp_path_factory.mktemp("momu_run")
    cfg = load_config(tiny_config())
    ctx = RunContext(accelerator=make_accelerator(RunConfig(tracker="none"), out, "test", {}), out_dir=out)
    dataset = build_component(cfg.dataset, "datasets")
    method = build_component(cfg.method, "methods")
    model = method.fit(ctx, dataset, to_container(cfg.dataset), 0)
    return ctx, model, dataset, cfg


# ---------------------------------------------------------------- parts and config
def test_method_builds_from_registry_defaults() -> None:
    cfg = load_config({"method": {"name": "momu"}})
    method = build_component(cfg.method, "methods")
    assert isinstance(method, MoMu)
    assert cfg.method.encoder.name == "bicor_vae" and cfg.method.joint_sampler.gamma == 0.5
    assert cfg.method.vae_loss.kl_weight == 1e-5 and cfg.method.gan_loss.weight == 0.5  # λ1, λ2
    assert cfg.method.contrastive_loss.weight == 1.0  # λ4


def test_bad_method_values_are_named() -> None:
    with pytest.raises(ValueError, match="method.evaluation.task"):
        build_component({"name": "momu", "evaluation": {"task": "both"}}, "methods")
    with pytest.raises(ValueError, match="min_seconds"):
        build_component(
            {"name": "momu", "evaluation": {"variable_length": True, "min_seconds": 9.0, "seconds": 4.0}},
            "methods",
        )


def test_backbone_channels_come_from_the_latent_width() -> None:
    assert backbone_node({"name": "dit", "in_channels": 99}, 7)["in_channels"] == 7
    node = backbone_node("unet1d", 5)
    assert node["in_channels"] == 5 and node["cond_channels"] == 5

    @dataclass
    class PlainConfig:
        width: int = 3

    BACKBONES.register("test_plain_backbone", config=PlainConfig)(lambda cfg, **deps: nn.Identity())
    try:
        assert backbone_node({"name": "test_plain_backbone"}, 5) == {"name": "test_plain_backbone"}
    finally:
        BACKBONES.unregister("test_plain_backbone")


def test_stage_keys_share_exactly_what_table7_rows_share() -> None:
    data = {"name": "synth_dance"}

    def keys(**method: object) -> dict:
        cfg = load_config(tiny_config(**method))
        return build_component(cfg.method, "methods").stage_keys(data, 0)

    base = keys()
    no_rcl = keys(contrastive_loss=None)
    unet = keys(music_backbone={"name": "unet1d", "base_channels": 8, "norm_groups": 4, "heads": 2})
    directional = keys(
        encoder={
            "name": "bicor_vae",
            "music": TINY_VAE,
            "motion_encoder": {"name": "directional_vector", "vae": TINY_VAE},
        }
    )
    joint = keys(
        evaluation={"task": "joint", "variable_length": True},
        joint_sampler={"name": "cross_guidance", "gamma": 0.9},
    )
    assert joint == base  # #5-#7 and Table 10 share every stage
    assert no_rcl["music_vae"] == base["music_vae"] and no_rcl["motion_vae"] != base["motion_vae"]  # #3
    assert (
        directional["music_vae"] == base["music_vae"] and directional["motion_vae"] != base["motion_vae"]
    )  # #1
    assert unet["motion_vae"] == base["motion_vae"] and unet["diffusion"] != base["diffusion"]  # #4
    other_seed = build_component(load_config(tiny_config()).method, "methods").stage_keys(data, 1)
    other_data = build_component(load_config(tiny_config()).method, "methods").stage_keys({"name": "x"}, 0)
    assert all(other_seed[k] != base[k] and other_data[k] != base[k] for k in base)


def test_stage1_single_step_equals_the_two_step_gan_update() -> None:
    """MusicVAEStage + one AdamW over both networks == App. A.2's VAE step then discriminator step."""
    from momu.encoders.bicor_vae import MelVAE
    from momu.encoders.discriminator import MelDiscriminator, MelDiscriminatorConfig

    torch.manual_seed(0)
    vae = MelVAE(8, VAE1dConfig(**TINY_VAE))
    disc = MelDiscriminator(MelDiscriminatorConfig(mel_bins=8, channels=4, num_layers=1, norm_groups=4))
    mel = torch.randn(3, 8, 12)
    vae2, disc2 = copy.deepcopy(vae), copy.deepcopy(disc)
    opt_v = torch.optim.AdamW(vae.parameters(), lr=1e-2)
    opt_d = torch.optim.AdamW(disc.parameters(), lr=1e-2)
    torch.manual_seed(5)
    ref = two_step_update(
        vae,
        disc,
        mel,
        vae_loss=VAELoss(),
        gan_loss=GANLoss(GANLossConfig()),
        vae_optimizer=opt_v,
        discriminator_optimizer=opt_d,
        step=0,
    )
    stage = MusicVAEStage(vae2, disc2, VAELoss(), GANLoss(GANLossConfig()))
    opt = torch.optim.AdamW([p for p in stage.parameters() if p.requires_grad], lr=1e-2)
    torch.manual_seed(5)
    loss, logs = stage({"mel": mel})
    opt.zero_grad()
    loss.backward()
    opt.step()
    assert logs["discriminator"] == pytest.approx(ref["discriminator"], rel=1e-5)
    assert logs["generator_weight"] == pytest.approx(ref["generator_weight"], rel=1e-5)
    for a, b in zip([*vae.parameters(), *disc.parameters()], [*vae2.parameters(), *disc2.parameters()]):
        torch.testing.assert_close(a, b, rtol=1e-5, atol=1e-6)


# ---------------------------------------------------------------- data helpers
def test_motion_normaliser_is_a_similarity_transform() -> None:
    from momu.data.synth import SynthDance, SynthDanceConfig

    clips = [
        SynthDance(SynthDanceConfig(num_clips=3, skeleton="openpose14", min_seconds=2, max_seconds=2))[i]
        for i in range(3)
    ]
    norms = MoMuNormalizers.fit(clips, 16000)
    m = clips[0].motion
    z = norms.motion.transform(m)
    bone = lambda x: x[:, 2] - x[:, 1]  # noqa: E731  (a shoulder-neck vector)
    ratio = np.linalg.norm(bone(z), axis=-1) / np.linalg.norm(bone(m), axis=-1)
    assert np.allclose(ratio, ratio[0]) and np.allclose(norms.motion.inverse(z), m, atol=1e-3)


def test_crops_and_eval_lengths() -> None:
    from momu.data.synth import SynthDance, SynthDanceConfig

    ds = SynthDance(SynthDanceConfig(num_clips=9, skeleton="openpose14", min_seconds=3, max_seconds=3))
    clip = crop_clip(ds[0], 1.5, start=0.5)
    assert clip.motion.shape[0] == 90 and clip.audio.shape[0] == 24000
    assert all(0 <= t < 1.5 for t in clip.meta["beat_times"])
    crops = eval_crops(ds, "test", 2, [1.0, 2.0])
    assert [round(c.duration, 3) for c in crops] == [1.0, 2.0]

    class Ev:
        variable_length, seconds, min_seconds, num_clips = True, 3.0, 1.0, 5

    lengths = eval_lengths(Ev(), 0)
    assert len(lengths) == 5 and all(1.0 <= s <= 3.0 for s in lengths) and len(set(lengths)) == 5
    assert eval_lengths(Ev(), 0) == lengths


def test_split_indices_of_synth_dance_come_from_the_index_without_generating_clips() -> None:
    from momu.data.synth import SynthDance, SynthDanceConfig
    from momu.methods.momu.data import count_split, select_split

    class Counted(SynthDance):
        generated = 0

        def __getitem__(self, index: int):  # type: ignore[no-untyped-def]
            Counted.generated += 1
            return super().__getitem__(index)

    ds = Counted(
        SynthDanceConfig(num_clips=12, skeleton="openpose14", min_seconds=1, max_seconds=1, styles=["techno"])
    )
    fast = {split: select_split(ds, split) for split in ("train", "val", "test")}
    assert Counted.generated == 0 and count_split(ds, "test") == len(fast["test"]) > 0
    clips = [ds[i] for i in range(len(ds))]  # the generating path: each clip's own split
    expected = {s: [i for i, c in enumerate(clips) if c.meta["split"] == s] for s in fast}
    assert fast == expected and sorted(sum(fast.values(), [])) == list(range(12))
    # split_at promises every clip carries motion, audio and text (what MoMu and MoFusion select on)
    assert all(c.motion is not None and c.audio is not None and c.text for c in clips)
    # a dataset without split_at is read clip by clip: no split means train, a missing modality drops it
    assert [clips[i].meta["split"] for i in (0, 3, 2)] == ["train", "train", "test"]
    plain = [clips[0], dataclasses.replace(clips[3], audio=None), dataclasses.replace(clips[2], meta={})]
    assert select_split(plain, "train") == [0, 2] and select_split(plain, "test") == []


def test_beat_onset_f1_by_hand() -> None:
    assert beat_onset_f1([1.0, 2.0, 3.0], [1.02, 2.5]) == pytest.approx(2 * 0.5 * (1 / 3) / (0.5 + 1 / 3))
    assert beat_onset_f1([1.0], [1.0, 1.01]) == pytest.approx(2 * 0.5 * 1 / 1.5)  # one-to-one matching
    assert beat_onset_f1([], [1.0]) == 0.0
    assert derangement(3) == [1, 2, 0] and all(i != p for i, p in enumerate(derangement(5)))


# ---------------------------------------------------------------- end to end
def test_fit_trains_three_stages_and_reuses_them(trained) -> None:
    ctx, model, dataset, cfg = trained
    assert sorted(name.split("-")[0] for name in ctx.trained) == ["diffusion", "motion_vae", "music_vae"]
    rerun = RunContext(accelerator=ctx.accelerator, out_dir=ctx.out_dir)  # a later run, same output folder
    again = build_component(cfg.method, "methods").fit(rerun, dataset, to_container(cfg.dataset), 0)
    assert set(rerun.trained.values()) == {"reused"} and len(rerun.trained) == 3
    for a, b in zip(model.motion_backbone.state_dict().values(), again.motion_backbone.state_dict().values()):
        torch.testing.assert_close(a, b)
    assert model.vae.music_frozen  # stage 2 froze the music VAE (Eq. 11)


def test_generation_shapes_rates_and_per_item_determinism(trained) -> None:
    _, model, dataset, _ = trained
    clip = dataset[6]  # a test clip
    rates = model.rates
    assert rates.latent_rate == pytest.approx(31.25) and rates.motion_fps == pytest.approx(62.5)
    audio = clip.audio[:16000]
    motions = model.music_to_motion([audio, clip.audio[:8000]], 16000, [3, 4])
    assert motions[0].shape == (62, 14, 2) and motions[1].shape == (30, 14, 2)
    assert all(np.isfinite(m).all() for m in motions)
    alone = model.music_to_motion([audio], 16000, [3])[0]
    np.testing.assert_allclose(alone, motions[0], atol=1e-4)  # independent of batching and padding
    music = model.motion_to_music([clip.motion[:60]], 60.0, [1])[0]
    assert music.ndim == 1 and abs(len(music) - 16000) <= 512 and np.abs(music).max() <= 1.0
    pairs = model.joint([1.0, 0.6], [1, 2])
    assert [m.shape[0] for _, m in pairs] == [62, 36]
    assert [abs(len(a) / 16000 - s) < 0.05 for (a, _), s in zip(pairs, [1.0, 0.6])] == [True, True]


def test_stochastic_sampling_depends_on_the_seed_only(trained) -> None:
    _, model, dataset, _ = trained
    clip = dataset[6]
    saved = dict(model._samplers)
    ddpm = build_component(
        {"name": "cfg", "num_inference_steps": 4, "scheduler": {"name": "ddpm"}}, "samplers"
    )
    model._samplers.update(music=ddpm, motion=ddpm)
    try:
        batch = model.music_to_motion([clip.audio[:16000], clip.audio[:8000]], 16000, [3, 4])
        torch.manual_seed(123)  # the global RNG plays no part
        alone = model.music_to_motion([clip.audio[:16000]], 16000, [3])[0]
        other = model.music_to_motion([clip.audio[:16000]], 16000, [5])[0]
        music = model.motion_to_music([clip.motion[:60], clip.motion[:30]], 60.0, [1, 2])
        music_alone = model.motion_to_music([clip.motion[:60]], 60.0, [1])[0]
    finally:
        model._samplers.clear()
        model._samplers.update(saved)
    np.testing.assert_allclose(alone, batch[0], atol=1e-4)
    assert not np.allclose(alone, other, atol=1e-3)
    np.testing.assert_allclose(music_alone, music[0], atol=1e-4)


def test_each_direction_can_have_its_own_sampler(trained) -> None:
    _, model, dataset, _ = trained
    clip = dataset[6]
    audio, motion = clip.audio[:16000], clip.motion[:60]
    default = model.music_to_motion([audio], 16000, [3])[0]  # cfg.sampler
    explicit = model.music_to_motion([audio], 16000, [3], guidance_scale=5.0)[0]
    music_default = model.motion_to_music([motion], 60.0, [1])[0]
    saved = (model.cfg.motion_sampler, dict(model._samplers))
    model.cfg.motion_sampler = {**dict(model.cfg.sampler), "guidance_scale": 5.0}
    model._samplers.clear()
    try:
        assert model.sampler_for("motion").cfg.guidance_scale == 5.0
        np.testing.assert_allclose(model.music_to_motion([audio], 16000, [3])[0], explicit, atol=1e-5)
        assert not np.allclose(explicit, default, atol=1e-3)
        np.testing.assert_allclose(model.motion_to_music([motion], 60.0, [1])[0], music_default, atol=1e-5)
    finally:
        model.cfg.motion_sampler = saved[0]
        model._samplers.clear()
        model._samplers.update(saved[1])


def test_save_load_round_trip_and_strict_loading(trained, tmp_path: Path) -> None:
    _, model, dataset, _ = trained
    folder = model.save(tmp_path / "model")
    assert (folder / "encoder" / "model.safetensors").is_file() and (folder / "mel_normalizer.json").is_file()
    loaded = MoMuModel.load(folder)
    audio = dataset[6].audio[:16000]
    np.testing.assert_allclose(
        loaded.music_to_motion([audio], 16000, [7])[0],
        model.music_to_motion([audio], 16000, [7])[0],
        atol=1e-5,
    )
    weights = folder / "motion_backbone" / "model.safetensors"
    state = load_file(str(weights))
    state.pop(next(iter(state)))
    save_file(state, str(weights))
    with pytest.raises(ValueError, match="missing keys"):
        MoMuModel.load(folder)
    with pytest.raises(FileNotFoundError, match="momu.json"):
        MoMuModel.load(tmp_path)


def test_generate_cli_dance_music_and_errors(
    trained, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from momu.cli import main

    _, model, dataset, _ = trained
    folder = model.save(tmp_path / "model")
    wav = tmp_path / "song.wav"
    sf.write(str(wav), dataset[6].audio[:16000], 16000)
    out = tmp_path / "dance.npz"
    argv = ["generate", "dance", "--model", str(folder), "--music", str(wav), "--out", str(out), "--quiet"]
    assert main(argv) == 0
    with np.load(out, allow_pickle=False) as data:
        motion = data["joints"]
        assert float(data["fps"]) == pytest.approx(62.5)
        assert str(data["skeleton"]) == "openpose14"
    assert motion.shape == (62, 14, 2)
    song = tmp_path / "gen.wav"
    assert main(["generate", "music", "--model", str(folder), "--motion", str(out), "--out", str(song)]) == 0
    assert sf.info(str(song)).samplerate == 16000
    # a 2D model cannot write BVH: refused before generating, nothing written
    code = main(
        ["generate", "dance", "--model", str(folder), "--music", str(wav), "--out", str(tmp_path / "d.bvh")]
    )
    assert code == 2 and "BVH needs a 3D model" in capsys.readouterr().err
    assert not (tmp_path / "d.bvh").exists()
    np.save(tmp_path / "bad.npy", np.zeros((10, 3, 2), dtype=np.float32))
    code = main(
        [
            "generate",
            "music",
            "--model",
            str(folder),
            "--motion",
            str(tmp_path / "bad.npy"),
            "--out",
            str(song),
        ]
    )
    assert code == 2 and "no registered skeleton has 3 joints" in capsys.readouterr().err


# ---------------------------------------------------------------- recipe specs
def test_table_rows_resolve_and_the_paper_preset_is_tables_8_9() -> None:
    from momu.engine.table import TableArgs, resolve_row_configs
    from momu.methods.momu.recipes import table7_spec, table10_spec

    spec10 = table10_spec()
    ten = resolve_row_configs(
        spec10, TableArgs("smoke", "synth", Path("x"), ["Tc=0.1T"], [], False, "none", [])
    )
    assert (
        ten["Tc=0.1T"].method.joint_sampler.gamma == 0.1 and ten["Tc=0.1T"].method.evaluation.task == "joint"
    )
    spec7 = table7_spec()
    paper = resolve_row_configs(
        spec7, TableArgs("paper", "synth", Path("x"), [r.id for r in spec7.rows], [], False, "none", [])
    )
    assert all(isinstance(build_component(cfg.method, "methods"), MoMu) for cfg in paper.values())
    enc = paper["#7"].method.encoder
    assert (enc.motion.latent_channels, enc.motion.base_channels, enc.motion.attention_layers) == (20, 192, 3)
    assert list(enc.music.downsample_levels) == [0]  # Table 8: one downsampling layer
    assert paper["#7"].method.discriminator_encoder.name == "mel_discriminator"
    dit = paper["#7"].method.motion_backbone
    assert (dit.hidden, dit.heads, dit.depth, dit.cond_embed_dim) == (576, 8, 4, 1024)  # Table 9
    assert paper["#7"].method.train_diffusion.lr == 1.6e-5  # App. B.3
    assert paper["#1"].method.encoder.motion_encoder.vae.base_channels == 192
    assert paper["#3"].method.contrastive_loss is None
    assert paper["#4"].method.music_backbone.name == "unet1d"
    assert paper["#6"].method.evaluation.variable_length
    # MoMu's own loss and metric in the paper preset; the cpu preset's departures are explicit
    assert paper["#7"].method.vae_loss.velocity_weight == 0.0  # Eq. 10-11: reconstruction + KL
    assert paper["#7"].method.evaluation.beat_bin_seconds == 1.0  # App. B.4-B.5: one-second bins
    assert enc.motion.padding_mode == "zeros"
    assert paper["#7"].method.train_diffusion.lr_schedule == "constant"  # App. B.3: warm-up, no decay
    assert paper["#7"].method.sampler.num_inference_steps == 50  # MoMu §5.1: 50 DDIM steps
    assert not paper["#7"].method.music_backbone.get("cond_add", False)  # the paper's token pathway only
    cpu = resolve_row_configs(spec7, TableArgs("cpu", "synth", Path("x"), ["#7"], [], False, "none", []))[
        "#7"
    ]
    assert cpu.method.evaluation.beat_bin_seconds == 0.25 and cpu.method.vae_loss.velocity_weight == 10.0
    assert cpu.method.encoder.motion.padding_mode == "replicate" and cpu.dataset.attack == 0.3
    assert cpu.method.train_diffusion.lr_schedule == "cosine"
    assert cpu.method.sampler.scheduler.name == "ddpm" and cpu.method.motion_sampler is None
    # θ_a wider and deeper than θ_m, each with its own guidance scale (paper preset: one sampler, Table 9 DiT)
    assert (cpu.method.music_backbone.hidden, cpu.method.music_backbone.depth) == (128, 4)
    assert cpu.method.music_sampler.guidance_scale == 5.0 and cpu.method.sampler.guidance_scale == 8.0
    assert paper["#7"].method.music_sampler is None
    assert cpu.method.music_backbone.cond_add and cpu.method.motion_backbone.cond_add


def test_variable_length_training_masks_prefixes_within_the_window_and_keys_the_stage() -> None:
    from momu.methods.momu.stages import DiffusionStage

    data = {"name": "synth_dance"}
    fixed = build_component(load_config(tiny_config()).method, "methods").stage_keys(data, 0)
    varied = build_component(load_config(tiny_config(train_min_seconds=0.5)).method, "methods").stage_keys(
        data, 0
    )
    assert varied["diffusion"] != fixed["diffusion"] and varied["motion_vae"] == fixed["motion_vae"]

    class Echo(nn.Module):  # records the masks the loss hands the backbone
        in_channels = cond_channels = 4

        def __init__(self) -> None:
            super().__init__()
            self.w = nn.Parameter(torch.zeros(()))
            self.masks: list[torch.Tensor] = []

        def forward(self, x, t, cond=None, *, x_mask=None, cond_mask=None, drop_cond=None):
            self.masks.append(x_mask)
            assert cond_mask is x_mask  # aligned latents: the condition keeps the same frames
            return x * self.w

    loss = build_component(
        {"name": "diffusion"}, "losses", scheduler=build_component({"name": "ddpm"}, "schedulers")
    )
    music, motion = Echo(), Echo()
    stage = DiffusionStage(music, motion, loss, 4, min_frames=3).train()
    torch.manual_seed(0)
    for _ in range(20):
        stage({"z_music": torch.randn(8, 10, 4), "z_motion": torch.randn(8, 10, 4)})
    lengths = torch.cat([m.sum(dim=1) for m in music.masks])
    assert int(lengths.min()) >= 3 and int(lengths.max()) == 10 and len(set(lengths.tolist())) > 4
    assert all(bool((m[:, :-1] >= m[:, 1:]).all()) for m in music.masks)  # valid frames first
    stage.eval()
    assert stage.length_mask(8, 10, torch.device("cpu")) is None  # evaluation sees whole windows


def test_per_batch_lengths_cut_every_item_to_one_length_without_a_mask() -> None:
    from momu.methods.momu.stages import DiffusionStage

    data = {"name": "synth_dance"}
    per_item = build_component(load_config(tiny_config(train_min_seconds=0.5)).method, "methods")
    per_batch = build_component(
        load_config(tiny_config(train_min_seconds=0.5, train_lengths="batch")).method, "methods"
    )
    assert per_item.stage_keys(data, 0)["diffusion"] != per_batch.stage_keys(data, 0)["diffusion"]

    class Record(nn.Module):  # records the shapes and masks the loss hands the backbone
        in_channels = cond_channels = 4

        def __init__(self) -> None:
            super().__init__()
            self.w = nn.Parameter(torch.zeros(()))
            self.calls: list[tuple[int, int, object]] = []

        def forward(self, x, t, cond=None, *, x_mask=None, cond_mask=None, drop_cond=None):
            self.calls.append((x.shape[1], cond.shape[1], x_mask))
            return x * self.w

    loss = build_component(
        {"name": "diffusion"}, "losses", scheduler=build_component({"name": "ddpm"}, "schedulers")
    )
    music, motion = Record(), Record()
    stage = DiffusionStage(music, motion, loss, 4, min_frames=3, per_batch=True).train()
    torch.manual_seed(0)
    for _ in range(40):
        stage({"z_music": torch.randn(8, 10, 4), "z_motion": torch.randn(8, 10, 4)})
    lengths = [n for n, _, _ in music.calls]
    assert all(n == c and mask is None for n, c, mask in music.calls + motion.calls)  # no padding
    assert [n for n, _, _ in motion.calls] == lengths  # θ_a and θ_m see the same frames
    assert min(lengths) == 3 and max(lengths) == 10 and len(set(lengths)) >= 6  # uniform on [3, 10]
    stage.eval()
    assert stage.batch_length(10) == 10  # evaluation sees whole windows


def test_train_lengths_must_be_item_or_batch() -> None:
    with pytest.raises(ValueError, match="method.train_lengths"):
        build_component(load_config(tiny_config(train_lengths="clip")).method, "methods")
