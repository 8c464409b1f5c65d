"""``clip_text``: CLIP's ViT-B/32 text tower (MoFusion §3.3, supp. B), weights from a local file only.

MoFusion: "we use the pre-trained CLIP token embeddings. We first retrieve the tokenised embedding
for each word in the input prompt. Next, these token embeddings are position-encoded and subjected
to CLIP's transformer. Finally, we project the token embeddings using an MLP" (the MLP is the
U-Net's ``cond_proj: mlp``). The tower (Radford et al. 2021): BPE vocabulary 49,408, context 77,
width 512, 12 residual attention blocks with 8 heads (pre-LN, QuickGELU MLP ×4, causal mask),
``ln_final``; the token outputs ``ln_final(x)`` ``(B, 77, 512)`` are the condition, masked after the
end token. Frozen by default (the paper does not say; a frozen pre-trained encoder is the usual
choice and keeps the 63 M text parameters out of the optimiser).

Weights cannot be downloaded at run time: ``checkpoint`` must name a local file holding the CLIP
state dict with OpenAI / open_clip key names (``token_embedding.weight``, ``positional_embedding``,
``transformer.resblocks.{i}.…``, ``ln_final.*``, ``text_projection``; a full CLIP checkpoint's
``visual.*`` and ``logit_scale`` keys are ignored). Accepted: ``.safetensors``, or a ``torch.save``d
state dict (``.pt``/``.bin``, read with ``weights_only=True``; OpenAI's TorchScript ``ViT-B-32.pt``
must be converted to a state dict first, see docs/papers/mofusion.md). Loading is strict on the
text tower's keys and shapes.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import torch
from safetensors.torch import load_file
from torch import Tensor, nn

from momu.encoders.clip_bpe import CONTEXT_LENGTH, CLIPTokenizer, default_vocab_path
from momu.registry import ENCODERS

__all__ = ["CLIPTextConfig", "CLIPTextTower", "load_clip_text_state", "build_clip_text", "TEXT_PREFIXES"]

TEXT_PREFIXES = ("token_embedding.", "positional_embedding", "transformer.", "ln_final.", "text_projection")


@dataclass
class CLIPTextConfig:
    """CLIP text tower (ViT-B/32 defaults).

    Attributes:
        checkpoint: local file with CLIP weights (required by the registered part; no download).
        bpe_path: CLIP's ``bpe_simple_vocab_16e6.txt.gz``; ``None``: the copy installed by the
            ``open-clip-torch`` package (``momu[clip]``).
        frozen: keep the tower's weights fixed (no gradients, eval mode).
        vocab_size, context_length, width, layers, heads, embed_dim: the architecture (ViT-B/32:
            49408, 77, 512, 12, 8, 512).
    """

    checkpoint: str | None = None
    bpe_path: str | None = None
    frozen: bool = True
    vocab_size: int = 49408
    context_length: int = CONTEXT_LENGTH
    width: int = 512
    layers: int = 12
    heads: int = 8
    embed_dim: int = 512


class _QuickGELU(nn.Module):
    def forward(self, x: Tensor) -> Tensor:
        return x * torch.sigmoid(1.702 * x)


class _ResidualAttentionBlock(nn.Module):
    """CLIP's block: ``x + attn(ln_1(x))`` then ``x + mlp(ln_2(x))`` (state-dict names as CLIP's)."""

    def __init__(self, width: int, heads: int) -> None:
        super().__init__()
        self.attn = nn.MultiheadAttention(width, heads, batch_first=True)
        self.ln_1 = nn.LayerNorm(width)
        self.mlp = nn.Sequential()
        self.mlp.add_module("c_fc", nn.Linear(width, width * 4))
        self.mlp.add_module("gelu", _QuickGELU())
        self.mlp.add_module("c_proj", nn.Linear(width * 4, width))
        self.ln_2 = nn.LayerNorm(width)

    def forward(self, x: Tensor, causal: Tensor) -> Tensor:
        h = self.ln_1(x)
        x = x + self.attn(h, h, h, need_weights=False, attn_mask=causal)[0]
        return x + self.mlp(self.ln_2(x))


class _Transformer(nn.Module):
    def __init__(self, width: int, layers: int, heads: int) -> None:
        super().__init__()
        self.resblocks = nn.ModuleList(_ResidualAttentionBlock(width, heads) for _ in range(layers))

    def forward(self, x: Tensor, causal: Tensor) -> Tensor:
        for block in self.resblocks:
            x = block(x, causal)
        return x


class CLIPTextTower(nn.Module):
    """The CLIP text transformer; ``forward(ids, mask)`` returns the ``ln_final`` token outputs.

    Built directly it is randomly initialised (for tests and for converting weights); the registered
    ``clip_text`` part always loads a checkpoint.
    """

    def __init__(self, cfg: CLIPTextConfig, tokenizer: CLIPTokenizer | None = None) -> None:
        super().__init__()
        self.cfg = cfg
        self.width = int(cfg.width)
        self._tokenizer = tokenizer
        self.token_embedding = nn.Embedding(cfg.vocab_size, cfg.width)
        self.positional_embedding = nn.Parameter(torch.randn(cfg.context_length, cfg.width) * 0.01)
        self.transformer = _Transformer(cfg.width, cfg.layers, cfg.heads)
        self.ln_final = nn.LayerNorm(cfg.width)
        self.text_projection = nn.Parameter(torch.randn(cfg.width, cfg.embed_dim) * cfg.width**-0.5)
        causal = torch.full((cfg.context_length, cfg.context_length), float("-inf")).triu(1)
        self.causal: Tensor
        self.register_buffer("causal", causal, persistent=False)

    @property
    def tokenizer(self) -> CLIPTokenizer:
        if self._tokenizer is None:
            path = self.cfg.bpe_path or default_vocab_path()
            if path is None:
                raise FileNotFoundError(
                    "clip_text.bpe_path: CLIP's bpe_simple_vocab_16e6.txt.gz is needed for tokenising; "
                    "install momu[clip] (open-clip-torch ships it) or set bpe_path to the file"
                )
            self._tokenizer = CLIPTokenizer(path, self.cfg.context_length)
        return self._tokenizer

    def tokenize(self, texts: Sequence[str]) -> tuple[Tensor, Tensor]:
        """``(ids, mask)`` of ``(B, 77)``: SOT, BPE tokens, EOT, padding (mask True through EOT)."""
        return self.tokenizer(texts)

    def forward(self, ids: Tensor, mask: Tensor) -> Tensor:
        """``ids (B, L ≤ 77)`` -> ``(B, L, width)`` token outputs, zero after the end token."""
        length = ids.shape[1]
        if length > self.cfg.context_length:
            raise ValueError(f"ids: {length} tokens exceed the context length {self.cfg.context_length}")
        x = self.token_embedding(ids) + self.positional_embedding[:length]
        x = self.transformer(x, self.causal[:length, :length].to(x.dtype))
        return self.ln_final(x) * mask[..., None].to(x.dtype)

    def pooled(self, ids: Tensor, mask: Tensor) -> Tensor:
        """CLIP's sentence embedding ``(B, embed_dim)``: the end token's output @ ``text_projection``."""
        tokens = self.forward(ids, mask)
        last = mask.long().sum(dim=1) - 1
        return tokens[torch.arange(ids.shape[0]), last] @ self.text_projection

    def train(self, mode: bool = True) -> CLIPTextTower:
        return super().train(mode and not self.cfg.frozen)


def _read_state(path: Path) -> dict[str, Tensor]:
    if not path.is_file():
        raise FileNotFoundError(f"clip_text.checkpoint: {path} not found (CLIP weights are never downloaded)")
    if path.suffix == ".safetensors":
        return load_file(str(path))
    try:
        state: Any = torch.load(str(path), map_location="cpu", weights_only=True)
    except Exception as exc:  # TorchScript archives and pickles beyond plain tensors are refused
        raise ValueError(
            f"clip_text.checkpoint: {path} is not a plain state dict ({type(exc).__name__}); convert "
            "OpenAI's TorchScript file to safetensors first (docs/papers/mofusion.md)"
        ) from None
    if isinstance(state, dict) and "state_dict" in state and isinstance(state["state_dict"], dict):
        state = state["state_dict"]
    if not isinstance(state, dict):
        raise ValueError(f"clip_text.checkpoint: {path} does not hold a state dict")
    return {str(k).removeprefix("module."): v for k, v in state.items() if isinstance(v, Tensor)}


def load_clip_text_state(tower: CLIPTextTower, path: str | Path) -> None:
    """Load the text-tower keys of a CLIP checkpoint into ``tower``, strictly (errors name the keys)."""
    path = Path(path)
    state = {k: v for k, v in _read_state(path).items() if k.startswith(TEXT_PREFIXES)}
    expected = tower.state_dict()
    missing = sorted(set(expected) - set(state))
    unexpected = sorted(set(state) - set(expected))
    shapes = [
        f"{k}: {tuple(state[k].shape)} vs {tuple(v.shape)}"
        for k, v in expected.items()
        if k in state and state[k].shape != v.shape
    ]
    if missing or unexpected or shapes:
        raise ValueError(
            f"clip_text.checkpoint: {path} does not match the configured CLIP text tower: "
            f"missing {missing[:5]}, unexpected {unexpected[:5]}, shape mismatches {shapes[:5]}"
        )
    tower.load_state_dict({k: v.float() for k, v in state.items()}, strict=True)


@ENCODERS.register("clip_text", config=CLIPTextConfig)
def build_clip_text(cfg: CLIPTextConfig, **deps: object) -> CLIPTextTower:
    """The CLIP ViT-B/32 text tower with weights from ``cfg.checkpoint`` (MoFusion §3.3)."""
    if not cfg.checkpoint:
        raise ValueError(
            "clip_text.checkpoint: CLIP weights are required and cannot be downloaded; set "
            "checkpoint=<path to a local CLIP ViT-B/32 state dict (.safetensors or .pt)>"
        )
    tower = CLIPTextTower(cfg)
    load_clip_text_state(tower, cfg.checkpoint)
    if cfg.frozen:
        tower.requires_grad_(False)
        tower.eval()
    return tower
