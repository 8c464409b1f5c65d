"""Properties of MoMu's symmetric InfoNCE (Eq. 4) and the amplitude categories of §3.2."""

from __future__ import annotations

import math

import numpy as np
import pytest
import torch
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

from momu.losses.rhythmic_contrastive import (
    RhythmicContrastiveConfig,
    amplitude_categories,
    sample_rhythmic_clips,
    symmetric_info_nce,
)

finite = st.floats(-10.0, 10.0, allow_nan=False, width=32)


@st.composite
def embedding_pairs(draw: st.DrawFn) -> tuple[torch.Tensor, torch.Tensor]:
    n = draw(st.integers(1, 8))
    d = draw(st.integers(1, 6))
    a = draw(arrays(np.float32, (n, d), elements=finite))
    m = draw(arrays(np.float32, (n, d), elements=finite))
    return torch.from_numpy(a).double(), torch.from_numpy(m).double()


temperatures = st.floats(0.05, 2.0)


@settings(deadline=None)
@given(embedding_pairs(), temperatures)
def test_info_nce_is_non_negative(pair: tuple[torch.Tensor, torch.Tensor], tau: float) -> None:
    a, m = pair
    assert symmetric_info_nce(a, m, tau).item() >= -1e-12


@settings(deadline=None)
@given(st.integers(1, 10), arrays(np.float32, (5,), elements=finite), temperatures)
def test_info_nce_is_log_n_for_identical_embeddings(n: int, row: np.ndarray, tau: float) -> None:
    e = torch.from_numpy(row).double().expand(n, -1).clone()
    assert symmetric_info_nce(e, e, tau).item() == pytest.approx(math.log(n), rel=1e-9, abs=1e-9)


@settings(deadline=None)
@given(embedding_pairs(), temperatures, st.randoms(use_true_random=False))
def test_info_nce_is_invariant_to_a_shared_permutation(
    pair: tuple[torch.Tensor, torch.Tensor], tau: float, rnd: object
) -> None:
    a, m = pair
    perm = list(range(a.shape[0]))
    rnd.shuffle(perm)  # type: ignore[attr-defined]
    idx = torch.tensor(perm)
    torch.testing.assert_close(symmetric_info_nce(a[idx], m[idx], tau), symmetric_info_nce(a, m, tau))


@settings(deadline=None)
@given(embedding_pairs(), temperatures)
def test_info_nce_is_symmetric_in_the_modalities(pair: tuple[torch.Tensor, torch.Tensor], tau: float) -> None:
    a, m = pair
    torch.testing.assert_close(symmetric_info_nce(a, m, tau), symmetric_info_nce(m, a, tau))


@settings(deadline=None)
@given(arrays(np.float64, st.integers(1, 40), elements=st.floats(0.0, 1.0)), st.integers(1, 8))
def test_quantile_categories_are_balanced_and_monotone(values: np.ndarray, n_c: int) -> None:
    v = torch.from_numpy(values)
    cats = amplitude_categories(v, n_c, "quantile")
    assert cats.min() >= 0 and cats.max() < n_c
    counts = torch.bincount(cats, minlength=n_c)[: min(n_c, len(values))]
    assert counts.max() - counts.min() <= 1 or len(values) < n_c
    order = torch.argsort(v, stable=True)
    assert torch.all(cats[order][1:] >= cats[order][:-1])  # a larger amplitude never gets a lower category


@settings(deadline=None)
@given(
    arrays(np.float64, st.integers(1, 48), elements=st.floats(0.0, 1.0)),
    st.integers(1, 12),
    st.integers(1, 6),
    st.integers(1, 6),
    st.integers(0, 2**16),
)
def test_sampled_clips_are_distinct_and_lie_inside(
    amp: np.ndarray, n_t: int, n_c: int, length: int, seed: int
) -> None:
    cfg = RhythmicContrastiveConfig(num_clips=n_t, num_categories=n_c, num_samples=n_c, clip_length=length)
    a = torch.from_numpy(amp)
    starts, used = sample_rhythmic_clips(a, cfg, generator=torch.Generator().manual_seed(seed))
    assert used == min(length, len(amp))
    assert 1 <= starts.numel() <= n_c
    assert int(starts.min()) >= 0 and int(starts.max()) + used <= len(amp)
    assert len(set(starts.tolist())) == starts.numel()
