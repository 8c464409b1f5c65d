"""Rhythmic contrastive loss (MoMu §3.2, Eq. 1-4) and the stage-2 objective, music VAE frozen (Eq. 11)."""

from __future__ import annotations

import math

import pytest
import torch
from tests.helpers.encoders import TINY_VAE

from momu.encoders.bicor_vae import BiCoRVAEConfig, build_bicor_vae, stage2_loss
from momu.losses.rhythmic_contrastive import (
    RhythmicContrastiveConfig,
    RhythmicContrastiveLoss,
    amplitude_categories,
    clip_max_pool,
    latent_kinematic_amplitude,
    sample_rhythmic_clips,
    symmetric_info_nce,
)
from momu.losses.vae import VAELoss


def test_info_nce_by_hand_for_orthogonal_pairs() -> None:
    # Cosine similarities: 1 on the diagonal, 0 off it; with tau = 1 each row is softmax([1, 0]).
    e = torch.eye(2)
    expected = math.log(1.0 + math.exp(-1.0))
    assert symmetric_info_nce(e, e, temperature=1.0).item() == pytest.approx(expected)


def test_info_nce_prefers_matched_pairs() -> None:
    torch.manual_seed(0)
    a = torch.randn(6, 8)
    matched = symmetric_info_nce(a, a + 0.01 * torch.randn(6, 8))
    shuffled = symmetric_info_nce(a, a[torch.tensor([1, 2, 3, 4, 5, 0])])
    assert matched < 0.1 < math.log(6) < shuffled


def test_info_nce_input_errors() -> None:
    with pytest.raises(ValueError, match=r"\(N, d\)"):
        symmetric_info_nce(torch.zeros(3, 2), torch.zeros(2, 2))
    with pytest.raises(ValueError, match="temperature"):
        symmetric_info_nce(torch.zeros(3, 2), torch.zeros(3, 2), temperature=0.0)


def test_clip_max_pool_by_hand() -> None:
    z = torch.tensor([[0.0, 5.0], [3.0, 1.0], [1.0, 2.0], [4.0, 0.0]])
    pooled = clip_max_pool(z, torch.tensor([0, 2]), 2)
    assert pooled.tolist() == [[3.0, 5.0], [4.0, 2.0]]
    with pytest.raises(ValueError, match="inside"):
        clip_max_pool(z, torch.tensor([3]), 2)


def test_amplitude_categories_by_hand() -> None:
    values = torch.tensor([0.9, 0.6, 0.7, 0.8])
    assert amplitude_categories(values, 2, "quantile").tolist() == [1, 0, 0, 1]  # equal-count halves
    assert amplitude_categories(values, 2, "uniform").tolist() == [1, 1, 1, 1]  # all in [0.5, 1]
    assert amplitude_categories(torch.tensor([0.0, 1.0]), 4, "uniform").tolist() == [0, 3]


def test_sampled_clips_come_from_distinct_categories() -> None:
    amp = torch.linspace(0, 1, 40) ** 2
    cfg = RhythmicContrastiveConfig(num_clips=16, num_categories=4, num_samples=4, clip_length=5)
    g = torch.Generator().manual_seed(0)
    starts, length = sample_rhythmic_clips(amp, cfg, generator=g)
    assert length == 5 and starts.numel() == 4
    assert len(set(starts.tolist())) == 4
    assert int(starts.max()) + length <= 40
    # amp is increasing, so a clip's max is at its end: distinct quantile categories -> distinct starts,
    # and reproducible with the same generator.
    again, _ = sample_rhythmic_clips(amp, cfg, generator=torch.Generator().manual_seed(0))
    assert again.tolist() == starts.tolist()


def test_sampling_respects_the_valid_length_and_short_sequences() -> None:
    cfg = RhythmicContrastiveConfig(num_clips=8, num_categories=4, num_samples=4, clip_length=6)
    starts, length = sample_rhythmic_clips(torch.rand(20), cfg, valid_length=8, generator=torch.Generator())
    assert length == 6 and int(starts.max()) + length <= 8
    starts, length = sample_rhythmic_clips(torch.rand(3), cfg, generator=torch.Generator())
    assert length == 3 and starts.tolist() == [0]  # one possible clip: a single positive, loss log 1 = 0


def test_latent_kinematic_amplitude_peaks_where_the_motion_accelerates() -> None:
    # Joint 0 is still, then jumps right between frames 4 and 5: the directogram rises at that
    # displacement, so Q peaks at frame 5, i.e. latent frame 2 when 2 motion frames make a latent frame.
    motion = torch.zeros(1, 8, 2, 2)
    motion[0, 5:, 0, 0] = 1.0
    q = latent_kinematic_amplitude(motion, 4)
    assert q.tolist() == [[0.0, 0.0, 1.0, 0.0]]


def test_loss_forward_weights_and_gradients() -> None:
    torch.manual_seed(0)
    cfg = RhythmicContrastiveConfig(weight=2.0, num_clips=8, num_categories=4, num_samples=4, clip_length=3)
    loss = RhythmicContrastiveLoss(cfg)
    z_a = torch.randn(2, 16, 4)
    z_m = torch.randn(2, 16, 4, requires_grad=True)
    out = loss(z_a, z_m, torch.rand(2, 16), generator=torch.Generator().manual_seed(0))
    assert out["loss"].item() == pytest.approx(2.0 * out["contrast"].item())
    assert 0.0 <= out["contrast"].item()
    out["loss"].backward()
    assert z_m.grad is not None and z_m.grad.abs().sum() > 0


def test_cross_pair_negatives_pool_the_batch() -> None:
    torch.manual_seed(0)
    z = torch.randn(3, 12, 4)
    amp = torch.rand(3, 12)
    cfg = RhythmicContrastiveConfig(num_clips=6, num_categories=2, num_samples=2, clip_length=2)
    # Identical embeddings for music and motion of every clip: with more negatives the loss is
    # still finite, and with all embeddings equal it is log of the number of clips (3 pairs x 2).
    same = torch.ones(3, 12, 4)
    pooled = RhythmicContrastiveLoss(dataclasses_replace(cfg, cross_pair_negatives=True))
    assert pooled(same, same, amp)["contrast"].item() == pytest.approx(math.log(6), rel=1e-5)
    assert torch.isfinite(pooled(z, z, amp)["contrast"])


def dataclasses_replace(cfg: RhythmicContrastiveConfig, **kw: object) -> RhythmicContrastiveConfig:
    import dataclasses

    return dataclasses.replace(cfg, **kw)  # type: ignore[arg-type]


def test_config_errors() -> None:
    with pytest.raises(ValueError, match="num_samples"):
        RhythmicContrastiveLoss(RhythmicContrastiveConfig(num_samples=5, num_categories=4))
    with pytest.raises(ValueError, match="amplitude must be"):
        RhythmicContrastiveLoss()(torch.zeros(1, 4, 2), torch.zeros(1, 4, 2), torch.zeros(1, 3))


# ----------------------------------------------------------------------------- stage 2 (Eq. 11)
def _stage2_setup() -> tuple:
    torch.manual_seed(0)
    model = build_bicor_vae(BiCoRVAEConfig(motion=TINY_VAE, music=TINY_VAE, mel_bins=16))
    contrastive = RhythmicContrastiveLoss(
        RhythmicContrastiveConfig(num_clips=8, num_categories=4, num_samples=4, clip_length=2)
    )
    mel = torch.randn(2, 16, 16)
    motion = torch.cumsum(torch.randn(2, 20, 14, 2), dim=1)
    return model, contrastive, mel, motion


def test_stage2_requires_the_frozen_music_vae() -> None:
    model, contrastive, mel, motion = _stage2_setup()
    with pytest.raises(ValueError, match="freeze"):
        stage2_loss(model, motion, mel, vae_loss=VAELoss(), contrastive=contrastive)


def test_frozen_music_vae_does_not_change_in_a_stage2_step() -> None:
    model, contrastive, mel, motion = _stage2_setup()
    model.freeze_music()
    model.train()
    music0 = {k: v.clone() for k, v in model.music_vae.state_dict().items()}
    motion0 = {k: v.clone() for k, v in model.motion_vae.state_dict().items()}
    # An optimizer over ALL parameters (as a careless training loop would build it).
    opt = torch.optim.AdamW(model.parameters(), lr=1e-2)
    out = stage2_loss(
        model,
        motion,
        mel,
        vae_loss=VAELoss(),
        contrastive=contrastive,
        generator=torch.Generator().manual_seed(0),
    )
    assert out["loss"].item() == pytest.approx(
        out["reconstruction"].item() + 1e-5 * out["kl"].item() + out["contrast"].item(), rel=1e-5
    )
    opt.zero_grad()
    out["loss"].backward()
    opt.step()
    for k, v in model.music_vae.state_dict().items():
        assert torch.equal(v, music0[k]), k
    assert any(not torch.equal(v, motion0[k]) for k, v in model.motion_vae.state_dict().items())
