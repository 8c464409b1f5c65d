"""T2M's pre-trained text–motion evaluator (Guo et al., CVPR 2022; MoFusion §4.2, Table 2).

The evaluator HumanML3D results are reported with (Diversity, Multi-Modality, R-precision,
MM-Dist): three modules whose parameter names and shapes are those of ``text2motion``'s
``networks/modules.py``, so that its checkpoint ``checkpoints/t2m/text_mot_match/model/finest.tar``
loads strictly:

* ``movement_encoder`` (:class:`MovementConvEncoder`): two stride-2 convolutions (kernel 4) over the
  263-d features without the 4 foot contacts → 512-d movement codes, one per 4 frames;
* ``motion_encoder`` (:class:`MotionEncoderBiGRUCo`): a bidirectional GRU (1024) over the movement
  codes → 512-d motion embedding;
* ``text_encoder`` (:class:`TextEncoderBiGRUCo`): GloVe word vectors plus projected POS one-hots
  (:mod:`momu.metrics.t2m_words`) through a bidirectional GRU (512) → 512-d text embedding.

Both GRUs read packed sequences and start from a learned hidden state; the embedding is the
concatenated last forward/backward states through a Linear–LayerNorm–LeakyReLU–Linear head.

Motions: ``(T, 22, 3)`` joints at 20 fps are turned into HumanML3D features
(:func:`momu.features.humanml_vec.humanml_features`, ``T − 1`` frames), cut to a multiple of 4 frames
(T2M's ``unit_length``; T2M crops at a random offset, momu at the start, so results are
deterministic) and to at most 196, z-scored with the evaluator's ``mean.npy`` / ``std.npy``
(``checkpoints/t2m/Comp_v6_KLD01/meta/``) and zero-padded to 196 frames as T2M's loaders do
(the padding reaches the last movement code through the convolution). Embeddings are not unit
vectors: distances are on T2M's scale (real HumanML3D test motions: Diversity ≈ 9.5).

The checkpoint is read with ``torch.load(..., weights_only=True)`` (tensors and plain containers
only); GloVe's ``.pkl`` files through the restricted unpickler.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import torch
from torch import Tensor, nn
from torch.nn.utils.rnn import pack_padded_sequence

from momu.data.files import DataFileError, MissingDataFileError, absent_reason, load_npy
from momu.features.humanml_vec import FEATURE_DIM, humanml_features
from momu.features.mofusion_pose import decode_pose
from momu.metrics.t2m_words import POS_ENUMERATOR, WordVectorizer, caption_arrays

__all__ = [
    "T2MDims",
    "MovementConvEncoder",
    "MotionEncoderBiGRUCo",
    "TextEncoderBiGRUCo",
    "T2MEvaluator",
    "CHECKPOINT_MODULES",
    "UNIT_LENGTH",
    "MAX_MOTION_LENGTH",
]

UNIT_LENGTH = 4
MAX_MOTION_LENGTH = 196
CHECKPOINT_MODULES = ("text_encoder", "motion_encoder", "movement_encoder")
"""The checkpoint's top-level keys holding the three state dicts (T2M also stores optimiser
states, ``epoch`` and ``iter``, which are not read)."""


@dataclass(frozen=True)
class T2MDims:
    """Widths of the three modules; the defaults are T2M's HumanML3D evaluator's (``dim_text_hidden``
    512, ``dim_motion_hidden`` 1024, ``dim_coemb_hidden`` 512, ``dim_movement_enc_hidden`` and
    ``dim_movement_latent`` 512), the only ones its checkpoint loads with."""

    text_hidden: int = 512
    motion_hidden: int = 1024
    embedding: int = 512
    movement_hidden: int = 512
    movement_latent: int = 512


def _head(hidden: int, output: int) -> nn.Sequential:
    return nn.Sequential(
        nn.Linear(2 * hidden, hidden), nn.LayerNorm(hidden), nn.LeakyReLU(0.2), nn.Linear(hidden, output)
    )


def _last_states(gru: nn.GRU, x: Tensor, lengths: Tensor, hidden: Tensor) -> Tensor:
    """Concatenated final forward and backward states of ``gru`` over the first ``lengths`` steps."""
    packed = pack_padded_sequence(x, lengths.cpu(), batch_first=True, enforce_sorted=False)
    _, last = gru(packed, hidden.expand(-1, x.shape[0], -1).contiguous())
    return torch.cat([last[0], last[1]], dim=-1)


class MovementConvEncoder(nn.Module):
    """``(B, T, 259)`` normalised features → ``(B, T/4, 512)`` movement codes (T2M's movement encoder)."""

    def __init__(
        self, input_size: int = FEATURE_DIM - 4, hidden_size: int = 512, output_size: int = 512
    ) -> None:
        super().__init__()
        self.main = nn.Sequential(
            nn.Conv1d(input_size, hidden_size, 4, 2, 1),
            nn.Dropout(0.2),
            nn.LeakyReLU(0.2),
            nn.Conv1d(hidden_size, output_size, 4, 2, 1),
            nn.Dropout(0.2),
            nn.LeakyReLU(0.2),
        )
        self.out_net = nn.Linear(output_size, output_size)

    def forward(self, x: Tensor) -> Tensor:
        return self.out_net(self.main(x.transpose(1, 2)).transpose(1, 2))


class MotionEncoderBiGRUCo(nn.Module):
    """Movement codes and their lengths → ``(B, 512)`` motion embeddings."""

    def __init__(self, input_size: int = 512, hidden_size: int = 1024, output_size: int = 512) -> None:
        super().__init__()
        self.input_emb = nn.Linear(input_size, hidden_size)
        self.gru = nn.GRU(hidden_size, hidden_size, batch_first=True, bidirectional=True)
        self.output_net = _head(hidden_size, output_size)
        self.hidden = nn.Parameter(torch.randn(2, 1, hidden_size))

    def forward(self, movements: Tensor, lengths: Tensor) -> Tensor:
        return self.output_net(_last_states(self.gru, self.input_emb(movements), lengths, self.hidden))


class TextEncoderBiGRUCo(nn.Module):
    """Word vectors, POS one-hots and caption lengths → ``(B, 512)`` text embeddings."""

    def __init__(
        self,
        word_size: int = 300,
        pos_size: int = len(POS_ENUMERATOR),
        hidden_size: int = 512,
        output_size: int = 512,
    ) -> None:
        super().__init__()
        self.pos_emb = nn.Linear(pos_size, word_size)
        self.input_emb = nn.Linear(word_size, hidden_size)
        self.gru = nn.GRU(hidden_size, hidden_size, batch_first=True, bidirectional=True)
        self.output_net = _head(hidden_size, output_size)
        self.hidden = nn.Parameter(torch.randn(2, 1, hidden_size))

    def forward(self, words: Tensor, pos: Tensor, lengths: Tensor) -> Tensor:
        x = self.input_emb(words + self.pos_emb(pos))
        return self.output_net(_last_states(self.gru, x, lengths, self.hidden))


def _state_dict(checkpoint: Any, key: str, module: nn.Module, path: Path) -> dict[str, Tensor]:
    """``checkpoint[key]`` checked against ``module``'s parameter names and shapes (one-line errors)."""
    state = checkpoint.get(key)
    if not isinstance(state, dict) or not all(isinstance(v, Tensor) for v in state.values()):
        raise DataFileError(
            path, f"key {key!r}: expected a state dict of tensors, got {type(state).__name__}"
        )
    want = module.state_dict()
    missing, extra = sorted(set(want) - set(state)), sorted(set(state) - set(want))
    if missing or extra:
        raise DataFileError(
            path, f"key {key!r}: missing {missing}, unexpected {extra} (not T2M's {type(module).__name__})"
        )
    shapes = [
        f"{k} {tuple(state[k].shape)} != {tuple(v.shape)}"
        for k, v in want.items()
        if state[k].shape != v.shape
    ]
    if shapes:
        raise DataFileError(path, f"key {key!r}: wrong shapes: {'; '.join(shapes[:3])}")
    return state


def _statistic(path: Path) -> np.ndarray:
    value = load_npy(path)
    if value.shape != (FEATURE_DIM,) or not np.all(np.isfinite(value)):
        raise DataFileError(
            path, f"expected {FEATURE_DIM} finite values (HumanML3D features), got {value.shape}"
        )
    return value.astype(np.float32)


class T2MEvaluator(nn.Module):
    """T2M's evaluator (module docstring): :meth:`load` it, then :meth:`embed_texts` / :meth:`embed_motions`.

    Args:
        words: the GloVe vectorizer.
        mean, std: ``(263,)`` feature statistics the evaluator was trained with.
        source: what was loaded (for the results' record).
    """

    kind = "t2m"

    def __init__(
        self,
        words: WordVectorizer,
        mean: np.ndarray,
        std: np.ndarray,
        dims: T2MDims = T2MDims(),
        source: str = "",
    ) -> None:
        super().__init__()
        self.text_encoder = TextEncoderBiGRUCo(
            word_size=words.dim, hidden_size=dims.text_hidden, output_size=dims.embedding
        )
        self.motion_encoder = MotionEncoderBiGRUCo(dims.movement_latent, dims.motion_hidden, dims.embedding)
        self.movement_encoder = MovementConvEncoder(
            FEATURE_DIM - 4, dims.movement_hidden, dims.movement_latent
        )
        self.words = words
        self.mean = torch.as_tensor(mean, dtype=torch.float32)
        self.std = torch.as_tensor(std, dtype=torch.float32)
        self.source = source

    @classmethod
    def load(
        cls, checkpoint: str | Path, glove_dir: str | Path, meta_dir: str | Path, dims: T2MDims = T2MDims()
    ) -> T2MEvaluator:
        """T2M's ``finest.tar``, its ``glove/`` folder and the ``meta/`` folder of ``mean.npy`` / ``std.npy``
        (``dims``: module widths, T2M's by default).

        Raises:
            DataFileError: a missing, unreadable or mismatching file (message: the file and the key).
        """
        path = Path(checkpoint).expanduser()
        meta = Path(meta_dir).expanduser()
        words = WordVectorizer.load(glove_dir)
        model = cls(words, _statistic(meta / "mean.npy"), _statistic(meta / "std.npy"), dims)
        if np.any(model.std.numpy() <= 0):
            raise DataFileError(meta / "std.npy", "non-positive standard deviations")
        if not path.is_file():
            raise MissingDataFileError(path, absent_reason(path))
        try:
            state = torch.load(path, map_location="cpu", weights_only=True)
        except Exception as exc:  # torch raises UnpicklingError, RuntimeError, EOFError, ...
            reason = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
            raise DataFileError(
                path, f"not a checkpoint torch.load(weights_only=True) accepts ({reason})"
            ) from None
        if not isinstance(state, dict):
            raise DataFileError(
                path, f"expected a dict with {', '.join(CHECKPOINT_MODULES)}, got {type(state).__name__}"
            )
        for key in CHECKPOINT_MODULES:
            if key not in state:
                raise DataFileError(path, f"missing key {key!r} (has {', '.join(sorted(map(str, state)))})")
            module = getattr(model, key)
            module.load_state_dict(_state_dict(state, key, module, path), strict=True)
        epoch = state.get("epoch")
        model.source = f"T2M evaluator {path}" + (f" (epoch {epoch})" if isinstance(epoch, int) else "")
        return model.eval()

    def describe(self) -> str:
        return self.source or "T2M evaluator"

    # ------------------------------------------------------------------------------------------ texts
    @torch.no_grad()
    def embed_texts(
        self, texts: Sequence[str], tokens: Sequence[Sequence[str] | None] | None = None, batch: int = 256
    ) -> np.ndarray:
        """``(N, 512)`` embeddings of captions given as HumanML3D ``word/POS`` tokens (``texts`` only
        name them in errors: T2M reads no raw text)."""
        given = list(tokens) if tokens is not None else [None] * len(texts)
        bare = [str(t) for t, k in zip(texts, given, strict=False) if not k]
        if len(given) != len(texts) or bare:
            raise ValueError(
                "t2m evaluator: every caption needs HumanML3D word/POS tokens (texts/<id>.txt, "
                f"Clip.meta['text_segments']); none for {bare[0] if bare else 'some captions'!r}"
            )
        self.eval()
        out = []
        for s in range(0, len(texts), batch):
            arrays = [caption_arrays(self.words, list(t or [])) for t in given[s : s + batch]]
            lengths = torch.tensor([a[0].shape[0] for a in arrays])
            longest = int(lengths.max())
            words = torch.zeros(len(arrays), longest, self.words.dim)
            pos = torch.zeros(len(arrays), longest, len(POS_ENUMERATOR))
            for i, (w, p) in enumerate(arrays):
                words[i, : len(w)], pos[i, : len(p)] = torch.from_numpy(w), torch.from_numpy(p)
            out.append(self.text_encoder(words, pos, lengths).numpy())
        return np.concatenate(out).astype(np.float64)

    # ------------------------------------------------------------------------------------------ motions
    @torch.no_grad()
    def embed_features(self, features: Sequence[np.ndarray], batch: int = 64) -> np.ndarray:
        """``(N, 512)`` embeddings of raw (not normalised) ``(T_i, 263)`` HumanML3D features at 20 fps."""
        self.eval()
        out = []
        for s in range(0, len(features), batch):
            chunk = features[s : s + batch]
            x = torch.zeros(len(chunk), MAX_MOTION_LENGTH, FEATURE_DIM)
            lengths = []
            for i, f in enumerate(chunk):
                f = np.asarray(f, dtype=np.float32)
                if f.ndim != 2 or f.shape[1] != FEATURE_DIM:
                    raise ValueError(f"t2m evaluator: features must be (T, {FEATURE_DIM}), got {f.shape}")
                n = min(len(f), MAX_MOTION_LENGTH) // UNIT_LENGTH * UNIT_LENGTH
                if n == 0:
                    raise ValueError(
                        f"t2m evaluator: a motion of {len(f)} feature frames is shorter than {UNIT_LENGTH}"
                    )
                x[i, :n] = (torch.from_numpy(f[:n]) - self.mean) / self.std
                lengths.append(n // UNIT_LENGTH)
            movements = self.movement_encoder(x[..., :-4])
            out.append(self.motion_encoder(movements, torch.tensor(lengths)).numpy())
        return np.concatenate(out).astype(np.float64)

    def embed_motions(self, poses: Sequence[np.ndarray], batch: int = 64) -> np.ndarray:
        """``(N, 512)`` embeddings of MoFusion pose vectors ``(T_i, 66)`` (HumanML3D's 22 joints, 20 fps)."""
        feats = []
        for p in poses:
            p = np.asarray(p, dtype=np.float64)
            if p.ndim != 2 or p.shape[1] != 66:
                raise ValueError(
                    f"t2m evaluator: pose vectors must be (T, 66) (humanml22, 20 fps), got {p.shape}"
                )
            feats.append(humanml_features(decode_pose(p, 22)))
        return self.embed_features(feats, batch)
