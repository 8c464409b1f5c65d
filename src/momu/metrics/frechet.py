"""Fréchet distance between two feature sets (FID_k, FID_g, and any learned-feature FID / FAD).

This module holds the one matrix square root and the one Fréchet distance of momu. It follows
the field's reference code (METRICS.md §1.3):

* **Bailando** ``utils/metrics_new.py::calc_fid(kps_gen, kps_gt)`` — the default (``variant="bailando"``):
  ``C = sqrtm(Σ_gen · Σ_gt)``; when ``C`` has non-finite entries it is recomputed as
  ``sqrtm((Σ_gen + 1e-5 I)(Σ_gt + 1e-5 I))``; a complex ``C`` whose diagonal has an imaginary part
  above 1e-3 is silently replaced by its real part, otherwise it stays complex and the FID carries a
  ~1e-6 imaginary part. Both branches give the same real number ``Re(·)``, which is what momu returns.
* **mint / FACT** ``calculate_frechet_distance(real, gen)`` (``variant="mint"``):
  ``C = sqrtm(Σ_real · Σ_gen)`` (product order swapped), fallback offset 1e-6, and a
  :class:`ValueError` when the diagonal's imaginary part exceeds 1e-3; otherwise ``C.real``.

FID = ‖μ1 − μ2‖² + tr Σ1 + tr Σ2 − 2 tr C, with μ the feature mean and Σ the covariance (``np.cov``,
rows = samples, ddof 1, float64).

Matrix square root: the references call ``scipy.linalg.sqrtm(A, disp=False)``, deprecated in scipy 1.16
(and broken from 1.18). ``disp`` only controlled whether scipy printed a warning and returned an error
estimate; the square root itself is the same, so :func:`matrix_sqrt` calls ``sqrtm(A)`` without it, turns
scipy's singular-matrix warning into a log message, and leaves the numbers untouched.

Normalisation (§1.3 step 2, both references): features are standardised with the **reference (ground-truth)**
set's mean and population std (ddof 0) plus 1e-10, in the features' own dtype (float32 for kinetic /
geometric features). A ground-truth dimension with zero variance is divided by 1e-10 and blows the FID up
(METRICS.md §2.3): :func:`normalize_by_reference` reproduces that by default (with a logged warning) and can
raise instead (``constant="raise"``).
"""

from __future__ import annotations

import logging
import warnings
from typing import Literal

import numpy as np
from scipy import linalg

__all__ = [
    "FIDVariant",
    "FID_VARIANTS",
    "matrix_sqrt",
    "feature_statistics",
    "normalize_by_reference",
    "frechet_distance_from_stats",
    "frechet_distance",
    "fid",
]

logger = logging.getLogger(__name__)

FIDVariant = Literal["bailando", "mint"]
FID_VARIANTS: tuple[str, ...] = ("bailando", "mint")

# Offsets added to both covariances' diagonals when the square root of their product is not finite.
_FALLBACK_EPS: dict[str, float] = {"bailando": 1e-5, "mint": 1e-6}
# Tolerance on the imaginary part of diag(C) (both references use np.allclose(..., atol=1e-3)).
_IMAG_ATOL = 1e-3
# Added to the reference std before dividing (both references).
NORMALIZE_EPS = 1e-10


def matrix_sqrt(a: np.ndarray) -> np.ndarray:
    """Principal square root of a square matrix, ``scipy.linalg.sqrtm`` without the deprecated ``disp``.

    Args:
        a: ``(d, d)`` real or complex matrix.

    Returns:
        ``(d, d)`` array ``C`` with ``C @ C ≈ a``; complex when scipy returns complex (e.g. negative or
        numerically negative eigenvalues), possibly with non-finite entries for singular input — exactly
        what ``sqrtm(a, disp=False)[0]`` returned. Scipy's singular-matrix warning is logged at DEBUG level.
    """
    a = np.asarray(a)
    if a.ndim != 2 or a.shape[0] != a.shape[1]:
        raise ValueError(f"matrix_sqrt: expected a square 2-D matrix, got shape {a.shape}")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", linalg.LinAlgWarning)
        root = linalg.sqrtm(a)
    for w in caught:
        logger.debug("sqrtm: %s", w.message)
    return np.asarray(root)


def _check_features(name: str, feats: np.ndarray, min_rows: int = 1) -> np.ndarray:
    feats = np.asarray(feats)
    if feats.ndim != 2:
        raise ValueError(f"{name}: expected a 2-D (num_samples, feature_dim) array, got shape {feats.shape}")
    if not np.issubdtype(feats.dtype, np.floating):
        feats = feats.astype(np.float64)
    if feats.shape[0] < min_rows:
        raise ValueError(
            f"{name}: needs at least {min_rows} samples (a covariance with ddof=1 needs 2), "
            f"got {feats.shape[0]}"
        )
    if not np.all(np.isfinite(feats)):
        bad = np.unique(np.nonzero(~np.isfinite(feats))[0])
        raise ValueError(
            f"{name}: non-finite feature values in rows {bad[:10].tolist()} (of {feats.shape[0]} rows)"
        )
    return feats


def feature_statistics(feats: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Mean and covariance of a feature set, as the references compute them.

    Args:
        feats: ``(N, d)`` features, one row per sample, N ≥ 2.

    Returns:
        ``mu`` ``(d,)`` in the features' dtype (``np.mean``) and ``sigma`` ``(d, d)`` float64
        (``np.cov(rowvar=False)``, ddof 1).
    """
    feats = _check_features("features", feats, min_rows=2)
    return np.mean(feats, axis=0), np.atleast_2d(np.cov(feats, rowvar=False))


def normalize_by_reference(
    reference: np.ndarray,
    *others: np.ndarray,
    constant: Literal["keep", "raise"] = "keep",
) -> tuple[np.ndarray, ...]:
    """Standardise ``reference`` and every set in ``others`` with the reference's mean and std (ddof 0).

    ``(x - mean) / (std + 1e-10)`` in the features' dtype: Bailando ``normalize(gt, pred)`` and mint
    ``calculate_frechet_feature_distance`` (METRICS.md §1.3 step 2).

    Args:
        reference: ``(N', d)`` ground-truth features.
        others: ``(N, d)`` feature sets to express in the reference's scale (generated features ...).
        constant: what to do when a reference dimension has zero variance: ``"keep"`` divides by 1e-10 as
            the references do (the FID of such sets is of order 1e13; a warning is logged), ``"raise"``
            raises :class:`ValueError` naming the dimensions.

    Returns:
        ``(reference_n, *others_n)``.
    """
    reference = _check_features("reference features", reference)
    d = reference.shape[1]
    checked = []
    for i, other in enumerate(others):
        other = _check_features(f"features set {i}", other)
        if other.shape[1] != d:
            raise ValueError(f"feature dims differ: reference has {d}, set {i} has {other.shape[1]}")
        checked.append(other)
    mean = reference.mean(axis=0)
    std = reference.std(axis=0)
    flat = np.nonzero(std == 0)[0]
    if flat.size:
        msg = (
            f"reference features have zero variance in dims {flat[:20].tolist()}"
            f"{' ...' if flat.size > 20 else ''}; normalising divides them by 1e-10"
        )
        if constant == "raise":
            raise ValueError(msg)
        if constant != "keep":
            raise ValueError(f"constant must be 'keep' or 'raise', got {constant!r}")
        logger.warning("%s (reference behaviour: Bailando/mint FID of order 1e13)", msg)
    denom = std + NORMALIZE_EPS
    return ((reference - mean) / denom, *((o - mean) / denom for o in checked))


def frechet_distance_from_stats(
    mu1: np.ndarray,
    sigma1: np.ndarray,
    mu2: np.ndarray,
    sigma2: np.ndarray,
    *,
    variant: FIDVariant = "bailando",
    eps: float | None = None,
) -> float:
    """Fréchet distance between N(mu1, sigma1) and N(mu2, sigma2) (METRICS.md §1.3 step 3).

    ``C = sqrtm(sigma1 · sigma2)`` in the given order; pass (generated, reference) for Bailando's
    ``calc_fid(pred, gt)`` and (reference, generated) for mint's ``calculate_frechet_distance(real, gen)`` —
    :func:`frechet_distance` and :func:`fid` do this for you.

    Args:
        mu1, mu2: ``(d,)`` means.
        sigma1, sigma2: ``(d, d)`` covariances.
        variant: ``"bailando"`` (complex parts dropped silently, fallback eps 1e-5) or ``"mint"``
            (:class:`ValueError` when ``diag(C)`` has an imaginary part above 1e-3, fallback eps 1e-6).
        eps: diagonal offset of the non-finite fallback; ``None`` = the variant's.

    Returns:
        The distance as a Python float (the real part; see the module docstring). Can be slightly negative
        (≈ −1e-10·scale) for identical inputs, as in the references.
    """
    if variant not in _FALLBACK_EPS:
        raise ValueError(f"variant must be one of {FID_VARIANTS}, got {variant!r}")
    mu1, mu2 = np.atleast_1d(mu1), np.atleast_1d(mu2)
    sigma1, sigma2 = np.atleast_2d(sigma1), np.atleast_2d(sigma2)
    if mu1.shape != mu2.shape:
        raise ValueError(f"mean vectors have different shapes: {mu1.shape} vs {mu2.shape}")
    if sigma1.shape != sigma2.shape or sigma1.shape != (mu1.shape[0], mu1.shape[0]):
        raise ValueError(
            f"covariances must both be ({mu1.shape[0]}, {mu1.shape[0]}), "
            f"got {sigma1.shape} and {sigma2.shape}"
        )
    for name, arr in (("mu1", mu1), ("mu2", mu2), ("sigma1", sigma1), ("sigma2", sigma2)):
        if not np.all(np.isfinite(arr)):
            raise ValueError(f"{name} has non-finite entries")
    offset_eps = _FALLBACK_EPS[variant] if eps is None else float(eps)

    diff = mu1 - mu2
    covmean = matrix_sqrt(sigma1.dot(sigma2))
    if not np.isfinite(covmean).all():
        logger.info("FID: singular covariance product; adding %g to the covariance diagonals", offset_eps)
        offset = np.eye(sigma1.shape[0]) * offset_eps
        covmean = matrix_sqrt((sigma1 + offset).dot(sigma2 + offset))
        if not np.isfinite(covmean).all():
            raise ValueError("FID: the covariance product has no finite square root even with the eps offset")

    if np.iscomplexobj(covmean):
        max_diag_imag = float(np.max(np.abs(np.diagonal(covmean).imag)))
        if not np.allclose(np.diagonal(covmean).imag, 0, atol=_IMAG_ATOL):
            max_imag = float(np.max(np.abs(covmean.imag)))
            if variant == "mint":
                raise ValueError(f"FID: imaginary component {max_imag} in sqrtm(Σ1·Σ2) (mint raises here)")
            logger.warning(
                "FID: sqrtm(Σ1·Σ2) has an imaginary diagonal part up to %.3g; dropping it as Bailando does",
                max_diag_imag,
            )
        # Bailando keeps C complex when the imaginary part is small and returns a complex FID; its real part
        # equals the value computed from C.real, which is what both variants return here.
        covmean = covmean.real

    tr_covmean = np.trace(covmean)
    value = diff.dot(diff) + np.trace(sigma1) + np.trace(sigma2) - 2 * tr_covmean
    return float(np.real(value))


def frechet_distance(
    generated: np.ndarray,
    reference: np.ndarray,
    *,
    variant: FIDVariant = "bailando",
) -> float:
    """Fréchet distance between two feature sets, without normalisation.

    Args:
        generated: ``(N, d)`` features of the generated samples, N ≥ 2.
        reference: ``(N', d)`` features of the reference (ground-truth) samples, N' ≥ 2.
        variant: see :func:`frechet_distance_from_stats`; decides the order of the covariance product.

    Returns:
        The Fréchet distance (float).
    """
    generated = _check_features("generated features", generated, min_rows=2)
    reference = _check_features("reference features", reference, min_rows=2)
    if generated.shape[1] != reference.shape[1]:
        raise ValueError(
            f"feature dims differ: generated has {generated.shape[1]}, reference has {reference.shape[1]}"
        )
    mu_gen, sigma_gen = feature_statistics(generated)
    mu_ref, sigma_ref = feature_statistics(reference)
    if variant == "mint":
        return frechet_distance_from_stats(mu_ref, sigma_ref, mu_gen, sigma_gen, variant="mint")
    return frechet_distance_from_stats(mu_gen, sigma_gen, mu_ref, sigma_ref, variant=variant)


def fid(
    generated: np.ndarray,
    reference: np.ndarray,
    *,
    variant: FIDVariant = "bailando",
    normalize: bool = True,
    constant: Literal["keep", "raise"] = "keep",
) -> float:
    """FID between generated and reference features, the Bailando / mint way (METRICS.md §1.3).

    Args:
        generated: ``(N, d)`` generated features (e.g. 72-d kinetic → FID_k, 32-d geometric → FID_g).
        reference: ``(N', d)`` ground-truth features.
        variant: ``"bailando"`` (default, reference-compatible with Bailando's ``quantized_metrics``) or
            ``"mint"`` (mint PR #41's ``calculate_frechet_feature_distance``).
        normalize: standardise both sets with the reference statistics first (both references do).
        constant: zero-variance reference dimensions: ``"keep"`` (reference behaviour) or ``"raise"``.

    Returns:
        FID as a Python float.
    """
    if normalize:
        reference, generated = normalize_by_reference(reference, generated, constant=constant)
    return frechet_distance(generated, reference, variant=variant)
