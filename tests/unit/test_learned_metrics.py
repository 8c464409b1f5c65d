"""Learned-feature metrics (MoMu §5, App. B.4–B.5; METRICS.md §3.1) on hand-checkable cases.

The extractors here are small untrained networks: the metric arithmetic does not depend on training.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
import torch

from momu.data.types import Clip
from momu.encoders.dstformer import DSTformerConfig
from momu.metrics import inter_diversity, intra_diversity, mean_kl_divergence
from momu.metrics.extractors import (
    AudioClassifier,
    AudioClassifierConfig,
    AudioClassifierEmbedding,
    MotionClassifier,
    MotionClassifierConfig,
    MotionExtractor,
    file_sha256,
    save_extractor,
)
from momu.registry import METRICS

SR = 16000


# ------------------------------------------------------------------------------- Mean KLD
def test_mean_kld_paired_hand_value() -> None:
    ref = np.log([[0.5, 0.5], [0.9, 0.1]])
    gen = np.log([[0.25, 0.75], [0.9, 0.1]])
    expected = (0.5 * math.log(0.5 / 0.25) + 0.5 * math.log(0.5 / 0.75) + 0.0) / 2
    assert mean_kl_divergence(ref, gen) == pytest.approx(expected, rel=1e-12)


def test_mean_kld_marginal_hand_value_and_identity() -> None:
    ref = np.log([[1.0 - 1e-12, 1e-12], [1e-12, 1.0 - 1e-12]])  # mean (0.5, 0.5)
    gen = np.log([[0.25, 0.75], [0.25, 0.75], [0.25, 0.75]])  # mean (0.25, 0.75)
    expected = 0.5 * math.log(0.5 / 0.25) + 0.5 * math.log(0.5 / 0.75)
    assert mean_kl_divergence(ref, gen, mode="marginal") == pytest.approx(expected, rel=1e-9)
    assert mean_kl_divergence(gen, gen) == 0.0
    assert mean_kl_divergence(gen, gen, mode="marginal") == 0.0


def test_mean_kld_errors() -> None:
    p = np.log([[0.5, 0.5]])
    with pytest.raises(ValueError, match="normalised"):
        mean_kl_divergence(np.array([[0.0, 0.0]]), p)
    with pytest.raises(ValueError, match="marginal"):
        mean_kl_divergence(p, np.log([[0.5, 0.5], [0.1, 0.9]]))
    with pytest.raises(ValueError, match="class counts"):
        mean_kl_divergence(p, np.log([[0.2, 0.3, 0.5]]))
    with pytest.raises(ValueError, match="mode"):
        mean_kl_divergence(p, p, mode="pairwise")


# ------------------------------------------------------------------------------- Diversity
def test_inter_diversity_all_pairs_hand_value() -> None:
    feats = np.array([[0.0], [3.0], [4.0]])  # pair distances 3, 4, 1
    assert inter_diversity(feats) == pytest.approx(8.0 / 3.0)
    # permuting the pieces does not change the mean over all pairs
    assert inter_diversity(feats[[2, 0, 1]]) == pytest.approx(8.0 / 3.0)


def test_inter_diversity_uses_one_piece_per_input() -> None:
    feats = np.array([[0.0, 0.0], [100.0, 0.0], [0.0, 5.0]])
    groups = ["a", "a", "b"]  # the second "a" piece is never used
    assert inter_diversity(feats, groups) == pytest.approx(5.0)


def test_inter_diversity_samples_pairs_reproducibly() -> None:
    rng = np.random.default_rng(0)
    feats = rng.normal(size=(60, 4))
    a = inter_diversity(feats, num_pieces=50, num_pairs=200, seed=3)
    assert a == inter_diversity(feats, num_pieces=50, num_pairs=200, seed=3)
    dists = np.linalg.norm(feats[:, None] - feats[None], axis=-1)
    assert dists[dists > 0].min() <= a <= dists.max()


def test_intra_diversity_hand_value() -> None:
    feats = np.array([[0.0], [3.0], [10.0], [10.0], [13.0], [99.0]])
    groups = ["a", "a", "b", "b", "b", "c"]  # a: 3; b: (0 + 3 + 3)/3 = 2; c: single piece, skipped
    assert intra_diversity(feats, groups) == pytest.approx(2.5)
    with pytest.raises(ValueError, match="2 or more"):
        intra_diversity(feats[:1], ["a"])


def test_diversity_errors() -> None:
    with pytest.raises(ValueError, match="2 different inputs"):
        inter_diversity(np.zeros((3, 2)), ["x", "x", "x"])
    with pytest.raises(ValueError, match="NaN"):
        inter_diversity(np.array([[0.0], [np.nan]]))
    with pytest.raises(ValueError, match="groups"):
        intra_diversity(np.zeros((3, 2)), ["a"])


# ------------------------------------------------------------------------------- metrics over clips
def _motion_extractor() -> MotionExtractor:
    torch.manual_seed(0)
    cfg = MotionClassifierConfig(
        class_names=["a", "b", "c"],
        window=10,
        fps=10.0,
        dstformer=DSTformerConfig(num_joints=4, dim_in=2, dim_feat=8, dim_rep=4, depth=1, num_heads=2),
    )
    return MotionExtractor(MotionClassifier(cfg))


def _motion_clips(n: int, seed: int, *, scale: float = 1.0, condition: bool = False) -> list[Clip]:
    rng = np.random.default_rng(seed)
    clips = []
    for i in range(n):
        motion = rng.normal(size=(12, 4, 2)).astype(np.float32) * scale
        meta = {"condition_id": i // 2} if condition else {}
        clips.append(Clip(id=f"m{seed}_{i}", motion=motion, fps=10.0, meta=meta))
    return clips


def test_fid_learned_identical_sets_zero_and_different_sets_positive() -> None:
    ext = _motion_extractor()
    metric = METRICS.build("fid_learned", extractor=ext)
    a = _motion_clips(6, 0)
    b = [
        Clip(id=c.id, motion=c.motion + np.linspace(0, 3, 12)[:, None, None] * [1, 0], fps=10.0)
        for c in _motion_clips(6, 1)
    ]
    assert abs(metric(a, a)["fid_learned"]) < 1e-6
    assert metric(b, a)["fid_learned"] > 1e-3
    assert metric.needs_reference


def test_fid_learned_equals_frechet_distance_of_features() -> None:
    from momu.metrics.frechet import frechet_distance

    ext = _motion_extractor()
    a, b = _motion_clips(5, 0), _motion_clips(5, 1)
    got = METRICS.build("fid_learned", extractor=ext)(a, b)["fid_learned"]
    want = frechet_distance(ext.clip_features(a), ext.clip_features(b), variant="mint")
    assert got == pytest.approx(want, rel=1e-9)


def test_mean_kld_metric_identical_zero_and_matches_function() -> None:
    ext = _motion_extractor()
    metric = METRICS.build("mean_kld", extractor=ext)
    a, b = _motion_clips(4, 0), _motion_clips(4, 1, scale=3.0)
    assert metric(a, a)["mean_kld"] == 0.0
    want = mean_kl_divergence(ext.log_probabilities(a), ext.log_probabilities(b))
    assert metric(b, a)["mean_kld"] == pytest.approx(want)
    with pytest.raises(ValueError, match="marginal"):
        metric(b[:3], a)
    marginal = METRICS.build("mean_kld", {"mode": "marginal"}, extractor=ext)
    assert marginal(b[:3], a)["mean_kld"] >= 0.0


def test_diversity_metric_inter_and_intra() -> None:
    ext = _motion_extractor()
    clips = _motion_clips(6, 0, condition=True)  # 3 inputs × 2 pieces
    result = METRICS.build("diversity", extractor=ext)(clips)
    feats = ext.clip_features(clips)
    groups = [c.meta["condition_id"] for c in clips]
    assert result["diversity.inter"] == pytest.approx(inter_diversity(feats, groups))
    assert result["diversity.intra"] == pytest.approx(intra_diversity(feats, groups))
    no_groups = METRICS.build("diversity", extractor=ext)(_motion_clips(4, 1))
    assert set(no_groups) == {"diversity.inter"}


def test_metrics_without_extractor_explain_how_to_get_one() -> None:
    metric = METRICS.build("fid_learned")
    assert metric.provenance()["extractor"] is None
    with pytest.raises(ValueError, match="momu extractor train --kind motion"):
        metric(_motion_clips(2, 0), _motion_clips(2, 1))
    with pytest.raises(ValueError, match="--kind audio"):
        METRICS.build("fad")([Clip("a", None, 30.0)], [Clip("b", None, 30.0)])
    with pytest.raises(ValueError, match="mode"):
        METRICS.build("mean_kld", {"mode": "joint"})
    with pytest.raises(ValueError, match="modality"):
        METRICS.build("diversity", {"modality": "dance"})


def test_provenance_names_extractor_and_checkpoint_hash(tmp_path: Path) -> None:
    ext = _motion_extractor()
    path = tmp_path / "motion.safetensors"
    digest = save_extractor(path, ext.model, provenance={"git_commit": "0123abc"})
    assert digest == file_sha256(path)
    assert json.loads(path.with_suffix(".json").read_text())["git_commit"] == "0123abc"
    for name in ("fid_learned", "mean_kld", "diversity"):
        metric = METRICS.build(name, {"extractor": str(path)})
        prov = metric.provenance()
        assert prov["extractor"]["sha256"] == digest
        assert prov["extractor"]["kind"] == "motion_classifier"
        assert prov["extractor"]["checkpoint"] == str(path)
        assert prov["extractor"]["config"]["class_names"] == ["a", "b", "c"]
    a = _motion_clips(4, 0)
    assert abs(METRICS.build("fid_learned", {"extractor": str(path)})(a, a)["fid_learned"]) < 1e-6


# ------------------------------------------------------------------------------- FAD
def _tone(freq: float, seconds: float = 2.0, noise: float = 0.0, seed: int = 0) -> np.ndarray:
    t = np.arange(int(seconds * SR)) / SR
    rng = np.random.default_rng(seed)
    return (0.5 * np.sin(2 * np.pi * freq * t) + noise * rng.normal(size=t.shape)).astype(np.float32)


def _audio_embedding() -> AudioClassifierEmbedding:
    torch.manual_seed(0)
    cfg = AudioClassifierConfig(class_names=["x", "y"], segment_frames=16, channels=[4, 8], embed_dim=6)
    return AudioClassifierEmbedding(AudioClassifier(cfg))


def test_fad_pools_segments_and_is_zero_for_identical_sets() -> None:
    from momu.metrics.frechet import frechet_distance

    emb = _audio_embedding()
    metric = METRICS.build("fad", extractor=emb)
    ref = [
        Clip(f"r{i}", None, 30.0, audio=_tone(220 * (i + 1), noise=0.05, seed=i), sample_rate=SR)
        for i in range(3)
    ]
    gen = [
        Clip(f"g{i}", None, 30.0, audio=_tone(300 * (i + 1), noise=0.2, seed=9 + i), sample_rate=SR)
        for i in range(3)
    ]
    # 2 s at 62.5 mel frames/s = 126 frames -> 7 segments of 16 frames per clip, all pooled
    assert emb.frame_embeddings(ref[0]).shape == (7, 6)
    assert abs(metric(ref, ref)["fad"]) < 1e-6
    value = metric(gen, ref)["fad"]
    pooled_gen = np.concatenate([emb.frame_embeddings(c) for c in gen])
    pooled_ref = np.concatenate([emb.frame_embeddings(c) for c in ref])
    assert value == pytest.approx(frechet_distance(pooled_gen, pooled_ref, variant="mint"))
    assert value > 0


def test_music_diversity_uses_mean_segment_embedding() -> None:
    emb = _audio_embedding()
    clips = [Clip(f"g{i}", None, 30.0, audio=_tone(200 + 150 * i), sample_rate=SR) for i in range(3)]
    result = METRICS.build("diversity", {"modality": "music"}, extractor=emb)(clips)
    feats = np.stack([emb.frame_embeddings(c).mean(0) for c in clips])
    assert result["diversity.inter"] == pytest.approx(inter_diversity(feats))


def test_audio_errors_name_the_clip() -> None:
    emb = _audio_embedding()
    with pytest.raises(ValueError, match="'short'.*shorter"):
        emb.frame_embeddings(Clip("short", None, 30.0, audio=np.zeros(1000, np.float32), sample_rate=SR))
    with pytest.raises(ValueError, match="'silent'.*no audio"):
        emb.frame_embeddings(Clip("silent", None, 30.0))
