"""VGGish front end and network (FAD's embedding), with random weights and local weight files."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import torch
from safetensors.torch import save_file

from momu.data.types import Clip
from momu.metrics.extractors import VGGishEmbedding, file_sha256, load_audio_embedding
from momu.metrics.vggish import (
    VGGish,
    load_state_dict_file,
    load_vggish,
    vggish_examples,
    vggish_log_mel,
    vggish_mel_matrix,
)
from momu.registry import METRICS

SR = 16000


def _hz_to_mel(f: float) -> float:
    return 1127.0 * np.log(1.0 + f / 700.0)


def test_example_framing_counts() -> None:
    # 2 s at 16 kHz: 1 + (32000 - 400) // 160 = 198 STFT frames -> 1 + (198 - 96) // 96 = 2 examples
    assert vggish_log_mel(np.zeros(32000, np.float32), SR).shape == (198, 64)
    assert vggish_examples(np.zeros(32000, np.float32), SR).shape == (2, 96, 64)
    assert vggish_examples(np.zeros(15000, np.float32), SR).shape == (0, 96, 64)
    # other sample rates are resampled to 16 kHz first
    assert vggish_examples(np.zeros(44100, np.float32), 22050).shape == (2, 96, 64)


def test_silence_is_log_offset() -> None:
    np.testing.assert_allclose(vggish_log_mel(np.zeros(8000, np.float32), SR), np.log(0.01))


def test_mel_matrix_structure() -> None:
    m = vggish_mel_matrix(257)
    assert m.shape == (257, 64)
    assert np.all(m[0] == 0) and m.min() >= 0 and m.max() <= 1
    hz = np.linspace(0, 8000, 257)
    assert np.all(m[hz < 125] == 0) and np.all(m[hz > 7500] == 0)


def test_tone_lands_in_its_mel_band() -> None:
    t = np.arange(SR) / SR
    log_mel = vggish_log_mel((0.5 * np.sin(2 * np.pi * 1000 * t)).astype(np.float32), SR)
    edges = np.linspace(_hz_to_mel(125), _hz_to_mel(7500), 66)
    expected = int(np.argmin(np.abs(edges[1:-1] - _hz_to_mel(1000))))
    assert abs(int(log_mel.mean(axis=0).argmax()) - expected) <= 1


@pytest.fixture(scope="module")
def vggish_file(tmp_path_factory: pytest.TempPathFactory) -> tuple[VGGish, Path]:
    """A randomly initialised VGGish saved as a (float16) safetensors state dict."""
    torch.manual_seed(0)
    model = VGGish().half().float().eval()  # weights exactly representable in float16
    path = tmp_path_factory.mktemp("vggish") / "vggish.safetensors"
    save_file({k: v.half().contiguous() for k, v in model.state_dict().items()}, str(path))
    return model, path


def test_vggish_shapes_and_strict_round_trip(vggish_file: tuple[VGGish, Path]) -> None:
    model, path = vggish_file
    loaded = load_vggish(path)
    x = torch.from_numpy(vggish_examples(np.random.default_rng(0).normal(size=32000).astype(np.float32), SR))
    with torch.no_grad():
        out = model(x[:, None])
        assert out.shape == (2, 128)
        torch.testing.assert_close(loaded(x[:, None]), out)
        # FAD drops the final ReLU (gudgud96 use_activation=False): embeddings can be negative
        assert (out < 0).any()


def test_vggish_embedding_clip_and_fad_provenance(vggish_file: tuple[VGGish, Path]) -> None:
    _, path = vggish_file
    emb = load_audio_embedding(path)  # auto: no momu .json beside it -> VGGish
    assert isinstance(emb, VGGishEmbedding)
    rng = np.random.default_rng(1)
    clip = Clip("c", None, 30.0, audio=rng.normal(scale=0.1, size=3 * SR).astype(np.float32), sample_rate=SR)
    assert emb.frame_embeddings(clip).shape == (3, 128)
    fad = METRICS.build("fad", {"extractor": str(path), "embedding": "vggish"})
    clips = [
        clip,
        Clip("d", None, 30.0, audio=rng.normal(scale=0.3, size=3 * SR).astype(np.float32), sample_rate=SR),
    ]
    assert abs(fad(clips, clips)["fad"]) < 1e-3
    prov = fad.provenance()["extractor"]
    assert prov["kind"] == "vggish" and prov["sha256"] == file_sha256(path)


def test_state_dict_files_are_read_safely(tmp_path: Path) -> None:
    state = {"a.weight": torch.arange(6.0).reshape(2, 3)}
    torch.save({"state_dict": state}, tmp_path / "w.pt")
    got = load_state_dict_file(tmp_path / "w.pt")
    torch.testing.assert_close(got["a.weight"], state["a.weight"])
    torch.save({"x": object()}, tmp_path / "evil.pt")  # needs arbitrary unpickling: refused
    with pytest.raises(ValueError, match="cannot read weights"):
        load_state_dict_file(tmp_path / "evil.pt")
    with pytest.raises(FileNotFoundError):
        load_state_dict_file(tmp_path / "missing.pt")


def test_load_vggish_rejects_wrong_keys(tmp_path: Path) -> None:
    save_file({"features.0.weight": torch.zeros(64, 1, 3, 3)}, str(tmp_path / "partial.safetensors"))
    with pytest.raises(ValueError, match=r"(?s)not a VGGish state dict.*Missing key"):
        load_vggish(tmp_path / "partial.safetensors")
