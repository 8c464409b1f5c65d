"""Learned feature extractors behind ``fid_learned``, ``mean_kld``, ``diversity`` and ``fad``.

MoMu-Diffusion evaluates generated motion with features of a motion style classifier ("a MotionBert
encoder and a classification head", trained with Adam, lr 1e-4, 100 epochs on the dataset's genres —
MoMu App. B.5) and generated music with VGGish embeddings (App. B.4). momu provides:

* :class:`MotionClassifier` — the shared :class:`~momu.encoders.dstformer.DSTformer` encoder plus
  MotionBERT's classification head (time-mean pooling, joints flattened, ``Linear → LayerNorm → ReLU →
  Linear``), trained on labelled clips (``Clip.style``). Its *feature* is the pooled encoder
  representation (B.5: "we use the trained MotionBert encoder as the feature extractor").
* :class:`AudioClassifier` — a small log-mel CNN trained on the dataset's style labels; the default
  audio embedding, because VGGish weights cannot be downloaded here. It embeds every 0.96 s segment of
  a clip (60 frames of MoMu's 62.5 frames/s mel), like VGGish embeds 0.96 s examples.
* :class:`~momu.metrics.vggish.VGGish` with user-provided local weights (:class:`VGGishEmbedding`).

Extractors are trained by :func:`train_extractor` (CLI: ``momu extractor train``), saved by
:func:`save_extractor` as ``FILE.safetensors`` (weights) plus ``FILE.json`` (kind, config, training
summary; no pickle), and reloaded strictly by :func:`load_extractor`. Every loaded extractor knows the
sha256 of its weights file and reports it in :meth:`provenance`, which every learned metric copies.

Motion preprocessing (both training and evaluation, so they see the same inputs): positions are
resampled to the classifier's ``fps`` (linear interpolation), divided by the clip's body scale (mean
distance of the joints from their per-frame centroid — so pixels and metres look alike), cut into
windows of ``window`` frames, and each window is translated so its first frame's centroid is the origin.
A clip's feature is the frame-weighted mean of its windows' pooled representations (the last, partial
window is padded and masked), i.e. the time-mean of the encoder output over the whole clip.
"""

from momu.metrics.extractors.networks import (
    KINDS,
    AudioClassifier,
    AudioClassifierConfig,
    MotionClassifier,
    MotionClassifierConfig,
    audio_segments,
    motion_windows,
    prepare_motion,
)
from momu.metrics.extractors.storage import (
    AudioClassifierEmbedding,
    AudioEmbedding,
    MotionExtractor,
    VGGishEmbedding,
    file_sha256,
    load_audio_embedding,
    load_extractor,
    save_extractor,
)
from momu.metrics.extractors.training import (
    TrainConfig,
    train_audio_classifier,
    train_extractor,
    train_motion_classifier,
)

__all__ = [
    "KINDS",
    "MotionClassifierConfig",
    "AudioClassifierConfig",
    "TrainConfig",
    "MotionClassifier",
    "AudioClassifier",
    "MotionExtractor",
    "AudioEmbedding",
    "AudioClassifierEmbedding",
    "VGGishEmbedding",
    "file_sha256",
    "prepare_motion",
    "motion_windows",
    "audio_segments",
    "train_extractor",
    "train_motion_classifier",
    "train_audio_classifier",
    "save_extractor",
    "load_extractor",
    "load_audio_embedding",
]
