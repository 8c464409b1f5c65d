"""Text–motion evaluation in the style of Guo et al. (T2M, CVPR 2022; MoFusion Table 2).

T2M scores text→motion with a pair of contrastively trained encoders, one for captions and one for
motions, and four numbers on their embeddings:

* **R-precision** (top-k, batch 32): the test pairs are grouped into batches of 32; for each caption
  the 32 motions of its batch are ranked by Euclidean distance to the caption's embedding, and the
  pair counts as a hit when its own motion is among the ``k`` nearest (T2M reports k = 1, 2, 3;
  MoFusion's 0.797 for real motions matches T2M's Top-3 column, so k = 3 here). A partial last batch
  is dropped, as in T2M. Per-item hits are returned so that comparisons can pair them.
* **MM-Dist**: the distance between a caption's embedding and its motion's.
* **Diversity**: the mean distance between the embeddings of random motion pairs (T2M: 300 pairs;
  here every pair of the evaluation set, :func:`~momu.metrics.diversity.average_pairwise_distance`).
* **Multi-Modality**: the mean distance between the embeddings of motions generated for the same
  caption, averaged over captions.

Two evaluators give the embeddings (both answer :class:`TextEvaluator`):

* **T2M's pre-trained evaluator** (:class:`~momu.metrics.t2m_evaluator.T2MEvaluator`), loaded from a
  user's local copy of T2M's ``finest.tar``, GloVe folder and ``mean.npy``/``std.npy`` (momu cannot
  download or ship them); it reads HumanML3D's 263-d features (converted from the 22 joints) and
  ``word/POS`` tokens (:func:`caption_tokens`), and its distances are on T2M's scale;
* otherwise :class:`TextMotionEvaluator`, a small pair of encoders trained from scratch with a
  symmetric InfoNCE loss on the dataset at hand; embeddings are unit vectors, so distances lie in
  [0, 2] and are not on T2M's scale. A folder saved by :meth:`TextMotionEvaluator.save` reloads with
  :meth:`TextMotionEvaluator.load`. It reads pose vectors ``(T, 3J)`` at 20 fps (MoFusion §3),
  standardised by its own statistics, and raw caption words.

Both take motions as MoFusion pose vectors (``embed_motions``) and captions as strings plus, where
known, their HumanML3D tokens (``embed_texts(texts, tokens)``).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any, Protocol

import numpy as np
import torch
import torch.nn.functional as F
from torch import Tensor, nn

from momu.encoders.text_transformer import TextTransformer, TextTransformerConfig, WordTokenizer
from momu.io import read_json, write_json
from momu.metrics.diversity import average_pairwise_distance
from momu.registry import METRICS

__all__ = [
    "TextEvaluator",
    "caption_tokens",
    "TextMotionEvaluatorConfig",
    "TextMotionEvaluator",
    "r_precision_hits",
    "mm_distances",
    "embedding_diversity",
    "embedding_multimodality",
    "contrastive_loss",
]


class TextEvaluator(Protocol):
    """What the text metrics need of an evaluator: caption and motion embeddings (rows in input order)."""

    kind: str

    def embed_texts(
        self, texts: Sequence[str], tokens: Sequence[Sequence[str] | None] | None = None
    ) -> np.ndarray: ...

    def embed_motions(self, poses: Sequence[np.ndarray]) -> np.ndarray: ...

    def describe(self) -> str: ...


def caption_tokens(clip: Any) -> list[str] | None:
    """HumanML3D's ``word/POS`` tokens of the clip's first caption (``Clip.text[0]``), or ``None``.

    They come from ``meta["text_tokens"]`` or from the ``humanml3d`` loader's
    ``meta["text_segments"]`` entry whose caption is ``text[0]``.
    """
    meta = getattr(clip, "meta", None) or {}
    if meta.get("text_tokens"):
        return [str(t) for t in meta["text_tokens"]]
    text = getattr(clip, "text", None) or []
    for seg in meta.get("text_segments") or []:
        if text and isinstance(seg, dict) and seg.get("caption") == text[0] and seg.get("tokens"):
            return [str(t) for t in seg["tokens"]]
    return None


@dataclass
class TextMotionEvaluatorConfig:
    """The from-scratch evaluator (momu's stand-in for T2M's).

    Attributes:
        channels: pose-vector width (3J).
        vocab: caption words (built from the training captions).
        embed_dim: joint embedding width.
        width: hidden width of both encoders.
        max_tokens: words per caption.
        temperature: InfoNCE temperature.
    """

    channels: int = 66
    vocab: list[str] = field(default_factory=lambda: ["<pad>", "<unk>"])
    embed_dim: int = 64
    width: int = 64
    max_tokens: int = 32
    temperature: float = 0.1


class TextMotionEvaluator(nn.Module):
    """Caption encoder (word Transformer, masked mean) and motion encoder (strided 1D convs + GRU)."""

    kind = "momu"

    def __init__(self, cfg: TextMotionEvaluatorConfig) -> None:
        super().__init__()
        self.cfg = cfg
        self.source = "momu evaluator trained from scratch"
        heads = 4 if cfg.width % 4 == 0 else 1
        self.text = TextTransformer(
            TextTransformerConfig(
                vocab=list(cfg.vocab), max_tokens=cfg.max_tokens, width=cfg.width, depth=2, heads=heads
            )
        )
        self.text_head = nn.Linear(cfg.width, cfg.embed_dim)
        c = cfg.width
        self.motion = nn.Sequential(
            nn.Conv1d(2 * cfg.channels, c, 5, padding=2),
            nn.GELU(),
            nn.Conv1d(c, c, 5, stride=2, padding=2),
            nn.GELU(),
            nn.Conv1d(c, c, 5, stride=2, padding=2),
            nn.GELU(),
        )
        self.gru = nn.GRU(c, c, batch_first=True, bidirectional=True)
        self.motion_head = nn.Linear(2 * c, cfg.embed_dim)
        self.mean: Tensor
        self.std: Tensor
        self.register_buffer("mean", torch.zeros(cfg.channels))
        self.register_buffer("std", torch.ones(cfg.channels))

    def set_statistics(self, poses: Sequence[np.ndarray]) -> None:
        flat = np.concatenate([np.asarray(p, dtype=np.float64) for p in poses])
        self.mean.copy_(torch.as_tensor(flat.mean(0), dtype=torch.float32))
        self.std.copy_(torch.as_tensor(flat.std(0), dtype=torch.float32).clamp_min(1e-4))

    def embed_text(self, texts: Sequence[str]) -> Tensor:
        ids, mask = self.text.tokenize(list(texts))
        ids, mask = ids.to(self.mean.device), mask.to(self.mean.device)
        h = self.text(ids, mask)
        pooled = h.sum(1) / mask.sum(1, keepdim=True).clamp_min(1)
        return F.normalize(self.text_head(pooled), dim=-1)

    def embed_motion(self, poses: Tensor, mask: Tensor | None = None) -> Tensor:
        """``poses (B, T, 3J)`` raw pose vectors (metres) -> unit embeddings ``(B, embed_dim)``."""
        x = (poses - self.mean) / self.std
        vel = torch.diff(x, dim=1, prepend=x[:, :1])
        h = self.motion(torch.cat([x, vel], dim=-1).transpose(1, 2)).transpose(1, 2)  # (B, T/4, C)
        out, _ = self.gru(h)
        if mask is None:
            pooled = out.mean(1)
        else:
            m = mask[:, ::4][:, : out.shape[1]].to(out.dtype)[..., None]
            pooled = (out * m).sum(1) / m.sum(1).clamp_min(1)
        return F.normalize(self.motion_head(pooled), dim=-1)

    @torch.no_grad()
    def embed_motions(self, poses: Sequence[np.ndarray], batch: int = 64) -> np.ndarray:
        """Unit embeddings of a list of ``(T_i, 3J)`` pose vectors (padded, masked)."""
        self.eval()
        out = []
        for s in range(0, len(poses), batch):
            chunk = [torch.as_tensor(np.asarray(p), dtype=torch.float32) for p in poses[s : s + batch]]
            longest = max(p.shape[0] for p in chunk)
            x = torch.zeros(len(chunk), longest, chunk[0].shape[-1])
            mask = torch.zeros(len(chunk), longest, dtype=torch.bool)
            for i, p in enumerate(chunk):
                x[i, : p.shape[0]], mask[i, : p.shape[0]] = p, True
            out.append(self.embed_motion(x, mask).cpu().numpy())
        return np.concatenate(out).astype(np.float64)

    def describe(self) -> str:
        return self.source

    @torch.no_grad()
    def embed_texts(
        self, texts: Sequence[str], tokens: Sequence[Sequence[str] | None] | None = None, batch: int = 256
    ) -> np.ndarray:
        """Unit embeddings of captions (``tokens`` are not used: this evaluator reads the words)."""
        self.eval()
        return np.concatenate(
            [self.embed_text(texts[s : s + batch]).cpu().numpy() for s in range(0, len(texts), batch)]
        ).astype(np.float64)

    def forward(self, batch: dict[str, Any]) -> tuple[Tensor, dict[str, float]]:
        """The training stage: symmetric InfoNCE over the batch's (caption, motion) pairs."""
        t = self.embed_text(batch["text"])
        m = self.embed_motion(batch["x"], batch.get("x_mask"))
        loss = contrastive_loss(t, m, self.cfg.temperature)
        return loss, {"infonce": float(loss.detach())}

    def save(self, folder: str | Path) -> Path:
        from safetensors.torch import save_file

        folder = Path(folder)
        folder.mkdir(parents=True, exist_ok=True)
        save_file(
            {k: v.contiguous() for k, v in self.state_dict().items()}, str(folder / "model.safetensors")
        )
        write_json(folder / "evaluator.json", {"kind": "text_motion_evaluator", "config": asdict(self.cfg)})
        return folder

    @classmethod
    def load(cls, folder: str | Path) -> TextMotionEvaluator:
        from safetensors.torch import load_file

        folder = Path(folder)
        meta = read_json(folder / "evaluator.json")
        if not isinstance(meta, dict) or meta.get("kind") != "text_motion_evaluator":
            raise ValueError(f"{folder / 'evaluator.json'}: not a text–motion evaluator")
        model = cls(TextMotionEvaluatorConfig(**meta["config"]))
        model.load_state_dict(load_file(str(folder / "model.safetensors")), strict=True)
        model.source = f"momu evaluator {folder}"
        return model.eval()


def contrastive_loss(text: Tensor, motion: Tensor, temperature: float) -> Tensor:
    """Symmetric InfoNCE of matched rows of two ``(B, D)`` unit-embedding sets."""
    logits = text @ motion.T / temperature
    target = torch.arange(text.shape[0], device=text.device)
    return 0.5 * (F.cross_entropy(logits, target) + F.cross_entropy(logits.T, target))


def _distances(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.linalg.norm(a[:, None, :] - b[None, :, :], axis=-1)


def r_precision_hits(text: np.ndarray, motion: np.ndarray, *, batch: int = 32, top_k: int = 3) -> np.ndarray:
    """Per-pair 0/1 hits ``(N',)`` of T2M's R-precision (top-``k`` within batches of ``batch``).

    Pair ``i`` of a batch is a hit when motion ``i`` is among the ``k`` motions of the batch nearest
    to caption ``i``. Only whole batches count (``N' = batch · ⌊N / batch⌋``).
    """
    if text.shape != motion.shape or text.ndim != 2:
        raise ValueError(
            f"r_precision: embeddings must be equal (N, D) arrays, got {text.shape} and {motion.shape}"
        )
    whole = (text.shape[0] // batch) * batch
    if whole == 0:
        raise ValueError(f"r_precision: {text.shape[0]} pairs, fewer than one batch of {batch}")
    hits = []
    for s in range(0, whole, batch):
        d = _distances(text[s : s + batch], motion[s : s + batch])
        own = np.diag(d)[:, None]
        rank = (d < own).sum(axis=1)  # motions strictly nearer than the pair's own
        hits.append((rank < top_k).astype(np.float64))
    return np.concatenate(hits)


def mm_distances(text: np.ndarray, motion: np.ndarray) -> np.ndarray:
    """Per-pair distance between a caption's and its motion's embedding (T2M's MM-Dist)."""
    return np.linalg.norm(np.asarray(text) - np.asarray(motion), axis=-1)


def embedding_diversity(motion: np.ndarray) -> float:
    """Mean pairwise distance of motion embeddings (T2M's Diversity over every pair)."""
    return float(average_pairwise_distance(np.asarray(motion, dtype=np.float64), accumulate="float64"))


def embedding_multimodality(groups: Sequence[np.ndarray]) -> float:
    """Mean over captions of the mean pairwise distance between their generations' embeddings."""
    return float(np.mean([embedding_diversity(g) for g in groups]))


def vocab_from(texts: Sequence[str], max_tokens: int) -> list[str]:
    return WordTokenizer.from_texts(texts, max_tokens).vocab


@dataclass
class TextMetricConfig:
    """Registered text–motion metrics: the evaluator is ``evaluator=`` (any :class:`TextEvaluator`),
    or T2M's pre-trained one when ``t2m_checkpoint``, ``glove_dir`` and ``t2m_meta_dir`` are set.

    Attributes:
        fps: the evaluator's motion rate (clips at another rate are resampled; MoFusion and T2M: 20).
        batch: R-precision's retrieval batch (T2M: 32).
        top_k: R-precision's k (T2M's Top-3).
        group_key: ``clip.meta`` key grouping generations of one caption (Multi-Modality).
        t2m_checkpoint: T2M's ``text_mot_match/model/finest.tar`` (a local file).
        glove_dir: T2M's ``glove/`` folder (``our_vab_data.npy``, ``our_vab_words.pkl``, ``our_vab_idx.pkl``).
        t2m_meta_dir: the folder of the evaluator's ``mean.npy`` / ``std.npy`` (T2M's
            ``checkpoints/t2m/Comp_v6_KLD01/meta``).
    """

    fps: float = 20.0
    batch: int = 32
    top_k: int = 3
    group_key: str = "condition_id"
    t2m_checkpoint: str | None = None
    glove_dir: str | None = None
    t2m_meta_dir: str | None = None


@dataclass
class TextMotionMetric:
    """``r_precision`` / ``mm_dist`` / ``text_diversity`` / ``text_multimodality`` over clips with
    3D ``motion`` and ``text`` (the caption each was generated for)."""

    cfg: TextMetricConfig
    name: str
    evaluator: TextEvaluator
    needs_reference: bool = False

    def _poses(self, clips: Sequence[Any]) -> list[np.ndarray]:
        from momu.features.mofusion_pose import encode_pose
        from momu.methods.mofusion.data import global_positions, resample_motion

        return [encode_pose(resample_motion(global_positions(c), c.fps, self.cfg.fps)) for c in clips]

    def __call__(self, generated: Sequence[Any], reference: Sequence[Any] | None = None) -> dict[str, float]:
        clips = list(generated)
        if len(clips) < 2:
            raise ValueError(f"{self.name}: needs at least 2 clips")
        motion = self.evaluator.embed_motions(self._poses(clips))
        if self.name == "text_diversity":
            return {self.name: embedding_diversity(motion)}
        if self.name == "text_multimodality":
            groups: dict[Any, list[int]] = {}
            for i, c in enumerate(clips):
                groups.setdefault(c.meta.get(self.cfg.group_key, c.text[0] if c.text else i), []).append(i)
            return {
                self.name: embedding_multimodality([motion[idx] for idx in groups.values() if len(idx) > 1])
            }
        if any(not c.text for c in clips):
            raise ValueError(f"{self.name}: every clip needs the caption it was generated for (Clip.text)")
        text = self.evaluator.embed_texts([str(c.text[0]) for c in clips], [caption_tokens(c) for c in clips])
        if self.name == "mm_dist":
            return {self.name: float(mm_distances(text, motion).mean())}
        return {
            self.name: float(
                r_precision_hits(text, motion, batch=self.cfg.batch, top_k=self.cfg.top_k).mean()
            )
        }


def _factory(name: str) -> Any:
    def build(cfg: TextMetricConfig, evaluator: TextEvaluator | None = None, **deps: Any) -> TextMotionMetric:
        paths = {
            "t2m_checkpoint": cfg.t2m_checkpoint,
            "glove_dir": cfg.glove_dir,
            "t2m_meta_dir": cfg.t2m_meta_dir,
        }
        if evaluator is None and any(paths.values()):
            unset = [k for k, v in paths.items() if not v]
            if unset:
                raise ValueError(f"{name}: T2M's evaluator also needs {', '.join(unset)} (local paths)")
            from momu.metrics.t2m_evaluator import T2MEvaluator

            evaluator = T2MEvaluator.load(str(cfg.t2m_checkpoint), str(cfg.glove_dir), str(cfg.t2m_meta_dir))
        if evaluator is not None and evaluator.kind == "t2m" and cfg.fps != 20.0:
            raise ValueError(f"{name}: T2M's evaluator reads 20 fps motion; fps is {cfg.fps}")
        if evaluator is None:
            raise ValueError(
                f"{name}: needs evaluator=<a text–motion evaluator>, or T2M's with t2m_checkpoint, "
                "glove_dir and t2m_meta_dir (local paths)"
            )
        return TextMotionMetric(cfg, name, evaluator)

    build.__name__ = f"build_{name}"
    build.__doc__ = f"``{name}`` on a text–motion evaluator's embeddings (T2M protocol; MoFusion Table 2)."
    return build


for _name in ("r_precision", "mm_dist", "text_diversity", "text_multimodality"):
    METRICS.register(_name, config=TextMetricConfig)(_factory(_name))
