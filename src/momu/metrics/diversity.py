"""Feature-space diversity: Div_k / Div_g (Bailando, mint) and MoFusion's Multimodality.

* **Div** (METRICS.md §1.4, Bailando / mint ``calculate_avg_distance``): the mean Euclidean distance over all
  unordered pairs of one feature set, ``(2/(n(n−1))) Σ_{i<j} ‖f_i − f_j‖₂``, on features normalised
  with the **ground-truth** statistics (:func:`momu.metrics.frechet.normalize_by_reference`). Bailando reports
  it for the generated set (``div_k``, ``div_m``) and for the ground truth (``div_k_gt``, ``div_m_gt``).
* **Multimodality** (MoFusion §4.1, METRICS.md §3.2): the average Euclidean distance between the kinetic
  features of K (= 50) motions generated for the same music, averaged over music inputs. momu computes it
  per group with the same pairwise mean as Div, on GT-normalised features by default (the scale MoFusion's
  11.38 and Bailando's Div values share).

Accumulation: Bailando sums float32 norms in a Python loop, so the result is a float32 sequential sum and its
last ~7 significant digits depend on the order of the files. ``accumulate="reference"`` (default) reproduces
that sum exactly (a float32 running sum in the same i<j order); ``accumulate="float64"`` sums in float64 and
is independent of order up to rounding.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Literal

import numpy as np

from momu.metrics.frechet import normalize_by_reference

__all__ = ["Accumulate", "average_pairwise_distance", "diversity", "multimodality"]

Accumulate = Literal["reference", "float64"]
_BLOCK_ELEMENTS = 1 << 22  # elements of one block of pairwise differences (16 MiB in float32)


def _pair_norms_rows(feats: np.ndarray, start: int, stop: int) -> np.ndarray:
    """Norms ‖f_i − f_j‖ for i in [start, stop), j > i, in row-major (i, then j) order."""
    block = feats[start:stop]  # (b, d)
    diffs = block[:, None, :] - feats[None, :, :]  # (b, n, d), features' dtype
    norms = np.sqrt(np.einsum("bnd,bnd->bn", diffs, diffs))
    n = feats.shape[0]
    return np.concatenate([norms[r, start + r + 1 : n] for r in range(stop - start)])


def average_pairwise_distance(features: np.ndarray, *, accumulate: Accumulate = "reference") -> float:
    """Mean Euclidean distance over all unordered pairs of rows (``calculate_avg_distance``).

    Args:
        features: ``(n, d)`` feature set, n ≥ 2 (already normalised as the caller wants).
        accumulate: ``"reference"`` — float32 sequential sum as Bailando's loop (for float32 features);
            ``"float64"`` — float64 sum.

    Returns:
        The mean distance (Python float), in the features' units.

    Raises:
        ValueError: not 2-D, fewer than 2 rows (the reference divides by zero), non-finite values.
    """
    feats = np.asarray(features)
    if feats.ndim != 2:
        raise ValueError(f"features: expected (n, d), got shape {feats.shape}")
    n = feats.shape[0]
    if n < 2:
        raise ValueError(f"features: diversity needs at least 2 samples, got {n}")
    if not np.issubdtype(feats.dtype, np.floating):
        feats = feats.astype(np.float64)
    if not np.all(np.isfinite(feats)):
        raise ValueError("features: contains NaN or inf")
    num_pairs = (n * n - n) / 2
    block = max(1, min(n, _BLOCK_ELEMENTS // max(1, n * feats.shape[1])))
    if accumulate == "float64":
        f64 = feats.astype(np.float64)
        total = 0.0
        for start in range(0, n, block):
            total += float(np.sum(_pair_norms_rows(f64, start, min(n, start + block))))
        return total / num_pairs
    if accumulate != "reference":
        raise ValueError(f"accumulate must be 'reference' or 'float64', got {accumulate!r}")
    # Bailando: `dist = 0; dist += np.linalg.norm(f_i - f_j)` → a running sum in the features' dtype.
    running = np.zeros(1, dtype=feats.dtype)
    for start in range(0, n, block):
        norms = _pair_norms_rows(feats, start, min(n, start + block))
        if norms.size:
            running = np.cumsum(np.concatenate([running, norms]), dtype=feats.dtype)[-1:]
    return float(running[0] / feats.dtype.type(num_pairs))


def diversity(
    features: np.ndarray,
    reference: np.ndarray | None = None,
    *,
    normalize: bool = True,
    accumulate: Accumulate = "reference",
) -> float:
    """Div (METRICS.md §1.4): average pairwise distance of ``features`` in the reference's normalised scale.

    Args:
        features: ``(n, d)`` features of the set whose diversity is measured (e.g. 72-d kinetic → Div_k,
            32-d geometric → Div_g).
        reference: ``(n', d)`` ground-truth features whose mean/std normalise ``features`` (Bailando);
            pass the same array as ``features`` for the GT's own diversity (``div_k_gt``).
        normalize: if False, distances are taken on the raw features and ``reference`` is not needed.
        accumulate: see :func:`average_pairwise_distance`.

    Returns:
        Div as a Python float.
    """
    if normalize:
        if reference is None:
            raise ValueError("diversity: normalize=True needs the reference (ground-truth) features")
        _, features = normalize_by_reference(reference, features)
    return average_pairwise_distance(features, accumulate=accumulate)


def multimodality(
    groups: Sequence[np.ndarray],
    reference: np.ndarray | None = None,
    *,
    normalize: bool = True,
    accumulate: Accumulate = "float64",
) -> float:
    """MoFusion Multimodality (§4.1): mean over inputs of the average pairwise distance of the K motions
    generated for that input.

    Args:
        groups: one ``(K_g, d)`` feature array per condition (music), K_g ≥ 2 (MoFusion uses K = 50).
        reference: ``(n', d)`` ground-truth features for the normalisation (as Div); unused without
            ``normalize``.
        normalize: normalise with the reference statistics first (default, Div's scale).
        accumulate: see :func:`average_pairwise_distance` (no reference loop exists for this metric, so the
            default is the order-independent float64 sum).

    Returns:
        Multimodality as a Python float.
    """
    if not groups:
        raise ValueError("multimodality: no groups of generated features")
    values = []
    for g, feats in enumerate(groups):
        feats = np.asarray(feats)
        if feats.ndim != 2 or feats.shape[0] < 2:
            raise ValueError(
                f"multimodality: group {g} needs (K, d) features with K ≥ 2 generations, "
                f"got shape {feats.shape}"
            )
        if normalize:
            if reference is None:
                raise ValueError("multimodality: normalize=True needs the reference (ground-truth) features")
            _, feats = normalize_by_reference(reference, feats)
        values.append(average_pairwise_distance(feats, accumulate=accumulate))
    return float(np.mean(values))
