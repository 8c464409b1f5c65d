"""Motion realism beside following: how far the root travels, how fast feet and joints move, and
whether bones keep their length — to be compared with the real data's 5th-95th percentile.

All on global positions (metres, Y up) at a known rate; the skeleton (:mod:`momu.features.skeletons`)
names the root, the ankles and the bones. Without a known skeleton only the joint speed is measured.
"""

from __future__ import annotations

import numpy as np
from scipy.ndimage import gaussian_filter1d

__all__ = ["REALISM_KEYS", "ROOT_SMOOTH_S", "realism_stats"]

REALISM_KEYS = ("root_travel_m_per_min", "foot_speed", "joint_speed", "bone_length_cv")
"""Statistics: horizontal root path length per minute (m/min), mean ankle speed (m/s), mean joint speed
(m/s), mean over bones of the coefficient of variation of the bone's length over time."""
ROOT_SMOOTH_S = 0.2
"""The root path is smoothed by a Gaussian of this σ (s) before its length is taken (marker jitter
would otherwise add length)."""


def realism_stats(positions: np.ndarray, rate: float, skeleton: str | None) -> dict[str, float]:
    """:data:`REALISM_KEYS` of ``positions`` ``(T, J, D)`` sampled at ``rate`` Hz (missing ones are NaN)."""
    x = np.asarray(positions, dtype=np.float64)
    out = dict.fromkeys(REALISM_KEYS, float("nan"))
    if len(x) < 2:
        return out
    speed = np.linalg.norm(np.diff(x, axis=0), axis=-1) * rate  # (T-1, J)
    out["joint_speed"] = float(speed.mean())
    if not skeleton:
        return out
    from momu.features.skeletons import get_skeleton

    try:
        skel = get_skeleton(skeleton)
    except KeyError:
        return out
    if skel.num_joints != x.shape[1]:
        return out
    ankles = [i for i, n in enumerate(skel.joint_names) if "ankle" in n]
    if ankles:
        out["foot_speed"] = float(speed[:, ankles].mean())
    if x.shape[2] == 3:
        root = gaussian_filter1d(x[:, skel.root][:, [0, 2]], ROOT_SMOOTH_S * rate, axis=0)
        path = float(np.linalg.norm(np.diff(root, axis=0), axis=-1).sum())
        out["root_travel_m_per_min"] = path / ((len(x) - 1) / rate) * 60.0
    bones = [(p, c) for c, p in enumerate(skel.parents) if p >= 0]
    if bones:
        lengths = np.stack([np.linalg.norm(x[:, c] - x[:, p], axis=-1) for p, c in bones], axis=1)
        mean = lengths.mean(axis=0)
        ok = mean > 1e-9
        out["bone_length_cv"] = float((lengths.std(axis=0)[ok] / mean[ok]).mean()) if ok.any() else 0.0
    return out
