"""Motion rhythm features: MoMu's directogram and kinematic amplitude, HarmoGAN's velocity sum and beats.

Conventions: ``motion`` is ``(T, J, D)`` joint positions (``D`` = 2 image-plane keypoints or 3 with
Y up), frames at ``fps``. First differences give ``T − 1`` values; value ``r`` describes the
displacement from frame ``r`` to frame ``r + 1``.

* :func:`directogram` — MoMu Eq. 1 (after Davis & Agrawala's visual rhythm): the first-order difference
  ``F(r, j)`` of every joint is binned by its angle ``tan⁻¹(y/x)`` with the x axis into ``K`` bins and the
  bins accumulate ``‖F(r, j)‖₂``. Bin ``k`` is centred at ``θ_k = (k + ½)·2π/K`` (angles in ``[0, 2π)``).
  ``window="paper"`` uses Eq. 1's indicator literally, ``𝟙_θ(φ) = 1`` iff the circular distance
  ``|θ − φ| ≤ 2π/K`` — a window two bins wide, so each displacement lands in the two nearest bins;
  ``window="hard"`` gives each displacement to the single bin containing its angle (``|θ − φ| ≤ π/K``).
  3D motion is projected on a plane first: ``plane=(0, 1)`` (default) keeps x (right) and y (up), the
  frontal image plane of a camera looking along z — the plane a 2D keypoint detector would see.
* :func:`kinematic_amplitude` — MoMu Eq. 2: ``Q(r) = Σ_k max(0, |D(r,k)| − |D(r−1,k)|)``; ``Q(0) = 0``
  (no previous directogram row), then divided by its maximum over the clip so ``Q ∈ [0, 1]``
  ("normalized within the range of (0,1)"); a motionless clip gives all zeros.
* :func:`velocity_sum` — HarmoGAN Eq. 2: ``j_t = Σ_p ‖v_t^p − v_{t−1}^p‖`` times ``fps`` (units/s;
  the scale does not move extrema).
* :func:`visual_beats` — HarmoGAN Eq. 3: frames where ``j`` has a strict local maximum or minimum, with
  the saliency ``s_v`` = ``j`` at the beat (§III-C).

Torch versions (:func:`directogram_torch`, :func:`kinematic_amplitude_torch`) are batched and
differentiable w.r.t. the displacement magnitudes (bin assignment is piecewise constant), for losses.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import torch

__all__ = [
    "check_motion",
    "project_plane",
    "directogram",
    "kinematic_amplitude",
    "motion_kinematic_amplitude",
    "directogram_torch",
    "kinematic_amplitude_torch",
    "velocity_sum",
    "visual_beats",
]

_WINDOWS = ("paper", "hard")


def check_motion(
    motion: Any, *, name: str = "motion", dims: tuple[int, ...] = (2, 3), min_frames: int = 1
) -> np.ndarray:
    """Validate ``(T, J, D)`` finite joint positions and return them as a float64 array.

    Raises:
        ValueError: wrong rank, ``D`` not in ``dims``, fewer than ``min_frames`` frames, no joints, or
            NaN/inf values (the message names the first bad frame and joint).
    """
    if isinstance(motion, torch.Tensor):
        motion = motion.detach().cpu().numpy()
    x = np.asarray(motion, dtype=np.float64)
    if x.ndim != 3:
        raise ValueError(f"{name}: expected joint positions of shape (T, J, D), got shape {x.shape}")
    if x.shape[2] not in dims:
        raise ValueError(
            f"{name}: expected D in {dims} coordinates per joint, got D={x.shape[2]} (shape {x.shape})"
        )
    if x.shape[1] == 0:
        raise ValueError(f"{name}: no joints (shape {x.shape})")
    if x.shape[0] < min_frames:
        raise ValueError(f"{name}: needs at least {min_frames} frames, got {x.shape[0]}")
    bad = ~np.isfinite(x)
    if bad.any():
        t, j, _ = np.argwhere(bad)[0]
        raise ValueError(
            f"{name}: non-finite value at frame {t}, joint {j} ({int(bad.any(-1).sum())} NaN/inf keypoints); "
            "fill missing keypoints with momu.features.preprocess.interpolate_missing first"
        )
    return x


def project_plane(motion: np.ndarray, plane: tuple[int, int] | list[int] = (0, 1)) -> np.ndarray:
    """``(T, J, 2)``: the coordinate axes ``plane`` of ``(T, J, D)`` motion (identity for 2D and (0, 1))."""
    a, b = int(plane[0]), int(plane[1])
    d = motion.shape[-1]
    if a == b or not (0 <= a < d and 0 <= b < d):
        raise ValueError(f"plane: expected two distinct axes in [0, {d}), got {tuple(plane)}")
    return motion[..., [a, b]]


def _bin_weights_np(angle: np.ndarray, bins: int, window: str) -> np.ndarray:
    """``(..., K)`` indicator 𝟙_θk(angle) of MoMu Eq. 1 for angles in radians."""
    width = 2.0 * math.pi / bins
    centres = (np.arange(bins) + 0.5) * width
    phi = np.mod(angle, 2.0 * math.pi)[..., None]
    dist = np.abs(phi - centres)
    dist = np.minimum(dist, 2.0 * math.pi - dist)  # circular distance
    if window == "paper":
        return (dist <= width).astype(np.float64)
    idx = np.floor(phi[..., 0] / width).astype(np.int64) % bins
    return np.eye(bins)[idx]


def directogram(
    motion: np.ndarray,
    bins: int = 8,
    *,
    plane: tuple[int, int] | list[int] = (0, 1),
    window: str = "paper",
) -> np.ndarray:
    """MoMu Eq. 1: the motion directogram ``D(r, θ_k)``, ``(T − 1, bins)`` float64, non-negative.

    Args:
        motion: ``(T, J, 2|3)`` joint positions, ``T ≥ 2``.
        bins: ``K``, the number of angular bins (bin ``k`` centred at ``(k + ½)·2π/K``).
        plane: the two axes the displacements are projected on (3D: default x–y, the frontal plane).
        window: ``"paper"`` (Eq. 1 literally, ``|θ − φ| ≤ 2π/K``) or ``"hard"`` (one bin per vector).

    Translating the skeleton leaves it unchanged; rotating 2D motion by ``m·2π/K`` rolls the bins by ``m``.
    """
    if bins < 1:
        raise ValueError(f"bins must be >= 1, got {bins}")
    if window not in _WINDOWS:
        raise ValueError(f"window must be one of {_WINDOWS}, got {window!r}")
    x = project_plane(check_motion(motion, min_frames=2), plane)
    f = np.diff(x, axis=0)  # (T-1, J, 2): F(r, j)
    mag = np.linalg.norm(f, axis=-1)  # (T-1, J)
    angle = np.arctan2(f[..., 1], f[..., 0])
    weights = _bin_weights_np(angle, bins, window)  # (T-1, J, K)
    return np.einsum("tj,tjk->tk", mag, weights)


def kinematic_amplitude(directogram: np.ndarray, *, normalize: bool = True) -> np.ndarray:
    """MoMu Eq. 2: ``Q(r) = Σ_k max(0, |D(r,k)| − |D(r−1,k)|)``, ``(T − 1,)`` float64 in ``[0, 1]``.

    ``Q(0) = 0`` (Eq. 2 needs a previous row). With ``normalize`` (default) ``Q`` is divided by its
    maximum over the clip (all zeros when the clip never speeds up in any direction).
    Accepts a batch ``(..., T − 1, K)`` (normalised per sequence).
    """
    d = np.abs(np.asarray(directogram, dtype=np.float64))
    if d.ndim < 2:
        raise ValueError(f"directogram: expected shape (T-1, K), got {d.shape}")
    if not np.all(np.isfinite(d)):
        raise ValueError("directogram: contains NaN/inf")
    q: Any = np.zeros(d.shape[:-1], dtype=np.float64)
    q[..., 1:] = np.maximum(0.0, d[..., 1:, :] - d[..., :-1, :]).sum(-1)
    if normalize:
        peak = q.max(axis=-1, keepdims=True) if q.shape[-1] else np.ones((*q.shape[:-1], 1))
        q = np.divide(q, peak, out=np.zeros_like(q), where=peak > 0)
    return q


def motion_kinematic_amplitude(
    motion: np.ndarray,
    bins: int = 8,
    *,
    plane: tuple[int, int] | list[int] = (0, 1),
    window: str = "paper",
    normalize: bool = True,
) -> np.ndarray:
    """``kinematic_amplitude(directogram(motion, ...))``: ``(T − 1,)`` in ``[0, 1]``."""
    return kinematic_amplitude(directogram(motion, bins, plane=plane, window=window), normalize=normalize)


def directogram_torch(
    motion: torch.Tensor,
    bins: int = 8,
    *,
    plane: tuple[int, int] | list[int] = (0, 1),
    window: str = "paper",
    eps: float = 1e-12,
) -> torch.Tensor:
    """Batched torch :func:`directogram`: ``(B, T, J, D)`` (or ``(T, J, D)``) → ``(B, T − 1, K)``.

    Differentiable w.r.t. the displacement magnitudes; ``eps`` keeps the norm's gradient finite at zero.
    """
    if window not in _WINDOWS:
        raise ValueError(f"window must be one of {_WINDOWS}, got {window!r}")
    squeeze = motion.ndim == 3
    x = motion.unsqueeze(0) if squeeze else motion
    if x.ndim != 4 or x.shape[1] < 2:
        raise ValueError(f"motion: expected (B, T, J, D) with T >= 2, got {tuple(motion.shape)}")
    a, b = int(plane[0]), int(plane[1])
    f = x[:, 1:, :, [a, b]] - x[:, :-1, :, [a, b]]  # (B, T-1, J, 2)
    mag = torch.sqrt((f**2).sum(-1) + eps) - math.sqrt(eps)
    angle = torch.remainder(torch.atan2(f[..., 1], f[..., 0]), 2.0 * math.pi).detach()
    width = 2.0 * math.pi / bins
    if window == "paper":
        centres = (torch.arange(bins, device=x.device, dtype=angle.dtype) + 0.5) * width
        dist = (angle[..., None] - centres).abs()
        dist = torch.minimum(dist, 2.0 * math.pi - dist)
        weights = (dist <= width).to(mag.dtype)
    else:
        idx = torch.floor(angle / width).long() % bins
        weights = torch.nn.functional.one_hot(idx, bins).to(mag.dtype)
    out = torch.einsum("btj,btjk->btk", mag, weights)
    return out[0] if squeeze else out


def kinematic_amplitude_torch(
    motion: torch.Tensor,
    bins: int = 8,
    *,
    plane: tuple[int, int] | list[int] = (0, 1),
    window: str = "paper",
    normalize: bool = True,
    eps: float = 1e-8,
) -> torch.Tensor:
    """Batched torch MoMu Eq. 1–2 from motion: ``(B, T, J, D)`` → ``(B, T − 1)`` in ``[0, 1]``.

    Same values as :func:`motion_kinematic_amplitude` (up to float rounding; ``eps`` is added to the
    per-sequence maximum to keep the division differentiable for motionless clips).
    """
    d = directogram_torch(motion, bins, plane=plane, window=window)
    q = torch.relu(d[..., 1:, :] - d[..., :-1, :]).sum(-1)
    q = torch.cat([torch.zeros_like(q[..., :1]), q], dim=-1)
    if normalize:
        q = q / (q.amax(dim=-1, keepdim=True) + eps)
    return q


def velocity_sum(motion: np.ndarray, fps: float) -> np.ndarray:
    """HarmoGAN Eq. 2: joint velocity sum ``j``, ``(T − 1,)`` float64 in units/s.

    ``j[i] = fps · Σ_p ‖v_{i+1}^p − v_i^p‖₂``: value ``i`` is the paper's ``j_t`` for frame ``t = i + 1``.
    """
    if not fps or fps <= 0:
        raise ValueError(f"fps must be positive, got {fps}")
    x = check_motion(motion, min_frames=2)
    return np.linalg.norm(np.diff(x, axis=0), axis=-1).sum(-1) * float(fps)


def visual_beats(
    motion: np.ndarray,
    fps: float,
    *,
    kind: str = "both",
    smooth_sigma: float = 0.0,
) -> tuple[np.ndarray, np.ndarray]:
    """HarmoGAN Eq. 3: visual beats at strict local extrema of the velocity sum, with their saliency.

    Args:
        motion: ``(T, J, D)`` positions.
        fps: frame rate of ``motion``.
        kind: ``"both"`` (Eq. 3: maxima and minima), ``"max"`` or ``"min"``.
        smooth_sigma: optional Gaussian smoothing of ``j`` in frames before picking (0 = the paper).

    Returns:
        ``(frames, saliency)``: int64 motion-frame indices (ascending; seconds = ``frames / fps``) and
        ``j`` at each beat (HarmoGAN's ``S_v``, units/s, un-smoothed). With ``j`` indexed as in
        :func:`velocity_sum`, an extremum at ``j[i]`` (``Δj_i > 0 > Δj_{i+1}`` or the reverse, strict) is
        reported at frame ``i + 1``, the paper's ``t`` of ``j_t``. (Eq. 3 literally labels the beat one
        frame later, at the first frame after the extremum; we report the extremum itself.)
        Plateaus (``Δj = 0``) never produce beats, as in Eq. 3's strict inequalities.
    """
    if kind not in ("both", "max", "min"):
        raise ValueError(f"kind must be 'both', 'max' or 'min', got {kind!r}")
    if smooth_sigma < 0:
        raise ValueError(f"smooth_sigma must be >= 0, got {smooth_sigma}")
    j = velocity_sum(motion, fps)
    signal = j
    if smooth_sigma > 0:
        from scipy.ndimage import gaussian_filter1d

        signal = gaussian_filter1d(j, smooth_sigma, mode="nearest")
    dj = np.diff(signal)
    prev, nxt = dj[:-1], dj[1:]
    is_max = (prev > 0) & (nxt < 0)
    is_min = (prev < 0) & (nxt > 0)
    mask = {"both": is_max | is_min, "max": is_max, "min": is_min}[kind]
    idx = np.flatnonzero(mask) + 1  # index into j
    return (idx + 1).astype(np.int64), j[idx]
