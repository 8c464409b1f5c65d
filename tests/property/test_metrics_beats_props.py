"""Hypothesis properties of the beat and harmony metrics (ranges, identities, symmetries)."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from momu.metrics import beat_align_score, harmony_from_beats, pair_beat_scores, select_aligned
from momu.metrics.loris_scores import aggregate_beat_scores

frames = st.lists(st.integers(0, 2000), min_size=1, max_size=40, unique=True)
bins = st.lists(st.integers(0, 1), min_size=1, max_size=30)
times = st.lists(st.floats(0, 60, allow_nan=False), min_size=0, max_size=25)


@given(frames, frames, st.floats(0.5, 20), st.sampled_from(["music", "motion"]))
@settings(deadline=None)
def test_bas_in_unit_interval(music: list[int], motion: list[int], sigma: float, over: str) -> None:
    s = beat_align_score(music, motion, sigma=sigma, over=over)  # type: ignore[arg-type]
    assert 0.0 <= s <= 1.0


@given(frames, st.lists(st.integers(0, 2000), max_size=20), st.floats(0.5, 20))
@settings(deadline=None)
def test_bas_is_one_when_beats_coincide(beats: list[int], extra: list[int], sigma: float) -> None:
    assert beat_align_score(beats, beats, sigma=sigma) == 1.0
    assert beat_align_score(beats, beats, sigma=sigma, over="motion") == 1.0
    # Bailando averages over music beats: extra motion beats cannot lower a perfect score
    assert beat_align_score(beats, beats + extra, sigma=sigma) == 1.0
    # mint averages over motion beats: extra music beats cannot lower it
    assert beat_align_score(beats + extra, beats, sigma=sigma, over="motion") == 1.0


@given(frames, frames)
@settings(deadline=None)
def test_bas_over_music_equals_over_motion_with_roles_swapped(a: list[int], b: list[int]) -> None:
    x = beat_align_score(a, b, over="music")
    y = beat_align_score(b, a, over="motion")
    assert abs(x - y) < 1e-6  # same definition; the mint path runs in float32


@given(bins, bins)
@settings(deadline=None)
def test_loris_pair_scores_in_unit_interval(gt: list[int], syn: list[int]) -> None:
    cover, hit = pair_beat_scores(gt, syn, truncate="shortest")
    assert 0.0 <= cover <= 1.0 and 0.0 <= hit <= 1.0
    assert pair_beat_scores(syn, syn) == ((1.0, 1.0) if any(syn) else (0, 0))


@given(st.lists(st.tuples(bins, bins), min_size=2, max_size=8))
@settings(deadline=None)
def test_loris_dataset_ranges_and_f1_harmonic_mean(pairs: list[tuple[list[int], list[int]]]) -> None:
    scores = [pair_beat_scores(g, s, truncate="shortest") for g, s in pairs]
    out = aggregate_beat_scores([c for c, _ in scores], [h for _, h in scores])
    for key in ("bcs", "bhs", "csd", "hsd", "f1"):
        assert 0.0 <= out[key] <= 1.0
    if out["bcs"] > 0 and out["bhs"] > 0:  # F1 is the harmonic mean of the two means
        assert np.isclose(1 / out["f1"], (1 / out["bcs"] + 1 / out["bhs"]) / 2)
    else:
        assert out["f1"] == 0.0
    assert min(out["bcs"], out["bhs"]) - 1e-12 <= out["f1"] <= max(out["bcs"], out["bhs"]) + 1e-12


@given(
    st.lists(st.tuples(st.floats(0, 30), st.floats(0.01, 10)), min_size=1, max_size=20),
    st.lists(st.tuples(st.floats(0, 30), st.floats(0, 10)), max_size=20),
    st.floats(0, 10),
    st.floats(0.1, 4),
    st.floats(0.05, 1.0),
)
@settings(deadline=None)
def test_harmony_identity(
    audio: list[tuple[float, float]], visual: list[tuple[float, float]], j0: float, beta: float, delay: float
) -> None:
    ta, sa = np.array([a for a, _ in audio]), np.array([s for _, s in audio])
    tv, sv = np.array([v for v, _ in visual]), np.array([s for _, s in visual])
    r = harmony_from_beats(ta, sa, tv, sv, j0, beta=beta, t_delay=delay)
    # HarmoGAN Eq. 11: h = (1 + β²) h_s / (N' β² + M')
    assert np.isclose(r.h, (1 + beta**2) * r.h_s / (r.n_audio * beta**2 + r.n_visual))
    if r.h_s > 0:  # ... which is the F_β mean of h_a = h_s/N' and h_v = h_s/M'
        assert np.isclose(r.h, (1 + beta**2) * r.h_a * r.h_v / (beta**2 * r.h_v + r.h_a))
    assert 0.0 <= r.hit_rate <= 1.0 and 0 <= r.hits <= r.n_audio
    assert 0.0 <= r.h_s <= r.hits + 1e-9  # normalised saliencies are <= 1
    if r.n_visual >= r.n_audio:
        assert r.h <= 1.0 + 1e-12


@given(frames, frames, st.integers(0, 30))
@settings(deadline=None)
def test_select_aligned_is_one_to_one_within_tolerance(music: list[int], motion: list[int], tol: int) -> None:
    m, d = select_aligned(music, motion, tol=tol)
    assert len(m) == len(d) == len(set(m.tolist())) == len(set(d.tolist()))
    assert np.all(np.abs(m - d) <= tol)
