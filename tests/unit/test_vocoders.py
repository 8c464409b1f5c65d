"""Vocoders `griffin_lim` and `bigvgan`: shapes, mel round trip, checkpoint loading, a tiny overfit."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import torch
from safetensors.torch import save_file

from momu.features.audio import MoMuMelConfig, momu_mel
from momu.registry import VOCODERS
from momu.vocoders.bigvgan import BigVGAN, kaiser_sinc_filter1d, load_bigvgan_state

SR = 16000


def tiny_bigvgan_params(**kw: object) -> dict[str, object]:
    params: dict[str, object] = {
        "mel": {"hop_length": 16, "n_fft": 64, "n_mels": 8},
        "upsample_rates": [4, 4],
        "upsample_kernel_sizes": [8, 8],
        "upsample_initial_channel": 16,
        "resblock_kernel_sizes": [3],
        "resblock_dilation_sizes": [[1, 3]],
    }
    params.update(kw)
    return params


def tone(freq: float = 440.0, seconds: float = 1.0) -> np.ndarray:
    t = np.arange(int(SR * seconds)) / SR
    return (0.5 * np.sin(2 * np.pi * freq * t)).astype(np.float32)


# ------------------------------------------------------------------------------- griffin-lim
def test_griffin_lim_uses_the_momu_mel_and_inverts_it() -> None:
    voc = VOCODERS.build("griffin_lim")
    assert (voc.sample_rate, voc.hop_length, voc.n_mels) == (16000, 256, 80)
    mel = momu_mel(tone(), SR)
    wav = voc(mel)
    assert wav.dtype == np.float32 and wav.ndim == 1 and np.abs(wav).max() <= 1.0
    assert momu_mel(wav, SR).shape == mel.shape  # frames survive the round trip
    again = momu_mel(wav, SR)
    err = np.abs(again - mel).mean()
    other = np.abs(momu_mel(tone(1500.0), SR) - mel).mean()
    assert err < 0.25 * other  # the re-analysed spectrum is the input's, not another sound's
    assert np.argmax(again.mean(axis=1)) == np.argmax(mel.mean(axis=1))  # same dominant band


def test_griffin_lim_batches_and_is_seeded() -> None:
    voc = VOCODERS.build("griffin_lim", {"n_iter": 4})
    mel = momu_mel(tone(seconds=0.3), SR)
    batch = voc(np.stack([mel, mel]))
    assert batch.shape == (2, voc(mel).shape[0])
    np.testing.assert_array_equal(voc(mel), voc(mel))
    np.testing.assert_array_equal(batch[0], voc(mel))  # item i is seeded with seed + i
    np.testing.assert_array_equal(batch[1], VOCODERS.build("griffin_lim", {"n_iter": 4, "seed": 1})(mel))
    assert not np.array_equal(batch[0], batch[1])


def test_griffin_lim_bad_input() -> None:
    voc = VOCODERS.build("griffin_lim", {"n_iter": 2})
    with pytest.raises(ValueError, match=r"mel: expected \(80, T\)"):
        voc(np.zeros((40, 10), dtype=np.float32))
    with pytest.raises(ValueError, match="mel: contains NaN"):
        voc(np.full((80, 10), np.nan, dtype=np.float32))
    with pytest.raises(ValueError, match="n_iter"):
        VOCODERS.build("griffin_lim", {"n_iter": 0})


def test_multiplicative_mel_inversion_solves_the_same_problem_better_than_its_start() -> None:
    from momu.features.audio import mel_filterbank, mel_to_power

    cfg = MoMuMelConfig()
    mel = momu_mel(tone(seconds=0.5) + 0.3 * tone(1500.0, seconds=0.5), SR)
    power = mel_to_power(mel, cfg)
    ref = VOCODERS.build("griffin_lim")
    basis = mel_filterbank(cfg)

    def residual(iters: int) -> float:
        voc = VOCODERS.build("griffin_lim", {"mel_inversion": "multiplicative", "inversion_iters": iters})
        mag = voc.magnitude(power)
        assert mag.shape == (cfg.n_fft // 2 + 1, mel.shape[1]) and (mag >= 0).all()
        return float(
            np.linalg.norm(basis @ mag.astype(np.float64) ** cfg.power - power) / np.linalg.norm(power)
        )

    start, ten, fifty = residual(0), residual(10), residual(50)
    assert fifty <= ten <= start  # Lee-Seung updates never increase the least-squares residual
    librosa_residual = float(
        np.linalg.norm(basis @ ref.magnitude(power).astype(np.float64) ** cfg.power - power)
        / np.linalg.norm(power)
    )
    assert ten <= librosa_residual * 1.05
    wav = VOCODERS.build("griffin_lim", {"mel_inversion": "multiplicative"})(mel)
    assert momu_mel(wav, SR).shape == mel.shape and np.abs(wav).max() <= 1.0


def _mel_power(seconds: float, dtype: type) -> tuple[np.ndarray, np.ndarray]:
    from momu.features.audio import mel_filterbank, mel_to_power

    cfg = MoMuMelConfig()
    rng = np.random.default_rng(0)
    audio = tone(seconds=seconds) + 0.2 * tone(1500.0, seconds=seconds) * (
        rng.random(int(SR * seconds)) > 0.5
    )
    power = mel_to_power(momu_mel(audio.astype(np.float32), SR), cfg).astype(dtype)
    return mel_filterbank(cfg).astype(dtype), power


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
@pytest.mark.parametrize("seconds", [0.5, 14.0])  # one column block; several (librosa's MAX_MEM_BLOCK)
def test_fast_nnls_is_librosa_nnls_bit_for_bit(seconds: float, dtype: type) -> None:
    import librosa

    from momu.vocoders.nnls import nnls

    basis, power = _mel_power(seconds, dtype)
    expected = librosa.util.nnls(basis, power)
    got = nnls(basis, power)
    assert got.dtype == expected.dtype and got.shape == expected.shape
    np.testing.assert_array_equal(got, expected)  # the same L-BFGS-B run, not a close one
    assert got.tobytes() == expected.tobytes()  # down to the sign of every zero


def test_fast_nnls_falls_back_to_librosa_without_scipys_routine(monkeypatch: pytest.MonkeyPatch) -> None:
    import librosa

    from momu.vocoders import nnls as fast

    basis, power = _mel_power(0.3, np.float32)
    expected = librosa.util.nnls(basis, power)

    def changed_signature(*args: object) -> None:
        raise TypeError("setulb() takes 16 positional arguments")

    for routine, reason in ((None, "has no"), (changed_signature, "takes 16")):
        monkeypatch.setattr(fast, "_setulb", lambda routine=routine: routine)
        with pytest.warns(RuntimeWarning, match=f"{reason}.*using librosa.util.nnls"):
            np.testing.assert_array_equal(fast.nnls(basis, power), expected)
    with pytest.raises(ValueError, match=r"b must be \(m, N\)"):
        fast.nnls(basis, power[0])


def test_griffin_lim_mel_inversion_options_are_checked() -> None:
    with pytest.raises(ValueError, match="griffin_lim.mel_inversion"):
        VOCODERS.build("griffin_lim", {"mel_inversion": "pinv"})
    with pytest.raises(ValueError, match="griffin_lim.inversion_iters"):
        VOCODERS.build("griffin_lim", {"inversion_iters": -1})


# ------------------------------------------------------------------------------- bigvgan
def test_bigvgan_default_builds_for_the_momu_mel() -> None:
    voc = VOCODERS.build("bigvgan")
    assert isinstance(voc, BigVGAN)
    assert voc.hop_length == MoMuMelConfig().hop_length == 256 and voc.n_mels == 80
    out = voc(torch.randn(1, 80, 2))
    assert out.shape == (1, 1, 512) and out.abs().max() <= 1.0


def test_bigvgan_shapes_and_vocoder_protocol() -> None:
    voc = VOCODERS.build("bigvgan", tiny_bigvgan_params(activation="snake"))
    assert voc(torch.randn(3, 8, 5)).shape == (3, 1, 80)
    wav = voc.synthesize(np.zeros((8, 7), dtype=np.float32))
    assert wav.shape == (7 * 16,) and wav.dtype == np.float32


def test_bigvgan_config_errors() -> None:
    with pytest.raises(ValueError, match="multiply to 8, but mel.hop_length is 16"):
        VOCODERS.build("bigvgan", tiny_bigvgan_params(upsample_rates=[4, 2]))
    with pytest.raises(ValueError, match="activation"):
        VOCODERS.build("bigvgan", tiny_bigvgan_params(activation="relu"))


def test_kaiser_filter_is_a_normalised_low_pass() -> None:
    taps = kaiser_sinc_filter1d(0.25, 0.3, 12)[0, 0]
    assert taps.sum().item() == pytest.approx(1.0, abs=1e-6)
    torch.testing.assert_close(taps, taps.flip(0))  # symmetric: linear phase
    response = torch.fft.rfft(taps, 256).abs()
    assert response[0] == pytest.approx(1.0, abs=1e-5) and response[-1] < 0.05  # passes DC, stops Nyquist


def test_bigvgan_loads_a_weight_normalised_torch_checkpoint(tmp_path: Path) -> None:
    torch.manual_seed(0)
    source = VOCODERS.build("bigvgan", tiny_bigvgan_params())
    state = source.state_dict()
    # write it as the official checkpoints do: weight-normalised convs under "generator"
    wn_state = {}
    for key, value in state.items():
        if key.endswith(".weight") and value.ndim == 3:
            norm = value.flatten(1).norm(dim=1).view(-1, 1, 1)
            wn_state[key[:-6] + "weight_g"] = norm
            wn_state[key[:-6] + "weight_v"] = value / norm * 3.0  # any scale of v gives the same weight
        else:
            wn_state[key] = value
    path = tmp_path / "g_00100000"
    torch.save({"generator": wn_state}, path)
    loaded = VOCODERS.build("bigvgan", tiny_bigvgan_params(checkpoint=str(path)))
    mel = torch.randn(1, 8, 4)
    torch.testing.assert_close(loaded(mel), source(mel), atol=1e-5, rtol=1e-5)


def test_bigvgan_loads_safetensors_and_rejects_mismatches(tmp_path: Path) -> None:
    source = VOCODERS.build("bigvgan", tiny_bigvgan_params())
    path = tmp_path / "g.safetensors"
    save_file({k: v.contiguous() for k, v in source.state_dict().items()}, str(path))
    loaded = VOCODERS.build("bigvgan", tiny_bigvgan_params(checkpoint=str(path)))
    mel = torch.randn(1, 8, 3)
    torch.testing.assert_close(loaded(mel), source(mel))
    with pytest.raises(ValueError, match="does not match the configured BigVGAN"):
        VOCODERS.build("bigvgan", tiny_bigvgan_params(checkpoint=str(path), upsample_initial_channel=32))
    with pytest.raises(FileNotFoundError, match="checkpoint not found"):
        load_bigvgan_state(tmp_path / "missing.pt")
    bad = tmp_path / "bad.pt"
    bad.write_bytes(b"not a checkpoint")
    with pytest.raises(ValueError, match="cannot read BigVGAN checkpoint"):
        load_bigvgan_state(bad)


def test_bigvgan_forward_path_can_overfit_one_waveform() -> None:
    """A tiny generator fits a fixed 2-tone waveform from its mel: the forward path is trainable."""
    torch.manual_seed(0)
    voc = VOCODERS.build("bigvgan", tiny_bigvgan_params())
    t = torch.arange(16 * 12) / 1000.0
    target = (0.4 * torch.sin(2 * np.pi * 40 * t) + 0.2 * torch.sin(2 * np.pi * 90 * t))[None, None]
    mel = torch.randn(1, 8, 12)
    opt = torch.optim.Adam(voc.parameters(), lr=3e-3)
    first = None
    for _ in range(150):
        loss = torch.nn.functional.l1_loss(voc(mel), target)
        first = loss.item() if first is None else first
        opt.zero_grad()
        loss.backward()
        opt.step()
    assert loss.item() < 0.3 * first
