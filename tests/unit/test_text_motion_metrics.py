"""T2M-style text–motion metrics (MoFusion Table 2): R-precision, MM-Dist, Diversity, Multi-Modality,
and the from-scratch evaluator telling real pairs from shuffled ones."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from momu.data.synth import SynthConfig, SynthDance
from momu.metrics.text_motion import (
    TextMotionEvaluator,
    TextMotionEvaluatorConfig,
    contrastive_loss,
    embedding_multimodality,
    mm_distances,
    r_precision_hits,
    vocab_from,
)
from momu.registry import METRICS


def test_r_precision_on_constructed_embeddings() -> None:
    rng = np.random.default_rng(0)
    text = rng.normal(size=(64, 8))
    assert r_precision_hits(text, text, batch=32, top_k=1).tolist() == [1.0] * 64  # own motion nearest
    far = text + 100.0  # a shifted set: only whole batches are scored
    hits = r_precision_hits(text, np.roll(text, 1, axis=0), batch=32, top_k=3)
    assert hits.shape == (64,) and hits.mean() < 0.2
    assert r_precision_hits(text[:40], far[:40], batch=32).shape == (32,)  # partial batch dropped
    with pytest.raises(ValueError, match="fewer than one batch"):
        r_precision_hits(text[:5], text[:5], batch=32)
    np.testing.assert_allclose(mm_distances(text, text), 0.0)
    groups = [np.zeros((3, 2)), np.array([[0.0, 0.0], [3.0, 4.0]])]
    assert embedding_multimodality(groups) == pytest.approx((0.0 + 5.0) / 2)


def test_contrastive_loss_prefers_matched_pairs() -> None:
    a = torch.nn.functional.normalize(torch.randn(8, 4), dim=-1)
    assert float(contrastive_loss(a, a, 0.1)) < float(contrastive_loss(a, a.roll(1, 0), 0.1))


def test_a_few_steps_of_training_separate_real_from_shuffled(tmp_path) -> None:
    torch.manual_seed(0)
    ds = SynthDance(
        SynthConfig(num_clips=48, min_seconds=2.0, max_seconds=2.0, skeleton="humanml22", fps=20.0)
    )
    clips = [ds[i] for i in range(len(ds))]
    from momu.features.mofusion_pose import encode_pose

    poses = [encode_pose(c.motion.astype(np.float64)) for c in clips]
    texts = [c.text[0] for c in clips]
    model = TextMotionEvaluator(TextMotionEvaluatorConfig(channels=66, vocab=vocab_from(texts, 32), width=32))
    model.set_statistics(poses)
    opt = torch.optim.AdamW(model.parameters(), lr=3e-3)
    x = torch.as_tensor(np.stack(poses), dtype=torch.float32)
    for _ in range(40):
        loss, _ = model({"x": x, "text": texts})
        opt.zero_grad()
        loss.backward()
        opt.step()
    t, m = model.embed_texts(texts), model.embed_motions(poses)
    real = r_precision_hits(t[:32], m[:32], batch=32).mean()
    shuffled = r_precision_hits(t[:32], np.roll(m[:32], 1, axis=0), batch=32).mean()
    assert real > shuffled + 0.3
    metric = METRICS.build("r_precision", {"batch": 16}, evaluator=model)
    assert 0.0 <= metric(clips[:32])["r_precision"] <= 1.0
    with pytest.raises(ValueError, match="evaluator"):
        METRICS.build("mm_dist", {})
    again = TextMotionEvaluator.load(model.save(tmp_path / "evaluator"))
    np.testing.assert_allclose(again.embed_motions(poses[:4]), m[:4], atol=1e-6)
