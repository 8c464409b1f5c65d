"""Hypothesis properties of the motion-feature metrics (FID, Div, kinetic/geometric features)."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from tests.helpers.motion_reference import reference_kinetic, reference_manual

from momu.features.skeletons import get_skeleton
from momu.metrics import fid, geometric_features, kinetic_features
from momu.metrics.diversity import average_pairwise_distance
from momu.metrics.frechet import frechet_distance

SMPL = get_skeleton("smpl24")
REST = SMPL.rest_pose()

# Left/right feature pairs of the 32 geometric features (METRICS.md §1.2 table). Features 0/1 and 14/15 are
# left/right in name only: their cross-product normals have opposite handedness, so mirroring maps "right
# wrist moves along n" onto "left wrist moves along −n" (a reference quirk) — they are excluded below.
_MIRROR_PAIRS = [
    (2, 3),
    (4, 5),
    (6, 7),
    (10, 11),
    (12, 13),
    (16, 17),
    (19, 20),
    (21, 22),
    (23, 24),
    (25, 26),
    (29, 30),
]
_CHIRAL = [0, 1, 14, 15]
_PERM = list(range(32))
for _a, _b in _MIRROR_PAIRS:
    _PERM[_a], _PERM[_b] = _b, _a

seeds = st.integers(min_value=0, max_value=2**32 - 1)


def random_motion(seed: int, frames: int, dtype: type = np.float64) -> np.ndarray:
    rng = np.random.default_rng(seed)
    walk = rng.normal(0, 0.02, size=(frames, 24, 3)).cumsum(axis=0)
    return (REST[None] + walk + rng.normal(0, 0.5, size=(1, 1, 3))).astype(dtype)


def feature_sets(seed: int, n: int, m: int, d: int) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    scale = rng.uniform(0.5, 3.0, size=d)
    return (rng.normal(size=(n, d)) * scale), (rng.normal(size=(m, d)) * scale + rng.normal(size=d))


@given(seeds, st.integers(4, 30), st.integers(4, 30), st.integers(1, 5))
@settings(deadline=None)
def test_fid_nonnegative_zero_on_identical_and_symmetric(seed: int, n: int, m: int, d: int) -> None:
    a, b = feature_sets(seed, n, m, d)
    scale = float(
        np.trace(np.cov(a, rowvar=False).reshape(d, d)) + np.trace(np.cov(b, rowvar=False).reshape(d, d))
    )
    tol = 1e-7 * (1.0 + scale)
    assert fid(a, b) >= -tol
    assert fid(a, b, variant="mint") >= -tol
    assert abs(fid(a, a)) <= tol
    # the unnormalised Fréchet distance is symmetric (tr √(Σ1Σ2) = tr √(Σ2Σ1)); with no more samples than
    # dimensions a covariance is singular and sqrtm of the product is accurate to ~√ε, not ε
    # (n = m = d = 4 gave a relative asymmetry of 2e-7)
    rel = 1e-7 if min(n, m) > d else 1e-5
    assert abs(frechet_distance(a, b) - frechet_distance(b, a)) <= rel * (1.0 + abs(frechet_distance(a, b)))


@given(seeds, st.integers(2, 40))
@settings(deadline=None)
def test_diversity_invariant_to_permutation(seed: int, n: int) -> None:
    rng = np.random.default_rng(seed)
    feats = rng.normal(size=(n, 8)).astype(np.float32)
    order = rng.permutation(n)
    base = average_pairwise_distance(feats)
    # float32 running sum: order changes only the last digits (METRICS.md §1.4)
    assert np.isclose(average_pairwise_distance(feats[order]), base, rtol=1e-5)
    exact = average_pairwise_distance(feats, accumulate="float64")
    assert np.isclose(average_pairwise_distance(feats[order], accumulate="float64"), exact, rtol=1e-12)


@given(seeds, st.integers(3, 25), st.floats(-3.0, 3.0), st.floats(-3.0, 3.0), st.floats(-3.0, 3.0))
@settings(deadline=None)
def test_kinetic_energy_invariant_to_translation(
    seed: int, frames: int, dx: float, dy: float, dz: float
) -> None:
    motion = random_motion(seed, frames)
    moved = motion + np.array([dx, dy, dz])
    base = kinetic_features(motion).reshape(24, 3)
    shifted = kinetic_features(moved).reshape(24, 3)
    np.testing.assert_allclose(shifted[:, :2], base[:, :2], rtol=1e-4, atol=1e-4)
    # the corrected energy expenditure is translation invariant too (the compat one is not, §1.1)
    fixed = kinetic_features(motion, variant="corrected").reshape(24, 3)
    fixed_moved = kinetic_features(moved, variant="corrected").reshape(24, 3)
    np.testing.assert_allclose(fixed_moved[:, 2], fixed[:, 2], rtol=1e-6, atol=1e-6)


@given(seeds, st.integers(3, 40))
@settings(deadline=None)
def test_mirrored_motion_swaps_left_and_right_features(seed: int, frames: int) -> None:
    motion = random_motion(seed, frames)
    mirrored = SMPL.mirror_pose(motion)  # x → −x and left/right joints swapped (smpl24 mirror map)
    kin = kinetic_features(motion).reshape(24, 3)
    np.testing.assert_array_equal(kinetic_features(mirrored).reshape(24, 3), kin[list(SMPL.mirror)])
    geo, geo_m = geometric_features(motion), geometric_features(mirrored)
    keep = [i for i in range(32) if i not in _CHIRAL]
    np.testing.assert_array_equal(geo_m[keep], geo[_PERM][keep])


@given(seeds, st.integers(3, 12), st.sampled_from([np.float32, np.float64]))
@settings(deadline=None)
def test_vectorised_features_equal_reference_loops(seed: int, frames: int, dtype: type) -> None:
    motion = random_motion(seed, frames, dtype)
    np.testing.assert_array_equal(kinetic_features(motion), reference_kinetic(motion))
    np.testing.assert_array_equal(geometric_features(motion), reference_manual(motion))
