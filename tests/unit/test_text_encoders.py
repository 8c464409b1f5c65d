"""MoFusion's text encoders: CLIP's BPE tokenizer (golden ids), the CLIP text tower loaded strictly from
a local checkpoint (random weights saved and reloaded), and the from-scratch ``text_transformer``."""

from __future__ import annotations

import gzip
from pathlib import Path

import pytest
import torch
from safetensors.torch import save_file

from momu.encoders.clip_bpe import CLIPTokenizer, bytes_to_unicode, default_vocab_path
from momu.encoders.clip_text import CLIPTextConfig, CLIPTextTower
from momu.encoders.text_transformer import TextEncoder, WordTokenizer
from momu.parts_io import load_part, save_part
from momu.registry import ENCODERS

TINY = {"vocab_size": 600, "context_length": 16, "width": 32, "layers": 2, "heads": 4, "embed_dim": 24}


def _tiny_merges(path: Path) -> Path:
    """A tiny merge file: 'h e', 'l l', 'he ll', 'o</w>' pieces — enough to exercise the algorithm."""
    with gzip.open(path, "wt", encoding="utf-8") as f:
        f.write("#version: test\nh e\nl l\nhe ll\nhell o</w>\n")
    return path


def test_bpe_algorithm_on_a_tiny_merge_file(tmp_path: Path) -> None:
    tok = CLIPTokenizer(_tiny_merges(tmp_path / "m.txt.gz"))
    byte = bytes_to_unicode()
    assert len(byte) == 256 and len(set(byte.values())) == 256
    assert tok.vocab_size == 512 + 4 + 2
    hello = tok.encoder["hello</w>"]
    assert tok.encode("Hello") == [hello] and tok.encode("  HELLO &amp; ") == [hello, tok.encoder["&</w>"]]
    ids, mask = CLIPTokenizer(tmp_path / "m.txt.gz", context_length=4)(["hello hello hello hello", "hello"])
    assert ids[0].tolist() == [tok.sot, hello, hello, tok.eot]  # cut with the end token kept
    assert ids[1].tolist() == [tok.sot, hello, tok.eot, 0] and mask[1].tolist() == [True, True, True, False]


def test_bpe_file_errors_name_the_file(tmp_path: Path) -> None:
    with pytest.raises(FileNotFoundError, match="nope.gz"):
        CLIPTokenizer(tmp_path / "nope.gz")
    bad = tmp_path / "bad.txt"
    bad.write_text("header\nonly-one-token\n")
    with pytest.raises(ValueError, match="bad.txt"):
        CLIPTokenizer(bad)


@pytest.mark.skipif(
    default_vocab_path() is None, reason="CLIP's BPE vocab needs momu[clip] (open-clip-torch)"
)
def test_clip_tokenizer_golden_ids() -> None:
    tok = CLIPTokenizer(default_vocab_path())  # type: ignore[arg-type]
    assert tok.vocab_size == 49408
    ids, mask = tok(["a photo of a cat"])
    assert ids[0, :7].tolist() == [49406, 320, 1125, 539, 320, 2368, 49407] and int(mask.sum()) == 7
    # the same ids as open_clip's SimpleTokenizer (checked once against open_clip 3.3.0)
    assert tok.encode("a person does a plié, then turns left!") == [
        320, 2533, 1897, 320, 30001, 4166, 267, 1594, 3185, 1823, 256,
    ]  # fmt: skip
    assert tok.encode("it's 3 o'clock &amp; the dancer's   pirouette") == [
        585, 568, 274, 334, 262, 6716, 261, 518, 11400, 568, 4351, 520, 5212,
    ]  # fmt: skip


def _checkpoint(tmp_path: Path, tower: CLIPTextTower, *, drop: str | None = None) -> Path:
    state = {k: v.clone() for k, v in tower.state_dict().items()}
    state["visual.conv1.weight"] = torch.zeros(2, 2)  # a full CLIP checkpoint: image tower ignored
    state["logit_scale"] = torch.tensor(4.6)
    if drop:
        state.pop(drop)
    path = tmp_path / "clip.safetensors"
    save_file(state, str(path))
    return path


def test_clip_text_loads_random_weights_strictly(tmp_path: Path) -> None:
    torch.manual_seed(0)
    tok = CLIPTokenizer(_tiny_merges(tmp_path / "m.txt.gz"), context_length=16)
    source = CLIPTextTower(CLIPTextConfig(**TINY), tokenizer=tok).eval()
    ckpt = _checkpoint(tmp_path, source)
    loaded = ENCODERS.build(
        "clip_text", {**TINY, "checkpoint": str(ckpt), "bpe_path": str(tmp_path / "m.txt.gz")}
    )
    assert isinstance(loaded, TextEncoder) and not any(p.requires_grad for p in loaded.parameters())
    loaded.train()
    assert not loaded.training  # frozen: stays in eval mode
    ids, mask = loaded.tokenize(["hello hello", "hello"])
    with torch.no_grad():
        out = loaded(ids, mask)
        torch.testing.assert_close(out, source(ids, mask))
    assert out.shape == (2, 16, 32) and float(out[1, 3:].abs().max()) == 0.0
    assert loaded.pooled(ids, mask).shape == (2, 24)
    # causal: a later token never changes an earlier output
    ids2 = ids.clone()
    ids2[0, 2] = 5
    with torch.no_grad():
        torch.testing.assert_close(loaded(ids2, mask)[0, :2], out[0, :2])
    # saved as a momu part and reloaded
    part = save_part(loaded, "encoders", "clip_text", loaded.cfg, tmp_path / "part")
    again = load_part(part)
    with torch.no_grad():
        torch.testing.assert_close(again(ids, mask), out)


def test_clip_text_errors(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match="checkpoint"):
        ENCODERS.build("clip_text", {})
    with pytest.raises(FileNotFoundError, match="missing.safetensors"):
        ENCODERS.build("clip_text", {**TINY, "checkpoint": str(tmp_path / "missing.safetensors")})
    tower = CLIPTextTower(CLIPTextConfig(**TINY))
    ckpt = _checkpoint(tmp_path, tower, drop="ln_final.weight")
    with pytest.raises(ValueError, match="ln_final.weight"):
        ENCODERS.build("clip_text", {**TINY, "checkpoint": str(ckpt)})
    wrong = {**TINY, "width": 64, "heads": 4}
    with pytest.raises(ValueError, match="shape mismatches"):
        ENCODERS.build("clip_text", {**wrong, "checkpoint": str(_checkpoint(tmp_path, tower))})


def test_word_tokenizer_vocab_is_deterministic_and_masks() -> None:
    texts = ["a person dances: a plie, then a glide.", "a person dances hiphop: a bounce."]
    tok = WordTokenizer.from_texts(texts, max_tokens=6)
    assert tok.vocab[:7] == ["<pad>", "<unk>", "a", ".", ":", "dances", "person"]
    assert WordTokenizer.from_texts(list(reversed(texts)), 6).vocab == tok.vocab
    ids, mask = tok(["a plie", "a person dances a zumba move forever and ever"])
    assert ids.shape == (2, 6) and mask[0].tolist() == [True, True] + [False] * 4
    assert ids[1, 4].item() == 1  # "zumba" is unknown


def test_text_transformer_trains_and_ignores_padding(tmp_path: Path) -> None:
    torch.manual_seed(0)
    vocab = WordTokenizer.from_texts(["a person does a plie", "a glide then a bounce"], 8).vocab
    enc = ENCODERS.build("text_transformer", {"vocab": vocab, "max_tokens": 8, "width": 16, "heads": 2})
    ids, mask = enc.tokenize(["a plie", "a glide then a bounce"])
    out = enc(ids, mask)
    assert out.shape == (2, 5, 16) and float(out[0, 2:].detach().abs().max()) == 0.0
    out.sum().backward()
    assert enc.embed.weight.grad is not None
    alone = enc(*enc.tokenize(["a plie"]))
    torch.testing.assert_close(alone[0], out[0, :2], atol=1e-5, rtol=1e-5)
    again = load_part(save_part(enc, "encoders", "text_transformer", enc.cfg, tmp_path / "tt"))
    torch.testing.assert_close(again(ids, mask), out)
