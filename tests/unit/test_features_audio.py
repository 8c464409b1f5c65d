"""Audio features: mel front ends (librosa and torch), MFCC, onsets, waveform framing, the mfcc encoder."""

from __future__ import annotations

import librosa
import numpy as np
import pytest
import torch
from omegaconf import OmegaConf

from momu.features.audio import (
    MelConfig,
    MfccConfig,
    MoFusionMelConfig,
    MoMuMelConfig,
    OnsetConfig,
    check_waveform,
    frame_waveform,
    log_mel,
    mel_to_power,
    mfcc,
    mofusion_mel,
    momu_mel,
    num_frames,
    onset_beats,
    onset_envelope,
    onset_times,
)
from momu.features.audio_torch import MelSpectrogram, Mfcc, dct_matrix

SR = 16000


def tone(seconds: float = 1.0, sr: int = SR, freq: float = 440.0, seed: int = 0) -> np.ndarray:
    t = np.arange(int(seconds * sr)) / sr
    noise = np.random.default_rng(seed).standard_normal(t.size)
    return (0.4 * np.sin(2 * np.pi * freq * t) + 0.02 * noise).astype(np.float32)


def click_track(times: list[float], seconds: float, sr: int) -> np.ndarray:
    """Short decaying noise bursts at ``times`` (seconds) over silence."""
    y = np.zeros(int(seconds * sr), dtype=np.float32)
    burst = np.random.default_rng(1).standard_normal(int(0.03 * sr)) * np.exp(
        -np.linspace(0, 8, int(0.03 * sr))
    )
    for t in times:
        i = int(t * sr)
        y[i : i + burst.size] += 0.8 * burst[: y.size - i].astype(np.float32)
    return y


# ------------------------------------------------------------------------------------ mel
def test_momu_mel_matches_paper_parameters_and_librosa() -> None:
    y = tone(1.0)
    mel = momu_mel(y, SR)
    # 80 filters, centred STFT with hop 256: 1 + 16000 // 256 = 63 frames (62.5 frames/s).
    assert mel.shape == (80, 63) and mel.dtype == np.float32
    ref = librosa.feature.melspectrogram(
        y=y, sr=SR, n_fft=1024, hop_length=256, win_length=1024, window="hann", n_mels=80, power=1.0
    )
    np.testing.assert_allclose(mel, np.log(np.maximum(ref, 1e-5)), atol=1e-5)
    assert MoMuMelConfig().frame_rate == 62.5


def test_mofusion_mel_gives_32_frames_per_second_of_audio() -> None:
    y = tone(1.0)
    mel = mofusion_mel(y, SR)
    assert mel.shape == (80, 32)  # 1 + 16000 // 512 = 32 (MoFusion §4's m = 32)
    assert MoFusionMelConfig().frame_rate == 31.25
    ref = librosa.power_to_db(
        librosa.feature.melspectrogram(y=y, sr=SR, n_fft=2048, hop_length=512, n_mels=80, fmin=0, fmax=8000),
        ref=1.0,
        amin=1e-10,
        top_db=None,
    )
    np.testing.assert_allclose(mel, ref, atol=1e-3)
    assert mofusion_mel(tone(10.0), SR).shape == (80, 1 + 160000 // 512)


def test_mel_resamples_to_the_config_rate() -> None:
    y22 = tone(2.0, sr=22050)
    mel = momu_mel(y22, 22050)
    assert mel.shape == (80, 1 + 32000 // 256)
    assert num_frames(32000, MoMuMelConfig()) == mel.shape[1]
    # Same tone analysed natively at 16 kHz: the spectra agree closely where the tone is.
    native = momu_mel(tone(2.0, sr=SR), SR)
    peak = int(np.argmax(native[:, 10]))
    assert int(np.argmax(mel[:, 10])) == peak


def test_mel_to_power_inverts_the_log() -> None:
    y = tone(0.5)
    for cfg in (MoMuMelConfig(), MoFusionMelConfig()):
        logmel = log_mel(y, SR, cfg)
        power = mel_to_power(logmel, cfg)
        assert power.shape == logmel.shape and np.all(power > 0)
        relog = np.log(power) if cfg.log == "ln" else 10.0 * np.log10(power)
        np.testing.assert_allclose(relog, logmel, atol=1e-3)
    db = MoFusionMelConfig()  # the dB branch gives back the mel-filtered power spectrogram (power 2)
    ref = librosa.feature.melspectrogram(
        y=y,
        sr=SR,
        n_fft=db.n_fft,
        hop_length=db.hop_length,
        n_mels=db.n_mels,
        fmin=db.fmin,
        fmax=db.fmax,
        power=2.0,
    )
    np.testing.assert_allclose(
        mel_to_power(log_mel(y, SR, db), db), np.maximum(ref, db.log_floor), rtol=1e-3, atol=1e-9
    )
    cfg = MoMuMelConfig()
    raw = mel_to_power(momu_mel(y, SR), cfg)
    ref = librosa.feature.melspectrogram(y=y, sr=SR, n_fft=1024, hop_length=256, n_mels=80, power=1.0)
    np.testing.assert_allclose(raw, np.maximum(ref, 1e-5), rtol=1e-4)


@pytest.mark.parametrize(
    "cfg",
    [
        MoMuMelConfig(),
        MoFusionMelConfig(),
        MelConfig(log="none", power=2.0),
        MelConfig(pad_mode="reflect", win_length=800, window="hamming"),
        MelConfig(center=False, htk=True, mel_norm="none", fmin=50.0, fmax=7000.0),
    ],
)
def test_torch_mel_matches_librosa_batched(cfg: MelConfig) -> None:
    batch = np.stack([tone(1.0, seed=0), tone(1.0, freq=880.0, seed=1)])
    module = MelSpectrogram(cfg)
    out = module(torch.from_numpy(batch))
    assert out.shape == (2, 80, num_frames(SR, cfg))
    for i in range(2):
        ref = log_mel(batch[i], SR, cfg)
        scale = max(1.0, float(np.abs(ref).max()))
        np.testing.assert_allclose(out[i].numpy(), ref, atol=1e-4 * scale)
    # 1-D input gives the unbatched (n_mels, frames) result.
    np.testing.assert_allclose(module(torch.from_numpy(batch[0])).numpy(), out[0].numpy(), atol=1e-6)


def test_torch_mel_is_differentiable() -> None:
    x = torch.from_numpy(tone(0.25)).requires_grad_(True)
    MelSpectrogram()(x).sum().backward()
    assert x.grad is not None and torch.isfinite(x.grad).all()


@pytest.mark.gpu
def test_torch_mel_on_gpu_matches_cpu() -> None:
    x = torch.from_numpy(np.stack([tone(1.0), tone(1.0, freq=300.0)]))
    cpu = MelSpectrogram()(x)
    gpu = MelSpectrogram().cuda()(x.cuda())
    assert gpu.device.type == "cuda"
    torch.testing.assert_close(gpu.cpu(), cpu, atol=1e-4, rtol=1e-4)


def test_mel_config_rejects_bad_values_and_is_a_config_node() -> None:
    with pytest.raises(ValueError, match="fmax"):
        MelConfig(fmax=9000.0)
    with pytest.raises(ValueError, match="log"):
        MelConfig(log="log10")
    with pytest.raises(ValueError, match="win_length"):
        MelConfig(win_length=4096)
    node = OmegaConf.structured(MoFusionMelConfig)
    assert node.hop_length == 512 and node.fmax == 8000.0
    cfg = OmegaConf.to_object(OmegaConf.merge(node, {"n_mels": 64}))
    assert isinstance(cfg, MoFusionMelConfig) and cfg.n_mels == 64


def test_waveform_validation_names_the_problem() -> None:
    with pytest.raises(ValueError, match="mono"):
        check_waveform(np.zeros((2, 100)), SR)
    with pytest.raises(ValueError, match="empty"):
        momu_mel(np.zeros(0, dtype=np.float32), SR)
    bad = tone(0.1)
    bad[5] = np.nan
    with pytest.raises(ValueError, match="non-finite"):
        momu_mel(bad, SR)
    with pytest.raises(ValueError, match="sample rate"):
        momu_mel(tone(0.1), 0)
    assert check_waveform(np.zeros((1, 10)), SR).shape == (10,)


# ------------------------------------------------------------------------------------ MFCC
def test_mfcc_matches_librosa() -> None:
    y = tone(1.0)
    out = mfcc(y, SR)
    np.testing.assert_allclose(out, librosa.feature.mfcc(y=y, sr=SR), atol=1e-3)
    cfg = MfccConfig(frame_rate=25.0, n_mfcc=13)
    assert cfg.hop == 640
    assert mfcc(y, SR, cfg).shape == (13, 1 + 16000 // 640)


def test_dct_matrix_is_orthonormal_dct2() -> None:
    from scipy.fft import dct

    basis = dct_matrix(16, 16).double()
    torch.testing.assert_close(basis @ basis.T, torch.eye(16, dtype=torch.float64), atol=1e-6, rtol=0)
    v = np.random.default_rng(0).standard_normal(16)
    np.testing.assert_allclose(basis.numpy() @ v, dct(v, type=2, norm="ortho"), atol=1e-5)


def test_torch_mfcc_matches_librosa_with_lifter() -> None:
    y = tone(1.0)
    cfg = MfccConfig(lifter=22.0)
    out = Mfcc(cfg)(torch.from_numpy(y)[None])[0].numpy()
    np.testing.assert_allclose(out, mfcc(y, SR, cfg), atol=2e-3 * max(1.0, float(np.abs(out).max())))


def test_mfcc_encoder_is_registered_and_channels_last() -> None:
    from momu.config import build_component
    from momu.registry import ENCODERS

    assert "mfcc" in ENCODERS.names()
    enc = build_component({"name": "mfcc", "frame_rate": 25.0, "n_mfcc": 13}, "encoders")
    y = np.stack([tone(1.0), tone(1.0, freq=660.0)])
    out = enc(torch.from_numpy(y))
    assert out.shape == (2, 26, 13) and enc.out_channels == 13 and enc.frame_rate == 25.0
    assert enc.num_frames(16000) == 26
    ref = mfcc(y[1], SR, MfccConfig(frame_rate=25.0, n_mfcc=13))
    np.testing.assert_allclose(out[1].numpy().T, ref, atol=2e-3 * float(np.abs(ref).max()))
    norm = ENCODERS.build("mfcc", {"normalize": True})(torch.from_numpy(y))
    torch.testing.assert_close(norm.mean(dim=1), torch.zeros(2, 20), atol=1e-4, rtol=0)
    with pytest.raises(ValueError, match="batch"):
        enc(torch.zeros(100))


# ------------------------------------------------------------------------------------ onsets
def test_onset_times_recover_a_click_track() -> None:
    sr = 22050
    clicks = [0.5, 1.0, 1.5, 2.0, 2.5, 3.0, 3.5]
    y = click_track(clicks, 4.0, sr)
    found = onset_times(y, sr)
    assert len(found) == len(clicks)
    # Onset frames are 512/22050 = 23.2 ms apart: each click is found within two frames.
    np.testing.assert_allclose(found, clicks, atol=0.05)
    # Same as the call MoMu quotes (App. B.4).
    ref = librosa.onset.onset_detect(
        y=y, sr=sr, wait=1, delta=0.2, pre_avg=3, post_avg=3, pre_max=3, post_max=3, units="time"
    )
    np.testing.assert_allclose(found, ref)


def test_onset_beats_saliency_is_the_envelope_at_each_onset() -> None:
    sr = 22050
    y = click_track([0.5, 1.5], 2.5, sr)
    y[int(1.5 * sr) :] *= 0.2  # the second click is quieter
    times, strength = onset_beats(y, sr)
    env = onset_envelope(y, sr)
    frames = np.round(times * sr / 512).astype(int)
    np.testing.assert_allclose(strength, env[frames])
    assert len(times) == 2 and strength[0] > strength[1] > 0


def test_onsets_resample_to_the_metric_rate() -> None:
    clicks = [0.5, 1.0, 1.5]
    y16 = click_track(clicks, 2.0, SR)
    np.testing.assert_allclose(onset_times(y16, SR), clicks, atol=0.05)
    assert OnsetConfig().frame_rate == pytest.approx(22050 / 512)


# ------------------------------------------------------------------------------------ framing
def test_frame_waveform_numpy_and_torch() -> None:
    y = np.arange(1000, dtype=np.float32)
    frames = frame_waveform(y)  # 256-sample non-overlapping frames, last one zero-padded
    assert isinstance(frames, np.ndarray) and frames.shape == (4, 256)
    np.testing.assert_array_equal(frames.reshape(-1)[:1000], y)
    assert np.all(frames.reshape(-1)[1000:] == 0)
    assert frame_waveform(y, pad=False).shape == (3, 256)
    assert frame_waveform(y, 400, 200).shape == (4, 400)
    batch = frame_waveform(torch.arange(2048.0).reshape(2, 1024), 256)
    assert isinstance(batch, torch.Tensor) and batch.shape == (2, 4, 256)
    assert torch.equal(batch[1, 2], torch.arange(1024.0 + 512, 1024.0 + 768))
    with pytest.raises(ValueError, match="positive"):
        frame_waveform(y, 0)
    with pytest.raises(ValueError, match="shorter"):
        frame_waveform(y[:100], pad=False)
