"""MoMu's issue-32 settings: rhythm conditions, root velocity, prediction types and rigid bones.

The config checks (``check_config``: one line naming the key, before anything is read or written)
and a smoke-preset training run with every setting on that then generates in both directions.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest
import torch

from momu.config import ConfigError, build_component
from momu.encoders.rhythm import MotionRhythm, MusicRhythm
from momu.features.bones import bone_lengths
from momu.features.skeletons import get_skeleton
from momu.methods.momu import MoMuModel
from momu.methods.momu.conditions import Conditions
from momu.methods.momu.config import MoMuConfig, check_config
from momu.training import train_method

V = {"name": "ddpm", "prediction_type": "v_prediction"}
RHYTHM = {
    "motion_condition": {"name": "music_rhythm"},
    "music_condition": {"name": "motion_rhythm"},
    "condition_latents": False,
}
"""The issue-32 conditions: each denoiser conditioned on the other side's rhythm features alone."""
ISSUE_32 = [
    "method.motion_condition=music_rhythm",
    "method.music_condition=motion_rhythm",
    "method.condition_latents=false",
    "method.motion_representation=root_velocity",
    "method.scheduler.prediction_type=v_prediction",
    "method.sampler.scheduler.prediction_type=v_prediction",
    "method.rigid_bones=true",
]
"""The same as overrides, with v-prediction and rigid bones (recipes/pretrain.py's METHOD_OVERRIDES)."""


def rejected(**method: Any) -> str:
    """The one-line reason the ``momu`` method with ``method`` is rejected."""
    with pytest.raises(ValueError) as err:
        build_component({"name": "momu", **method}, "methods")
    message = str(err.value)
    assert "\n" not in message, message
    return message


# ---------------------------------------------------------------- check_config
def test_the_issue_32_settings_pass() -> None:
    sampler = {"name": "cfg", "scheduler": V}
    check_config(
        MoMuConfig(
            **RHYTHM,
            motion_representation="root_velocity",
            scheduler=V,
            sampler=sampler,
            joint_sampler={"name": "cross_guidance", "scheduler": V},
            rigid_bones=True,
        )
    )
    cond = Conditions.of(MoMuConfig(**RHYTHM, motion_representation="root_velocity"), "dwm21")
    assert isinstance(cond.from_music, MusicRhythm) and isinstance(cond.from_motion, MotionRhythm)
    assert cond.cond_width("motion", 16) == 4 and cond.cond_width("music", 16) == 4  # features alone
    kept = Conditions.of(MoMuConfig(motion_condition={"name": "music_rhythm"}), "dwm21")
    assert kept.cond_width("motion", 16) == 20 and kept.cond_width("music", 16) == 16  # latent + features


SAMPLER_KEYS = ("sampler", "music_sampler", "motion_sampler", "joint_sampler")


def samplers(scheduler: dict[str, Any] | None, **override: Any) -> dict[str, Any]:
    """Every sampler node on ``scheduler`` (``None``: each sampler's default, ε), then ``override``."""
    nodes = {}
    for key in SAMPLER_KEYS:
        node: dict[str, Any] = {"name": "cross_guidance" if key == "joint_sampler" else "cfg"}
        if scheduler is not None:
            node["scheduler"] = scheduler
        nodes[key] = node
    return {**nodes, **override}


@pytest.mark.parametrize("key", SAMPLER_KEYS)
def test_sampler_prediction_type_must_match_training(key: str) -> None:
    build_component({"name": "momu", "scheduler": V, **samplers(V)}, "methods")  # all alike: fine
    name = "cross_guidance" if key == "joint_sampler" else "cfg"
    message = rejected(scheduler=V, **samplers(V, **{key: {"name": name}}))
    assert message == (
        f"method.{key}.scheduler.prediction_type is 'epsilon' but the denoisers are trained with "
        "method.scheduler.prediction_type 'v_prediction'"
    )
    sample = {"name": "ddim", "prediction_type": "sample"}
    message = rejected(**samplers(None, **{key: {"name": name, "scheduler": sample}}))
    assert message.startswith(f"method.{key}.scheduler.prediction_type is 'sample' but")


def test_unknown_prediction_type_is_named() -> None:
    bad = {"name": "ddpm", "prediction_type": "velocity"}
    assert rejected(scheduler=bad) == (
        "method.scheduler.prediction_type: unknown prediction type 'velocity'; "
        "valid: epsilon, sample, v_prediction"
    )
    message = rejected(scheduler=V, **samplers(V, motion_sampler={"name": "cfg", "scheduler": bad}))
    assert message.startswith("method.motion_sampler.scheduler.prediction_type: unknown prediction type")


def test_bad_conditions_are_named() -> None:
    assert rejected(motion_condition={"name": "beats"}).startswith(
        "method.motion_condition: encoder: unknown encoder 'beats'; valid names: "
    )
    assert rejected(music_condition={"name": "motion_rhythm", "min_bpm": 0.0}).startswith(
        "method.music_condition: motion_rhythm: need 0 < min_bpm < max_bpm"
    )
    assert rejected(music_condition={"name": "motion_rhythm", "bpm": 3}).startswith(
        "method.music_condition: "
    )
    assert rejected(motion_condition={"name": "waveform"}) == (
        "method.motion_condition: WaveformVAE has no track()/out_channels (docs/protocols.md)"
    )
    assert rejected(condition_latents=False, motion_condition={"name": "music_rhythm"}).startswith(
        "method.condition_latents: false needs both motion_condition and music_condition"
    )


def test_bad_motion_representation_is_named() -> None:
    assert rejected(motion_representation="world") == (
        "method.motion_representation: unknown motion representation 'world'; valid: positions, root_velocity"
    )
    with pytest.raises(ValueError, match="'root_velocity' needs 3D keypoints"):
        Conditions.of(MoMuConfig(motion_representation="root_velocity"), "openpose14")


def test_momu_train_rejects_bad_method_values_before_writing_anything(tmp_path: Path) -> None:
    out = tmp_path / "run"
    for override, key in [
        ("method.motion_representation=world", "method.motion_representation: "),
        ("method.music_condition=beats", "method.music_condition: "),
        ("method.scheduler.prediction_type=v_prediction", "method.sampler.scheduler.prediction_type is "),
    ]:
        with pytest.raises(ConfigError) as err:
            train_method("momu", out, preset="smoke", overrides=[override])
        assert str(err.value).startswith(key) and "\n" not in str(err.value)
        assert not out.exists()


# ---------------------------------------------------------------- smoke: train and generate
@pytest.fixture(scope="module")
def issue_32_model(tmp_path_factory: pytest.TempPathFactory) -> MoMuModel:
    torch.set_num_threads(1)
    out = tmp_path_factory.mktemp("issue32")
    overrides = ["dataset.skeleton=dwm21", "method.train_diffusion.steps=2", *ISSUE_32]
    result = train_method("momu", out, preset="smoke", overrides=overrides)
    return MoMuModel.load(result.model)


def test_issue_32_model_keeps_its_settings(issue_32_model: MoMuModel) -> None:
    model = issue_32_model
    cfg = model.cfg
    assert cfg.rigid_bones and cfg.motion_representation == "root_velocity" and not cfg.condition_latents
    assert model.sampler_for("motion").scheduler.prediction_type == "v_prediction"
    assert model.sampler_for("music").scheduler.prediction_type == "v_prediction"
    assert model.motion_backbone.cond_channels == 4 and model.music_backbone.cond_channels == 4
    assert model.bone_lengths.shape == (len(get_skeleton("dwm21").bones),)


def test_issue_32_model_generates_both_ways_on_rigid_bones(issue_32_model: MoMuModel) -> None:
    model = issue_32_model
    sr = model.rates.sample_rate
    t = np.arange(2 * sr) / sr
    song = (0.5 * np.sin(2 * np.pi * 440 * t) * (np.sin(2 * np.pi * 2 * t) > 0.9)).astype(np.float32)
    (motion,) = model.music_to_motion([song], sr, [0])
    frames = model.rates.latent_frames(2.0) * model.vae.motion_vae.frames_per_latent
    assert motion.shape == (frames, 21, 3) and np.isfinite(motion).all()
    lengths = bone_lengths(motion.astype(np.float64), get_skeleton("dwm21").bones)
    assert float(np.ptp(lengths, axis=0).max()) < 1e-3  # every bone keeps its length (within 1 mm)
    np.testing.assert_allclose(lengths[0], model.bone_lengths, atol=1e-3)  # the training data's lengths
    (music,) = model.motion_to_music([motion], model.rates.motion_fps, [0])
    assert music.ndim == 1 and abs(len(music) - 2 * sr) <= 512 and np.isfinite(music).all()
    assert np.abs(music).max() <= 1.0
