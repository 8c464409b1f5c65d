"""The MoMu-Diffusion presets: the paper preset pins every paper value, runs at paper lengths, and the
documented departures of the cpu preset are exactly the configs' differences."""

from __future__ import annotations

from pathlib import Path

import pytest
import torch

from momu.config import build_component, load_config
from momu.engine.table import parse_table_args, resolve_row_configs
from momu.methods.momu.config import backbone_node, vocoder_node
from momu.methods.momu.data import Rates
from momu.methods.momu.presets_doc import presets_page
from momu.methods.momu.recipes import paper_config, table7_spec, table10_spec
from momu.methods.momu.tables import TABLE_SPECS
from momu.training import train_config

ROOT = Path(__file__).resolve().parents[2]


def _rows(spec, preset: str) -> dict:
    return resolve_row_configs(spec, parse_table_args(spec, ["--preset", preset]))


def test_paper_preset_is_its_own_file_with_nothing_inherited() -> None:
    spec = table7_spec()
    assert spec.presets["paper"] == [] and spec.preset_configs["paper"] == paper_config()
    row7 = _rows(spec, "paper")["#7"]
    assert row7 == load_config(paper_config(), [])  # row #7 has no overrides: the file as written


def test_momu_train_paper_preset_is_the_tables_paper_file() -> None:
    paper = train_config("momu", preset="paper")
    assert paper == load_config(paper_config(), [])  # not the cpu YAML (once `paper: []` over it)
    assert paper.method == _rows(table7_spec(), "paper")["#7"].method
    cpu = train_config("momu", preset="cpu")
    assert cpu.method.motion_backbone.hidden != paper.method.motion_backbone.hidden
    override = train_config("momu", preset="paper", overrides=["method.train_diffusion.steps=7"])
    assert override.method.train_diffusion.steps == 7


def test_paper_preset_values() -> None:
    paper = _rows(table7_spec(), "paper")
    m = paper["#7"].method
    assert m.vae_loss.reduction == "mean" and m.vae_loss.velocity_weight == 0.0  # Eq. 10-11
    assert m.gan_loss.weight == 0.5 and not m.gan_loss.adaptive_weight  # Eq. 10: fixed lambda2
    assert m.bone_correction and m.bone_ratio == 1.3  # App. E
    assert m.vocoder.name == "bigvgan" and m.vocoder.checkpoint is None  # App. A.2, local weights
    assert m.music_backbone.max_length >= 2 * 937 + 1  # 30 s of both latents, concatenated positions
    assert m.sampler.scheduler.name == "ddim" and m.sampler.num_inference_steps == 50  # §5.1
    joint = m.joint_sampler
    assert (joint.scheduler.name, joint.num_inference_steps, joint.guidance_scale) == ("ddim", 50, 3.0)
    assert m.train_min_seconds == 10.0 and m.window_seconds == 25.0  # §5.3 / §5.1 segments
    assert paper["#4"].method.music_backbone.base_channels == 128  # the registered unet1d, not cpu-sized
    for spec_factory in TABLE_SPECS.values():
        spec = spec_factory()
        cfg = next(iter(_rows(spec, "paper").values()))
        assert cfg.method.vae_loss.reduction == "mean" and cfg.method.bone_correction


def test_without_a_bigvgan_checkpoint_the_vocoder_falls_back_with_a_warning(caplog) -> None:
    with caplog.at_level("WARNING"):
        node = vocoder_node({"name": "bigvgan", "checkpoint": None})
    assert node["name"] == "griffin_lim" and "method.vocoder.checkpoint" in caplog.text
    assert vocoder_node({"name": "bigvgan", "checkpoint": "/w.safetensors"})["name"] == "bigvgan"


def test_every_table_samples_joint_rows_like_its_cross_rows() -> None:
    for spec in (table7_spec(), table10_spec()):
        for preset in ("cpu", "paper"):
            for cfg in _rows(spec, preset).values():
                joint, cross = cfg.method.joint_sampler, cfg.method.sampler
                assert joint.scheduler == cross.scheduler
                assert joint.num_inference_steps == cross.num_inference_steps
                music = cfg.method.music_sampler or cross
                assert (joint.music_guidance_scale or joint.guidance_scale) == music.guidance_scale
                assert (joint.motion_guidance_scale or joint.guidance_scale) == cross.guidance_scale


def test_docs_presets_page_lists_exactly_the_cpu_departures() -> None:
    committed = (ROOT / "docs" / "presets.md").read_text()
    assert committed == presets_page(), "regenerate: python -m momu.methods.momu.presets_doc docs/presets.md"


@pytest.mark.parametrize("seconds", [25.0, 30.0])
def test_paper_dit_forwards_at_paper_lengths(seconds: float) -> None:
    m = _rows(table7_spec(), "paper")["#7"].method
    with torch.device("meta"):  # the 217 M-parameter BiCoR-VAE: shapes only
        vae = build_component(m.encoder, "encoders")
    rates = Rates(
        sample_rate=int(m.sample_rate),
        hop_length=256,
        music_frames_per_latent=int(vae.music_vae.frames_per_latent),
        motion_frames_per_latent=int(vae.motion_vae.frames_per_latent),
        music_input=vae.music_input,
    )
    frames = rates.latent_frames(seconds)
    assert frames == int(seconds * 31.25)  # 31.25 Hz latents (MoMu App. B.2 hop 256, x2 downsampling)
    mel = torch.zeros(1, 80, frames * rates.music_frames_per_latent, device="meta")
    assert vae.encode_music(mel).mode().shape == (1, frames, 20)
    torch.manual_seed(0)
    dit = build_component(backbone_node(m.music_backbone, 20), "backbones").eval()
    with torch.no_grad():
        out = dit(torch.randn(1, frames, 20), torch.tensor([500]), torch.randn(1, frames, 20))
    assert out.shape == (1, frames, 20) and torch.isfinite(out).all()
