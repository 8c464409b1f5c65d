"""Hypothesis properties of MoMu's Mean KLD and inter/intra diversity (METRICS.md §3.1)."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from momu.metrics import inter_diversity, intra_diversity, mean_kl_divergence

_logits = arrays(np.float64, st.tuples(st.integers(1, 6), st.integers(2, 5)), elements=st.floats(-20, 20))


def _log_softmax(x: np.ndarray) -> np.ndarray:
    return x - np.logaddexp.reduce(x, axis=1, keepdims=True)


@settings(deadline=None)
@given(a=_logits, seed=st.integers(0, 2**16))
def test_kld_nonnegative_and_zero_on_identity(a: np.ndarray, seed: int) -> None:
    p = _log_softmax(a)
    q = _log_softmax(np.random.default_rng(seed).normal(scale=5, size=a.shape))
    for mode in ("paired", "marginal"):
        assert mean_kl_divergence(p, p, mode=mode) == 0.0
        value = mean_kl_divergence(p, q, mode=mode)
        assert np.isfinite(value) and value >= 0.0


@settings(deadline=None)
@given(a=_logits, seed=st.integers(0, 2**16))
def test_paired_kld_invariant_to_a_shared_permutation(a: np.ndarray, seed: int) -> None:
    rng = np.random.default_rng(seed)
    p, q = _log_softmax(a), _log_softmax(rng.normal(size=a.shape))
    perm = rng.permutation(len(a))
    assert np.isclose(mean_kl_divergence(p[perm], q[perm]), mean_kl_divergence(p, q), rtol=1e-12, atol=1e-12)


_features = arrays(
    np.float64, st.tuples(st.integers(2, 12), st.integers(1, 4)), elements=st.floats(-100, 100)
)


@settings(deadline=None)
@given(feats=_features, seed=st.integers(0, 2**16))
def test_inter_diversity_over_all_pairs_is_permutation_invariant(feats: np.ndarray, seed: int) -> None:
    perm = np.random.default_rng(seed).permutation(len(feats))
    # num_pieces/num_pairs larger than available -> every pair is used, so the order cannot matter
    a = inter_diversity(feats, num_pieces=100, num_pairs=1000)
    b = inter_diversity(feats[perm], num_pieces=100, num_pairs=1000)
    assert np.isclose(a, b, rtol=1e-9, atol=1e-9)
    assert a >= 0.0


@settings(deadline=None)
@given(feats=_features, seed=st.integers(0, 2**16))
def test_intra_diversity_is_invariant_to_shuffling_pieces(feats: np.ndarray, seed: int) -> None:
    rng = np.random.default_rng(seed)
    groups = [i % 2 for i in range(len(feats))]
    if len(feats) < 3:
        groups = [0] * len(feats)
    perm = rng.permutation(len(feats))
    a = intra_diversity(feats, groups)
    b = intra_diversity(feats[perm], [groups[i] for i in perm])
    assert np.isclose(a, b, rtol=1e-9, atol=1e-9)
    # identical pieces for every input -> zero intra-diversity
    assert intra_diversity(np.zeros_like(feats), groups) == 0.0
