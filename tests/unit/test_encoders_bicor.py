"""BiCoR-VAE and its Table 7 alternatives: shapes, alignment, freezing, save/load (MoMu §3, App. A)."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest
import torch
from tests.helpers.encoders import TINY_VAE

from momu.encoders.bicor_vae import (
    BiCoRVAE,
    BiCoRVAEConfig,
    KeypointVAE,
    MelVAE,
    align_frames,
    build_bicor_vae,
)
from momu.encoders.directional_vector import DirectionalVectorConfig, DirectionalVectorVAE
from momu.encoders.discriminator import MelDiscriminator, MelDiscriminatorConfig
from momu.encoders.waveform import WaveformVAE, WaveformVAEConfig
from momu.features.skeletons import forward_kinematics, get_skeleton
from momu.registry import ENCODERS


def tiny_bicor(**kw: object) -> BiCoRVAE:
    cfg = BiCoRVAEConfig(motion=TINY_VAE, music=TINY_VAE, mel_bins=16, **kw)  # type: ignore[arg-type]
    return build_bicor_vae(cfg)


# ----------------------------------------------------------------------------- default builds
@pytest.mark.parametrize(
    ("name", "make_input"),
    [
        ("directional_vector", lambda: torch.randn(1, 16, 14, 2)),
        ("waveform", lambda: torch.randn(1, 2048)),
    ],
)
def test_single_branch_parts_build_from_defaults_and_backpropagate(name: str, make_input: object) -> None:
    vae = ENCODERS.build(name)
    x = make_input()  # type: ignore[operator]
    out = vae(x)
    assert out.reconstruction.shape == out.target.shape
    assert out.latent.shape[-1] == 20  # Table 8 latent width
    (out.reconstruction - out.target).abs().mean().backward()
    assert all(p.grad is not None for p in vae.parameters() if p.requires_grad)


def test_bicor_vae_builds_from_default_config_and_backpropagates() -> None:
    model = ENCODERS.build("bicor_vae")
    assert isinstance(model.motion_vae, KeypointVAE) and isinstance(model.music_vae, MelVAE)
    mel = torch.randn(1, 80, 32)
    motion = torch.randn(1, 40, 14, 2)
    q_motion, q_music, aligned = model.encode_pair(motion, mel)
    assert q_music.shape == (1, 16, 20)  # one downsampling layer of rate 2 (Table 8 / App. A.1)
    assert q_motion.shape == q_music.shape  # MoMu §3.2: T_zm = T_za
    assert aligned.shape == (1, 32, 14, 2)
    loss = (
        model.decode_music(q_music.sample()).abs().mean()
        + model.decode_motion(q_motion.sample()).abs().mean()
    )
    loss.backward()
    assert all(p.grad is not None for p in model.parameters())


def test_mel_discriminator_builds_from_defaults() -> None:
    disc = ENCODERS.build("mel_discriminator")
    logits = disc(torch.randn(2, 80, 32))
    assert logits.shape == (2, 1, 10, 4)  # three stride-2 layers: 80 -> 10, 32 -> 4
    logits.mean().backward()


def test_mel_discriminator_rejects_bad_input() -> None:
    disc = MelDiscriminator(MelDiscriminatorConfig(mel_bins=16, channels=4, num_layers=2))
    with pytest.raises(ValueError, match="frames"):
        disc(torch.randn(1, 16, 3))
    with pytest.raises(ValueError, match=r"\(B, 16, T\)"):
        disc(torch.randn(1, 12, 8))


# ----------------------------------------------------------------------------- shapes and lengths
def test_encode_decode_shapes_with_padding_and_cropping() -> None:
    model = tiny_bicor()
    mel = torch.randn(2, 16, 13)  # odd length: padded to 14 inside, cropped back on decode
    q = model.encode_music(mel)
    assert q.shape == (2, 7, 4)
    assert model.decode_music(q.mode(), 13).shape == (2, 16, 13)
    assert model.decode_music(q.mode()).shape == (2, 16, 14)
    with pytest.raises(ValueError, match="length"):
        model.decode_music(q.mode(), 15)


def test_input_shape_errors_name_the_expected_layout() -> None:
    model = tiny_bicor()
    with pytest.raises(ValueError, match=r"motion must be \(B, T, 14, 2\)"):
        model.encode_motion(torch.randn(1, 8, 13, 2))
    with pytest.raises(ValueError, match=r"mel must be \(B, 16, T\)"):
        model.encode_music(torch.randn(1, 80, 8))


def test_branch_latent_widths_must_agree() -> None:
    with pytest.raises(ValueError, match="same width"):
        BiCoRVAE(KeypointVAE(14, 2, TINY_VAE), MelVAE(16, dataclasses.replace(TINY_VAE, latent_channels=5)))


def test_branches_must_have_the_right_modality() -> None:
    with pytest.raises(ValueError, match="motion branch"):
        BiCoRVAE(MelVAE(16, TINY_VAE), MelVAE(16, TINY_VAE))


# ----------------------------------------------------------------------------- alignment (§3.2)
def test_align_frames_drops_evenly() -> None:
    x = torch.arange(10).reshape(1, 10)
    # floor(i * 10 / 5 + 0.5) = 0, 2, 4, 6, 8
    assert align_frames(x, 5, dim=1).tolist() == [[0, 2, 4, 6, 8]]
    assert align_frames(x, 10, dim=1) is x


def test_align_frames_upsampling_modes() -> None:
    x = torch.arange(4).reshape(1, 4)
    assert align_frames(x, 8, dim=1, mode="nearest").tolist() == [[0, 1, 1, 2, 2, 3, 3, 3]]
    with pytest.raises(ValueError, match="align='linear'"):
        align_frames(x, 8, dim=1, mode="drop")
    # linear (default): output frame i at input position i * 4 / 8, the last one held
    linear = align_frames(x.float(), 8, dim=1)
    assert linear.tolist() == [[0.0, 0.5, 1.0, 1.5, 2.0, 2.5, 3.0, 3.0]]
    # constant-speed motion keeps a constant speed (no repeated frame = no one-frame stop)
    ramp = torch.arange(60, dtype=torch.float32).reshape(1, 60, 1, 1).expand(1, 60, 2, 2)
    speed = align_frames(ramp, 62, dim=1).diff(dim=1)[0, :-1]
    assert torch.allclose(speed, torch.full_like(speed, 60 / 62), atol=1e-5)
    # fewer frames: every mode drops the same frames as the paper
    y = torch.arange(10.0).reshape(1, 10)
    assert align_frames(y, 5, dim=1).tolist() == align_frames(y, 5, dim=1, mode="drop").tolist()


def test_motion_is_aligned_to_the_music_latent_length() -> None:
    model = tiny_bicor(align="drop")
    mel = torch.randn(1, 16, 20)  # 10 latent frames
    motion = torch.randn(1, 37, 14, 2)  # more frames than the 20 needed: dropped evenly
    q_motion, q_music, aligned = model.encode_pair(motion, mel)
    assert q_music.shape[1] == q_motion.shape[1] == 10
    assert aligned.shape[1] == 20
    # The kept frames are frames of the input (no interpolation).
    kept = [int(np.argmin(((motion[0] - f) ** 2).sum(dim=(1, 2)).numpy())) for f in aligned[0]]
    assert kept == sorted(set(kept)) and kept[0] == 0


# ----------------------------------------------------------------------------- stage 2 freezing
def test_frozen_music_vae_stays_in_eval_mode_and_requires_no_grad() -> None:
    model = tiny_bicor().freeze_music()
    model.train()
    assert model.music_frozen and not model.music_vae.training and model.motion_vae.training
    assert not any(p.requires_grad for p in model.music_vae.parameters())
    assert {id(p) for p in model.trainable_parameters()} == {id(p) for p in model.motion_vae.parameters()}
    model.freeze_music(False)
    assert all(p.requires_grad for p in model.music_vae.parameters())


# ----------------------------------------------------------------------------- Table 7 replacements
def test_branches_are_replaced_through_component_nodes() -> None:
    model = ENCODERS.build(
        "bicor_vae",
        {
            "motion_encoder": {"name": "directional_vector", "vae": dataclasses.asdict(TINY_VAE)},
            "music_encoder": {"name": "waveform", "hop_length": 8, "vae": dataclasses.asdict(TINY_VAE)},
        },
    )
    assert isinstance(model.motion_vae, DirectionalVectorVAE)
    assert isinstance(model.music_vae, WaveformVAE) and model.music_input == "waveform"
    q_motion, q_music, _ = model.encode_pair(torch.randn(1, 40, 14, 2), torch.randn(1, 160))
    assert q_music.shape == (1, 10, 4) and q_motion.shape == q_music.shape


def test_replacement_of_the_wrong_modality_is_an_error() -> None:
    with pytest.raises(ValueError, match="not a motion VAE"):
        ENCODERS.build("bicor_vae", {"motion_encoder": "waveform"})


def test_waveform_vae_lands_on_the_mel_vae_latent_rate() -> None:
    wave = WaveformVAE(WaveformVAEConfig(vae=TINY_VAE))
    mel = MelVAE(80, TINY_VAE)
    # 16 kHz, hop 256, downsampling 2: 31.25 latent frames per second for both.
    assert wave.latent_rate == 16000 / 512
    assert wave.frames_per_latent == 256 * mel.frames_per_latent
    samples = 16000
    mel_frames = 1 + samples // 256  # centred STFT
    assert abs(wave.latent_length(samples) - mel.latent_length(mel_frames)) <= 1
    x = torch.randn(2, samples)
    assert wave.encode(x).shape == (2, 32, 4)
    assert wave.decode(wave.encode(x).mode(), samples).shape == (2, samples)


def rigid_openpose_motion(frames: int = 6, seed: int = 0) -> np.ndarray:
    """Rigid 2D keypoints: openpose14 forward kinematics with random rotations, projected on x-y."""
    skel = get_skeleton("openpose14")
    rng = np.random.default_rng(seed)
    angles = rng.normal(scale=0.6, size=(frames, skel.num_joints))
    c, s = np.cos(angles), np.sin(angles)
    rot = np.zeros((frames, skel.num_joints, 3, 3))
    rot[..., 0, 0], rot[..., 0, 1], rot[..., 1, 0], rot[..., 1, 1], rot[..., 2, 2] = c, -s, s, c, 1.0
    pos3 = forward_kinematics(skel, rot, rng.normal(size=(frames, 3)))
    return pos3[..., :2]


def test_directional_representation_round_trips_rigid_motion() -> None:
    vae = DirectionalVectorVAE(DirectionalVectorConfig(vae=TINY_VAE)).double()
    motion = torch.as_tensor(rigid_openpose_motion(), dtype=torch.float64)[None]
    vae.fit_bone_lengths(motion)
    rep = vae.represent(motion)
    assert rep.shape == motion.shape
    torch.testing.assert_close(rep[:, :, 1:].norm(dim=-1), torch.ones(1, 6, 13, dtype=torch.float64))
    torch.testing.assert_close(vae.realize(rep), motion)


def test_directional_bone_lengths_are_saved_with_the_weights(tmp_path: Path) -> None:
    from momu.parts_io import load_part, save_part

    cfg = DirectionalVectorConfig(vae=TINY_VAE)
    vae = DirectionalVectorVAE(cfg)
    vae.fit_bone_lengths(torch.as_tensor(rigid_openpose_motion(), dtype=torch.float32))
    save_part(vae, "encoders", "directional_vector", cfg, tmp_path / "dv")
    loaded = load_part(tmp_path / "dv")
    torch.testing.assert_close(loaded.mean_lengths, vae.mean_lengths)


def test_fit_bone_lengths_rejects_wrong_layout() -> None:
    vae = DirectionalVectorVAE(DirectionalVectorConfig(vae=TINY_VAE))
    with pytest.raises(ValueError, match="14, 2"):
        vae.fit_bone_lengths(np.zeros((5, 13, 2)))


def test_unknown_skeleton_is_a_config_error() -> None:
    with pytest.raises(ValueError, match="directional_vector.skeleton"):
        DirectionalVectorVAE(DirectionalVectorConfig(skeleton="nope", vae=TINY_VAE))


# ----------------------------------------------------------------------------- save / load
@pytest.mark.parametrize(
    ("name", "cfg"),
    [
        ("bicor_vae", BiCoRVAEConfig(motion=TINY_VAE, music=TINY_VAE, mel_bins=16)),
        ("waveform", WaveformVAEConfig(hop_length=8, vae=TINY_VAE)),
        ("directional_vector", DirectionalVectorConfig(vae=TINY_VAE)),
        ("mel_discriminator", MelDiscriminatorConfig(mel_bins=16, channels=4, num_layers=2)),
    ],
)
def test_save_load_round_trip(tmp_path: Path, name: str, cfg: object) -> None:
    from momu.parts_io import load_part, save_part

    torch.manual_seed(0)
    part = ENCODERS.build(name, cfg)
    save_part(part, "encoders", name, cfg, tmp_path / name)
    loaded = load_part(tmp_path / name)
    assert type(loaded) is type(part)
    state, state2 = part.state_dict(), loaded.state_dict()
    assert state.keys() == state2.keys()
    for key in state:
        torch.testing.assert_close(state[key], state2[key])


def test_save_load_round_trip_with_replacement_branch(tmp_path: Path) -> None:
    from momu.parts_io import load_part, save_part

    params = {
        "music_encoder": {"name": "waveform", "hop_length": 8, "vae": dataclasses.asdict(TINY_VAE)},
        "motion": dataclasses.asdict(TINY_VAE),
    }
    model = ENCODERS.build("bicor_vae", params)
    save_part(model, "encoders", "bicor_vae", params, tmp_path / "m")
    loaded = load_part(tmp_path / "m")
    assert isinstance(loaded, BiCoRVAE) and isinstance(loaded.music_vae, WaveformVAE)
    x = torch.randn(1, 64)
    model.eval()
    loaded.eval()
    torch.testing.assert_close(loaded.encode_music(x).mean, model.encode_music(x).mean)
