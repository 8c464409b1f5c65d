"""Motion representations a model can learn: world positions, or root velocity + root-relative pose.

A dancer crosses the floor: real Dance with Melody dancers travel 15–55 m a minute and span 3–8 m.
A model that learns world positions from short windows cannot place a dancer it has never seen
there, and a long dance stitched from windows drifts out of the positions it was trained on. The
``root_velocity`` representation is translation invariant (as HumanML3D's and EDGE's are):

* every joint's horizontal coordinates (x, z) are taken relative to the root's; heights (y) stay;
* the root's own x and z hold its horizontal velocity in metres per second (forward differences,
  the last repeated), so the path is the running sum of what the model generates.

:func:`from_root_velocity` integrates the velocity back from a start point; on a motion that
:func:`to_root_velocity` made it reproduces the positions exactly (up to float rounding) when
started at the first root position. 3D skeletons only (Y up).
"""

from __future__ import annotations

import numpy as np

__all__ = ["REPRESENTATIONS", "check_representation", "to_root_velocity", "from_root_velocity"]

REPRESENTATIONS = ("positions", "root_velocity")
"""Names of the representations: ``positions`` (the papers' world keypoints) and ``root_velocity``."""

_XZ = [0, 2]


def check_representation(name: str, dims: int | None = None) -> None:
    """``ValueError`` for an unknown name, or ``root_velocity`` on a 2D skeleton."""
    if name not in REPRESENTATIONS:
        raise ValueError(f"unknown motion representation {name!r}; valid: {', '.join(REPRESENTATIONS)}")
    if name == "root_velocity" and dims is not None and dims != 3:
        raise ValueError(f"motion representation 'root_velocity' needs 3D keypoints (Y up), got {dims}D")


def to_root_velocity(positions: np.ndarray, fps: float, root: int) -> np.ndarray:
    """``(T, J, 3)`` world positions → root velocity (m/s) in the root's x/z, the rest root-relative."""
    p = np.asarray(positions, dtype=np.float64)
    if p.ndim != 3 or p.shape[-1] != 3:
        raise ValueError(f"root_velocity: expected (T, J, 3) positions, got shape {p.shape}")
    out = p.copy()
    root_xz = p[:, root, _XZ]
    out[:, :, _XZ] -= root_xz[:, None, :]
    vel = np.diff(root_xz, axis=0) * float(fps) if p.shape[0] > 1 else np.zeros((1, 2))
    vel = np.concatenate([vel, vel[-1:]]) if p.shape[0] > 1 else vel
    out[:, root, 0], out[:, root, 2] = vel[:, 0], vel[:, 1]
    return out.astype(np.asarray(positions).dtype, copy=False)


def from_root_velocity(
    features: np.ndarray, fps: float, root: int, start_xz: tuple[float, float] = (0.0, 0.0)
) -> np.ndarray:
    """Inverse of :func:`to_root_velocity`: world positions whose root starts at ``start_xz``."""
    f = np.asarray(features, dtype=np.float64)
    if f.ndim != 3 or f.shape[-1] != 3:
        raise ValueError(f"root_velocity: expected (T, J, 3) features, got shape {f.shape}")
    vel = f[:, root, _XZ]
    path = np.zeros_like(vel)
    path[0] = start_xz
    if f.shape[0] > 1:
        path[1:] = np.asarray(start_xz) + np.cumsum(vel[:-1], axis=0) / float(fps)
    out = f.copy()
    out[:, root, 0] = 0.0
    out[:, root, 2] = 0.0
    out[:, :, _XZ] += path[:, None, :]
    return out.astype(np.asarray(features).dtype, copy=False)
