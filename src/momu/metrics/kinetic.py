"""Kinetic motion features (72-d for SMPL-24), vectorised over frames, joints and sequences.

Reference: AIST++ API ``aist_plusplus/features/kinetic.py`` == Bailando ``utils/features/kinetic.py``
(METRICS.md §1.1), used by FID_k / Div_k (Bailando Table 1, MoFusion Table 1, MoMu Table 7).

For each joint ``j`` (in the input's joint order) the feature vector holds ``[KE_h(j), KE_v(j), EE(j)]``:

* windowed velocity at frame ``i = 1..T-1``:
  ``V_i = (1/(n_i·ft)) Σ_{k=-w..w, 1 ≤ i+k ≤ T-1} (p_{i+k} − p_{i+k-1})``
  with ``n_i`` the number of valid ``k``;
* ``KE_h = mean_i ‖(V_i.x, V_i.z)‖²`` and ``KE_v = mean_i (V_i.y)²`` (y up; for ``up_axis="z"`` the horizontal
  pair is (x, y) and the vertical component z). No ½, no mass;
* ``EE = mean_i ‖(1/m_i) Σ_{k: 1 ≤ i+k ≤ T-2} a_{i+k}‖`` — the norm of the window-mean acceleration, where
  the reference computes **a_c = ((p_{c+1} − p_c)/ft − (p_c − p_{c−1}/ft))/ft** (operator-precedence bug: only
  ``p_{c−1}`` is divided by ``ft``), i.e. ``(p_{c+1} − p_c + p_{c−1})/ft² − p_c/ft ≈ 3540·‖p‖`` at 60 fps: EE
  measures the distance from the coordinate origin and is not translation invariant. ``variant="corrected"``
  uses the intended second difference ``(p_{c+1} − 2p_c + p_{c−1})/ft²`` (translation invariant).

Numerics follow the reference: frame differences are taken in the input dtype (float32 positions stay
float32), window sums accumulate in float64 in the same ``k`` order, per-frame terms are summed sequentially
over frames, and the result is cast to float32. ``frame_time`` defaults to 1/60 s (AIST++ / Bailando data
are 60 fps).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Literal

import numpy as np

__all__ = ["KineticVariant", "KINETIC_VARIANTS", "kinetic_features", "KINETIC_FEATURE_NAMES"]

KineticVariant = Literal["compat", "corrected"]
KINETIC_VARIANTS: tuple[str, ...] = ("compat", "corrected")
KINETIC_FEATURE_NAMES: tuple[str, ...] = ("ke_horizontal", "ke_vertical", "energy_expenditure")

_AXES: dict[str, tuple[tuple[int, int], int]] = {"y": ((0, 2), 1), "z": ((0, 1), 2)}


def _as_float_array(motion: np.ndarray, name: str) -> np.ndarray:
    x = np.asarray(motion)
    if not np.issubdtype(x.dtype, np.floating):
        x = x.astype(np.float64)
    if not np.all(np.isfinite(x)):
        raise ValueError(f"{name}: motion contains NaN or inf positions")
    return x


def _window_sum(terms: np.ndarray, window: int, out_len: int) -> tuple[np.ndarray, np.ndarray]:
    """Σ_{k=-w..w} terms[i-1+k] for i = 1..out_len, zero outside ``terms``, summed in float64 in k order.

    Args:
        terms: ``(..., L, J, 3)`` per-frame terms (frame axis -3).
        window: the half window ``w``.
        out_len: number of output frames.

    Returns:
        ``(sums (..., out_len, J, 3) float64, counts (out_len,) int)`` — counts of valid terms per frame.
    """
    length = terms.shape[-3]
    total = out_len + 2 * window  # padded length: window zeros before, ≥ window zeros after
    padded = np.zeros(terms.shape[:-3] + (total,) + terms.shape[-2:], dtype=np.float64)
    padded[..., window : window + length, :, :] = terms  # exact float32 → float64 conversion
    valid = np.zeros(total, dtype=np.int64)
    valid[window : window + length] = 1
    # The reference starts from 0.0 and adds the valid terms in k order; adding the zero padding instead of
    # skipping invalid terms leaves every partial sum bit-identical.
    acc = padded[..., 0:out_len, :, :].copy()
    counts = valid[0:out_len].copy()
    for offset in range(1, 2 * window + 1):  # k = -w+1..w
        np.add(acc, padded[..., offset : offset + out_len, :, :], out=acc)
        counts += valid[offset : offset + out_len]
    return acc, counts


def _kinetic_single(x: np.ndarray, frame_time: float, up_axis: str, window: int, variant: str) -> np.ndarray:
    """Features of ``x`` ``(..., T, J, 3)`` (leading batch axes allowed) → ``(..., J*3)`` float32."""
    num_frames = x.shape[-3]
    horizontal, vertical = _AXES[up_axis]
    ft = frame_time

    # ---- windowed velocity (frames i = 1..T-1)
    diffs = x[..., 1:, :, :] - x[..., :-1, :, :]  # input dtype; diffs[i-1] = p_i - p_{i-1}
    vsum, vcount = _window_sum(diffs, window, num_frames - 1)
    vel = vsum / (vcount.astype(np.float64) * ft)[:, None, None]
    h0, h1 = vel[..., horizontal[0]], vel[..., horizontal[1]]
    ke_h_terms = np.sqrt(h0 * h0 + h1 * h1) ** 2  # ‖(vx, vz)‖² as norm(...)**2
    vv = vel[..., vertical]
    ke_v_terms = np.sqrt(vv * vv) ** 2
    # Sequential sum over frames (the reference's Python loop), then / (T - 1).
    ke_h = np.cumsum(ke_h_terms, axis=-2)[..., -1, :] / (num_frames - 1.0)
    ke_v = np.cumsum(ke_v_terms, axis=-2)[..., -1, :] / (num_frames - 1.0)

    # ---- energy expenditure (acceleration centred at c = 1..T-2)
    nxt, cur, prv = x[..., 2:, :, :], x[..., 1:-1, :, :], x[..., :-2, :, :]
    v2 = (nxt - cur) / ft
    if variant == "compat":
        v1 = cur - prv / ft  # the reference's precedence bug (METRICS.md §1.1)
    else:
        v1 = (cur - prv) / ft
    accel = (v2 - v1) / ft  # input dtype, accel[c-1] = a_c
    asum, acount = _window_sum(accel, window, num_frames - 1)
    mean_acc = asum / acount.astype(np.float64)[:, None, None]
    ax, ay, az = mean_acc[..., 0], mean_acc[..., 1], mean_acc[..., 2]
    ee_terms = np.sqrt(ax * ax + ay * ay + az * az)  # ‖·‖ summed left to right, as a 3-element dot
    ee = np.cumsum(ee_terms, axis=-2)[..., -1, :] / (num_frames - 1.0)

    feats = np.stack([ke_h, ke_v, ee], axis=-1)  # (..., J, 3)
    return feats.reshape(feats.shape[:-2] + (-1,)).astype(np.float32)


def kinetic_features(
    motion: np.ndarray | Sequence[np.ndarray],
    *,
    frame_time: float = 1.0 / 60.0,
    up_axis: Literal["y", "z"] = "y",
    sliding_window: int = 2,
    variant: KineticVariant = "compat",
) -> np.ndarray:
    """Kinetic features of one motion or a batch of motions (METRICS.md §1.1).

    Args:
        motion: joint positions in metres, ``(T, J, 3)`` for one sequence, ``(N, T, J, 3)`` for a batch of
            equal-length sequences, or a list of ``(T_n, J, 3)`` arrays of varying length. Axis order
            (x, y, z) with ``up_axis`` up; SMPL-24 order for the standard 72-d vector. T ≥ 3.
        frame_time: seconds per frame (1/60 for AIST++/Bailando; the reference's constant).
        up_axis: ``"y"`` (AIST++, Bailando) or ``"z"``.
        sliding_window: half width ``w`` of the averaging window in frames (reference: 2), ≥ 1.
        variant: ``"compat"`` reproduces the reference including the EE precedence bug; ``"corrected"``
            uses the true second difference for EE (KE identical in both).

    Returns:
        float32 ``(3·J,)`` for one sequence or ``(N, 3·J)`` for a batch, ordered joint by joint as
        ``[KE_h, KE_v, EE]`` — KE in (m/s)², EE in m/s² (in ``"compat"`` it grows with distance from origin).

    Raises:
        ValueError: wrong shape, fewer than 3 frames (the reference gives NaN EE at T = 2), non-finite
            positions, unknown ``variant`` / ``up_axis``, ``sliding_window < 1`` or ``frame_time <= 0``.
    """
    if variant not in KINETIC_VARIANTS:
        raise ValueError(f"variant must be one of {KINETIC_VARIANTS}, got {variant!r}")
    if up_axis not in _AXES:
        raise ValueError(f"up_axis must be 'y' or 'z', got {up_axis!r}")
    if int(sliding_window) != sliding_window or sliding_window < 1:
        raise ValueError(f"sliding_window must be an integer ≥ 1, got {sliding_window!r}")
    if not frame_time > 0:
        raise ValueError(f"frame_time must be > 0 seconds, got {frame_time!r}")
    window = int(sliding_window)

    if isinstance(motion, (list, tuple)):
        if not motion:
            raise ValueError("motion: empty list of sequences")
        return np.stack(
            [
                kinetic_features(
                    m, frame_time=frame_time, up_axis=up_axis, sliding_window=window, variant=variant
                )
                for m in motion
            ]
        )
    x = _as_float_array(np.asarray(motion), "motion")
    if x.ndim not in (3, 4) or x.shape[-1] != 3:
        raise ValueError(f"motion: expected (T, J, 3) or (N, T, J, 3) positions, got shape {x.shape}")
    if x.shape[-3] < 3:
        raise ValueError(
            f"motion: kinetic features need at least 3 frames, got {x.shape[-3]} "
            "(the reference returns NaN energy expenditure for 2 frames)"
        )
    if x.shape[-2] < 1:
        raise ValueError("motion: no joints")
    with np.errstate(over="ignore"):
        return _kinetic_single(x, float(frame_time), up_axis, window, variant)
