"""CLIP's byte-level BPE tokenizer (Radford et al. 2021; MoFusion §3.3 "tokenised embedding for
each word"), written from the published algorithm.

* text is cleaned (HTML entities unescaped, whitespace collapsed, lower-cased; ``ftfy.fix_text``
  first when ftfy is installed), split by CLIP's pattern (contractions, letter runs, single digits,
  runs of other symbols; the ``regex`` module's ``\\p{L}``/``\\p{N}`` classes);
* each piece's UTF-8 bytes map to printable unicode characters (``bytes_to_unicode``), the last
  character gets the end-of-word marker ``</w>``, and the lowest-ranked merge is applied until none
  applies;
* a sequence is ``<|startoftext|>`` + tokens + ``<|endoftext|>``, cut to the context length (77)
  with the last slot kept for the end token, zero-padded.

The merge list is CLIP's ``bpe_simple_vocab_16e6.txt.gz`` (MIT licence, 262,145 lines). momu does not
ship it: :func:`default_vocab_path` finds the copy that the ``open-clip-torch`` package installs
(``pip install 'momu[clip]'``) without importing open_clip, or the user points ``bpe_path`` at the file.
"""

from __future__ import annotations

import gzip
import html
import importlib.util
from collections.abc import Sequence
from functools import cache
from pathlib import Path

import regex
import torch

__all__ = ["CLIPTokenizer", "bytes_to_unicode", "default_vocab_path", "SOT", "EOT", "CONTEXT_LENGTH"]

SOT = "<|startoftext|>"
EOT = "<|endoftext|>"
CONTEXT_LENGTH = 77
_NUM_MERGES = 49152 - 256 - 2
_PATTERN = regex.compile(
    r"""<\|startoftext\|>|<\|endoftext\|>|'s|'t|'re|'ve|'m|'ll|'d|[\p{L}]+|[\p{N}]|[^\s\p{L}\p{N}]+""",
    regex.IGNORECASE,
)


@cache
def bytes_to_unicode() -> dict[int, str]:
    """CLIP/GPT-2's reversible map of the 256 byte values onto printable unicode characters."""
    keep = list(range(ord("!"), ord("~") + 1)) + list(range(ord("¡"), ord("¬") + 1))
    keep += list(range(ord("®"), ord("ÿ") + 1))
    chars = keep[:]
    extra = 0
    for b in range(256):
        if b not in keep:
            keep.append(b)
            chars.append(256 + extra)
            extra += 1
    return dict(zip(keep, (chr(c) for c in chars)))


def default_vocab_path() -> Path | None:
    """The merge file installed by ``open-clip-torch`` (found without importing it), or ``None``."""
    try:
        spec = importlib.util.find_spec("open_clip")
    except (ImportError, ValueError):
        return None
    for folder in (spec.submodule_search_locations or []) if spec else []:
        path = Path(folder) / "bpe_simple_vocab_16e6.txt.gz"
        if path.is_file():
            return path
    return None


def _clean(text: str) -> str:
    try:
        import ftfy

        text = ftfy.fix_text(text)
    except ImportError:
        pass
    text = html.unescape(html.unescape(text))
    return " ".join(text.split()).strip().lower()


class CLIPTokenizer:
    """CLIP's BPE tokenizer from a merge file (``bpe_simple_vocab_16e6.txt.gz`` or a plain text copy).

    Args:
        path: the merge file (first line a header, then one ``"a b"`` merge per line).
        context_length: tokens per sequence (CLIP: 77).
        num_merges: merges used (CLIP: 48,894); a smaller file uses all of its merges.
    """

    def __init__(self, path: str | Path, context_length: int = CONTEXT_LENGTH, num_merges: int = _NUM_MERGES):
        path = Path(path)
        if not path.is_file():
            raise FileNotFoundError(f"{path}: CLIP BPE merge file not found")
        opener = gzip.open if path.suffix == ".gz" else open
        try:
            with opener(path, "rt", encoding="utf-8") as handle:  # type: ignore[operator]
                lines = handle.read().split("\n")
        except (OSError, UnicodeDecodeError) as exc:
            raise ValueError(f"{path}: cannot read the BPE merge file: {exc}") from None
        merges = [tuple(line.split()) for line in lines[1 : num_merges + 1] if line.strip()]
        if not merges or any(len(m) != 2 for m in merges):
            raise ValueError(f"{path}: not a BPE merge file (expected 'a b' pairs after a header line)")
        self.byte_encoder = bytes_to_unicode()
        vocab = list(self.byte_encoder.values())
        vocab += [v + "</w>" for v in vocab]
        vocab += ["".join(m) for m in merges]
        vocab += [SOT, EOT]
        self.encoder = {tok: i for i, tok in enumerate(vocab)}
        self.ranks = {m: i for i, m in enumerate(merges)}
        self.context_length = int(context_length)
        self.sot, self.eot = self.encoder[SOT], self.encoder[EOT]
        self._cache: dict[str, list[str]] = {SOT: [SOT], EOT: [EOT]}

    @property
    def vocab_size(self) -> int:
        return len(self.encoder)

    def _bpe(self, piece: str) -> list[str]:
        if piece in self._cache:
            return self._cache[piece]
        word = list(piece[:-1]) + [piece[-1] + "</w>"]
        while len(word) > 1:
            pairs = {(word[i], word[i + 1]) for i in range(len(word) - 1)}
            best = min(pairs, key=lambda p: self.ranks.get(p, float("inf")))  # type: ignore[arg-type]
            if best not in self.ranks:
                break
            merged: list[str] = []
            i = 0
            while i < len(word):
                if i < len(word) - 1 and (word[i], word[i + 1]) == best:
                    merged.append(word[i] + word[i + 1])
                    i += 2
                else:
                    merged.append(word[i])
                    i += 1
            word = merged
        self._cache[piece] = word
        return word

    def encode(self, text: str) -> list[int]:
        """Token ids of ``text`` without the start/end tokens."""
        ids: list[int] = []
        for piece in _PATTERN.findall(_clean(text)):
            chars = "".join(self.byte_encoder[b] for b in piece.encode("utf-8"))
            ids.extend(self.encoder[t] for t in self._bpe(chars))
        return ids

    def __call__(self, texts: Sequence[str]) -> tuple[torch.Tensor, torch.Tensor]:
        """``(ids (B, context_length) long, mask (B, context_length) bool)``: SOT, tokens, EOT, zeros.

        The mask covers every position up to and including the end token (MoFusion uses the token
        outputs; the padding after EOT is masked out).
        """
        n = self.context_length
        ids = torch.zeros(len(texts), n, dtype=torch.long)
        mask = torch.zeros(len(texts), n, dtype=torch.bool)
        for i, text in enumerate(texts):
            tokens = [self.sot, *self.encode(text)][: n - 1] + [self.eot]
            ids[i, : len(tokens)] = torch.tensor(tokens)
            mask[i, : len(tokens)] = True
        return ids, mask
