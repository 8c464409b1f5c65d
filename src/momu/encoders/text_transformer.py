"""``text_transformer``: a word-level tokenizer plus a small Transformer trained from scratch.

The offline stand-in for MoFusion's CLIP text tower (§3.3) on the cpu preset: the vocabulary is built
from the training captions (:meth:`WordTokenizer.from_texts`), stored in the config (``vocab``), so a
saved part reloads with the same ids. Token outputs ``(B, L, width)`` with a padding mask are the
condition (MoFusion projects every token through an MLP into the U-Net's context; the U-Net's
``cond_proj: mlp`` does that).

Both text encoders (this one and ``clip_text``) follow one protocol, :class:`TextEncoder`:
``tokenize(texts) -> (ids, mask)`` and ``forward(ids, mask) -> (B, L, width)``.
"""

from __future__ import annotations

import re
from collections import Counter
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from typing import Protocol, runtime_checkable

import torch
from torch import Tensor, nn

from momu.backbones.blocks import scaled_init_std
from momu.registry import ENCODERS

__all__ = [
    "TextEncoder",
    "WordTokenizer",
    "TextTransformerConfig",
    "TextTransformer",
    "build_text_transformer",
    "PAD",
    "UNK",
]

PAD, UNK = "<pad>", "<unk>"
_WORD = re.compile(r"[a-z0-9]+|[^\sa-z0-9]")


@runtime_checkable
class TextEncoder(Protocol):
    """What a text condition encoder provides (``text_transformer``, ``clip_text``, plugins)."""

    width: int

    def tokenize(self, texts: Sequence[str]) -> tuple[Tensor, Tensor]: ...

    def __call__(self, ids: Tensor, mask: Tensor) -> Tensor: ...


class WordTokenizer:
    """Lower-cased words and punctuation marks -> ids; ``<pad>`` = 0, ``<unk>`` = 1."""

    def __init__(self, vocab: Sequence[str], max_tokens: int) -> None:
        vocab = list(vocab)
        if vocab[:2] != [PAD, UNK] or len(set(vocab)) != len(vocab):
            raise ValueError("text_transformer.vocab must start with '<pad>', '<unk>' and hold no duplicates")
        if max_tokens < 1:
            raise ValueError(f"text_transformer.max_tokens must be >= 1, got {max_tokens}")
        self.vocab = vocab
        self.index = {w: i for i, w in enumerate(vocab)}
        self.max_tokens = int(max_tokens)

    @staticmethod
    def words(text: str) -> list[str]:
        return _WORD.findall(text.lower())

    @classmethod
    def from_texts(cls, texts: Iterable[str], max_tokens: int, min_count: int = 1) -> WordTokenizer:
        """A deterministic vocabulary: words seen ``min_count`` times or more, by count then spelling."""
        counts = Counter(w for t in texts for w in cls.words(t))
        words = sorted((w for w, n in counts.items() if n >= min_count), key=lambda w: (-counts[w], w))
        return cls([PAD, UNK, *words], max_tokens)

    def __call__(self, texts: Sequence[str]) -> tuple[Tensor, Tensor]:
        """``(ids (B, L) long, mask (B, L) bool)``, ``L`` the longest (≤ ``max_tokens``, ≥ 1) text."""
        rows = [[self.index.get(w, 1) for w in self.words(t)][: self.max_tokens] or [1] for t in texts]
        length = max((len(r) for r in rows), default=1)
        ids = torch.zeros(len(rows), length, dtype=torch.long)
        mask = torch.zeros(len(rows), length, dtype=torch.bool)
        for i, r in enumerate(rows):
            ids[i, : len(r)] = torch.tensor(r)
            mask[i, : len(r)] = True
        return ids, mask


@dataclass
class TextTransformerConfig:
    """A small text Transformer (momu's; MoFusion uses CLIP ViT-B/32, §3.3 / supp. B).

    Attributes:
        vocab: the word list (``<pad>``, ``<unk>``, then the words); built from the training
            captions by the method (:meth:`WordTokenizer.from_texts`).
        max_tokens: words kept per caption.
        width, depth, heads, mlp_ratio, dropout: the Transformer encoder (pre-norm, GELU).
    """

    vocab: list[str] = field(default_factory=lambda: [PAD, UNK])
    max_tokens: int = 32
    width: int = 128
    depth: int = 2
    heads: int = 4
    mlp_ratio: float = 4.0
    dropout: float = 0.0


class TextTransformer(nn.Module):
    """Word embeddings + learned positions -> Transformer encoder -> LayerNorm'd token outputs."""

    def __init__(self, cfg: TextTransformerConfig) -> None:
        super().__init__()
        self.tokenizer = WordTokenizer(cfg.vocab, cfg.max_tokens)
        if cfg.width % cfg.heads:
            raise ValueError(f"text_transformer: width {cfg.width} not divisible by heads={cfg.heads}")
        self.cfg = cfg
        self.width = int(cfg.width)
        self.embed = nn.Embedding(len(cfg.vocab), cfg.width, padding_idx=0)
        self.positions = nn.Parameter(torch.randn(cfg.max_tokens, cfg.width) * scaled_init_std(cfg.width))
        layer = nn.TransformerEncoderLayer(
            cfg.width,
            cfg.heads,
            int(cfg.width * cfg.mlp_ratio),
            cfg.dropout,
            activation="gelu",
            batch_first=True,
            norm_first=True,
        )
        self.encoder = nn.TransformerEncoder(layer, cfg.depth, enable_nested_tensor=False)
        self.norm = nn.LayerNorm(cfg.width)

    def tokenize(self, texts: Sequence[str]) -> tuple[Tensor, Tensor]:
        return self.tokenizer(texts)

    def forward(self, ids: Tensor, mask: Tensor) -> Tensor:
        """``ids (B, L)``, ``mask (B, L)`` -> token outputs ``(B, L, width)`` (zero at padding)."""
        if ids.shape[1] > self.cfg.max_tokens:
            raise ValueError(
                f"ids: {ids.shape[1]} tokens, text_transformer.max_tokens is {self.cfg.max_tokens}"
            )
        h = self.embed(ids) + self.positions[: ids.shape[1]]
        h = self.encoder(h, src_key_padding_mask=~mask)
        return self.norm(h) * mask[..., None].to(h.dtype)


@ENCODERS.register("text_transformer", config=TextTransformerConfig)
def build_text_transformer(cfg: TextTransformerConfig, **deps: object) -> TextTransformer:
    """A from-scratch text encoder (the cpu preset's stand-in for CLIP in MoFusion Table 2)."""
    return TextTransformer(cfg)
