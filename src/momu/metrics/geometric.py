"""Geometric ("manual") motion features (32-d), vectorised over frames and sequences.

Reference: Bailando ``utils/features/manual_new.py`` == AIST++ API ``manual.py`` after commit 091f00b
(METRICS.md §1.2), used by FID_g / Div_g (Bailando's ``fid_m`` / ``div_m``). Müller-style boolean relational
features of SMPL-24 joints (y up, metres), evaluated at frames ``t = 1..T-1`` and averaged over frames, so
each entry is the fraction of frames where the relation holds.

Primitives (``t`` = current frame, ``t-1`` the previous one; ``tpf`` = time per frame):

* ``move(j1,j2,j3,j4,θ)``: ``v = (j3−j1)_t − (j3−j1)_{t−1}``, ``d = j2 − j1``; ``(v·d/‖d‖)/tpf > θ``. The
  reference **ignores j4** (the moving point is j3), so features 4 and 5 are identical.
* ``nmove(j1,j2,j3,j4,θ)``: ``v = (j4−j1)_t − (j4−j1)_{t−1}``, ``d = (j3−j1)×(j2−j1)``; ``(v·d/‖d‖)/tpf > θ``.
* ``plane(j1,j2,j3,j4,θ)``: ``n = (j3−j1)×(j2−j1)``; ``n·(j4−j1)/‖n‖ > θ``.
* ``nplane(j1,j2,j3,j4,θ)``: ``n = j2−j1``; ``n·(j4−j3)/‖n‖ > θ``.
* ``angle(j1,j2,j3,j4,(lo,hi))``: ``lo < degrees(arccos((j2−j1)·(j4−j3)/(‖j2−j1‖‖j4−j3‖))) < hi``
  (no clipping: a cosine that rounds above 1 gives NaN → False).
* ``fast(j,θ)``: ``‖j_t − j_{t−1}‖/tpf > θ``.

Virtual joints: ``zero`` = (0,0,0), ``y_unit`` = (0,1,0), ``minus_y_unit`` = (0,−1,0),
``y_min`` = (0, min_j y_j(t), 0).
Thresholds scale with constants measured on the SMPL rest pose: humerus length ``hl``, shoulder width ``sw``,
hip width ``hw``.

Variants:

* ``"compat"`` (default): the reference, including ``tpf = 1/120`` s on 60-fps data (velocities are twice the
  true speed), the ignored fourth joint of ``move`` and the unclipped arccos. Arithmetic follows the
  reference's dtypes (named joints in the input dtype, virtual joints in float64).
* ``"corrected"``: ``tpf = 1/fps`` (true speed), the arccos argument clipped to [−1, 1], and features 4/5
  ("right / left hand moves up along the spine") move the wrist given as the table's fourth joint, relative
  to the chest. All other features are unchanged (their intended fourth-joint semantics cannot be recovered
  from the table: using j4 as the moving point would make feature 9 vanish identically).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any, Literal

import numpy as np

__all__ = [
    "GeometricVariant",
    "GEOMETRIC_VARIANTS",
    "SMPL_JOINT_NAMES",
    "GEOMETRIC_FEATURE_TABLE",
    "geometric_features",
    "HUMERUS_LENGTH",
    "SHOULDER_WIDTH",
    "HIP_WIDTH",
]

GeometricVariant = Literal["compat", "corrected"]
GEOMETRIC_VARIANTS: tuple[str, ...] = ("compat", "corrected")

SMPL_JOINT_NAMES: tuple[str, ...] = (
    "root", "lhip", "rhip", "belly", "lknee", "rknee", "spine", "lankle", "rankle", "chest", "ltoes", "rtoes",
    "neck", "linshoulder", "rinshoulder", "head", "lshoulder", "rshoulder", "lelbow", "relbow", "lwrist",
    "rwrist", "lhand", "rhand",
)  # fmt: skip
_INDEX = {name: i for i, name in enumerate(SMPL_JOINT_NAMES)}
_VIRTUAL = ("zero", "y_unit", "minus_y_unit", "y_min")

# Hard-coded SMPL rest joints of the reference (metres): lshoulder, lelbow, rshoulder, lhip, rhip.
_LSHOULDER = np.array([1.99113488e-01, 2.36807942e-01, -1.80702247e-02])
_LELBOW = np.array([4.54445392e-01, 2.21158922e-01, -4.10167128e-02])
_RSHOULDER = np.array([-1.91692337e-01, 2.36928746e-01, -1.23055102e-02])
_LHIP = np.array([5.64076714e-02, -3.23069185e-01, 1.09197125e-02])
_RHIP = np.array([-6.24834076e-02, -3.31302464e-01, 1.50412619e-02])
HUMERUS_LENGTH = np.linalg.norm(_LSHOULDER - _LELBOW)  # 0.2568381092115207
SHOULDER_WIDTH = np.linalg.norm(_LSHOULDER - _RSHOULDER)  # 0.39084835854945527
HIP_WIDTH = np.linalg.norm(_LHIP - _RHIP)  # 0.11924706586886204

_HL, _SW, _HW = HUMERUS_LENGTH, SHOULDER_WIDTH, HIP_WIDTH

# (primitive, joints, threshold or (lo, hi)) — METRICS.md §1.2 table, in output order.
GEOMETRIC_FEATURE_TABLE: tuple[tuple[str, tuple[str, ...], Any], ...] = (
    ("nmove", ("neck", "rhip", "lhip", "rwrist"), 1.8 * _HL),
    ("nmove", ("neck", "lhip", "rhip", "lwrist"), 1.8 * _HL),
    ("nplane", ("chest", "neck", "neck", "rwrist"), 0.2 * _HL),
    ("nplane", ("chest", "neck", "neck", "lwrist"), 0.2 * _HL),
    ("move", ("belly", "chest", "chest", "rwrist"), 1.8 * _HL),
    ("move", ("belly", "chest", "chest", "lwrist"), 1.8 * _HL),
    ("angle", ("relbow", "rshoulder", "relbow", "rwrist"), (0, 110)),
    ("angle", ("lelbow", "lshoulder", "lelbow", "lwrist"), (0, 110)),
    ("nplane", ("lshoulder", "rshoulder", "lwrist", "rwrist"), 2.5 * _SW),
    ("move", ("lwrist", "rwrist", "rwrist", "lwrist"), 1.4 * _HL),
    ("move", ("rwrist", "root", "lwrist", "root"), 1.4 * _HL),
    ("move", ("lwrist", "root", "rwrist", "root"), 1.4 * _HL),
    ("fast", ("rwrist",), 2.5 * _HL),
    ("fast", ("lwrist",), 2.5 * _HL),
    ("plane", ("root", "lhip", "ltoes", "rankle"), 0.38 * _HL),
    ("plane", ("root", "rhip", "rtoes", "lankle"), 0.38 * _HL),
    ("nplane", ("zero", "y_unit", "y_min", "rankle"), 1.2 * _HL),
    ("nplane", ("zero", "y_unit", "y_min", "lankle"), 1.2 * _HL),
    ("nplane", ("lhip", "rhip", "lankle", "rankle"), 2.1 * _HW),
    ("angle", ("rknee", "rhip", "rknee", "rankle"), (0, 110)),
    ("angle", ("lknee", "lhip", "lknee", "lankle"), (0, 110)),
    ("fast", ("rankle",), 2.5 * _HL),
    ("fast", ("lankle",), 2.5 * _HL),
    ("angle", ("neck", "root", "rshoulder", "relbow"), (25, 180)),
    ("angle", ("neck", "root", "lshoulder", "lelbow"), (25, 180)),
    ("angle", ("neck", "root", "rhip", "rknee"), (50, 180)),
    ("angle", ("neck", "root", "lhip", "lknee"), (50, 180)),
    ("plane", ("rankle", "neck", "lankle", "root"), 0.5 * _HL),
    ("angle", ("neck", "root", "zero", "y_unit"), (70, 110)),
    ("nplane", ("zero", "minus_y_unit", "y_min", "rwrist"), -1.2 * _HL),
    ("nplane", ("zero", "minus_y_unit", "y_min", "lwrist"), -1.2 * _HL),
    ("fast", ("root",), 2.3 * _HL),
)
# Features whose corrected form moves the table's fourth joint (the wrist) instead of the third.
_CORRECTED_MOVE_J4 = frozenset({4, 5})


def _dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Row-wise 3-vector dot product, summed left to right like a 3-element BLAS dot."""
    return a[..., 0] * b[..., 0] + a[..., 1] * b[..., 1] + a[..., 2] * b[..., 2]


def _norm(a: np.ndarray) -> np.ndarray:
    return np.sqrt(_dot(a, a))


class _Frames:
    """Joint lookup over frames 1..T-1 (current) and 0..T-2 (previous), batched over leading axes."""

    def __init__(self, x: np.ndarray) -> None:
        self.cur = x[..., 1:, :, :]
        self.prev = x[..., :-1, :, :]
        lead = self.cur.shape[:-2]
        zeros = np.zeros(lead + (3,), dtype=np.float64)
        y_min = zeros.copy()
        # The reference builds [0, min(y), 0] as a Python list → float64 array.
        y_min[..., 1] = self.cur[..., :, 1].min(axis=-1)
        unit = np.zeros(3)
        unit[1] = 1.0
        self.virtual = {
            "zero": zeros,
            "y_unit": np.broadcast_to(unit, lead + (3,)),
            "minus_y_unit": np.broadcast_to(-unit, lead + (3,)),
            "y_min": y_min,
        }

    def now(self, name: str) -> np.ndarray:
        if name in self.virtual:
            return self.virtual[name]
        return self.cur[..., _INDEX[name], :]

    def before(self, name: str) -> np.ndarray:
        return self.prev[..., _INDEX[name], :]


def _geometric_single(x: np.ndarray, variant: str, time_per_frame: float) -> np.ndarray:
    f = _Frames(x)
    corrected = variant == "corrected"
    columns = []
    for index, (kind, joints, param) in enumerate(GEOMETRIC_FEATURE_TABLE):
        if kind == "move":
            j1, j2, j3, j4 = joints
            moving = j4 if corrected and index in _CORRECTED_MOVE_J4 else j3
            base = j3 if corrected and index in _CORRECTED_MOVE_J4 else j1
            velocity = (f.now(moving) - f.now(base)) - (f.before(moving) - f.before(base))
            direction = f.now(j2) - f.now(j1)
            along = _dot(velocity, direction) / _norm(direction)
            value = (along / time_per_frame) > param
        elif kind == "nmove":
            j1, j2, j3, j4 = joints
            velocity = (f.now(j4) - f.now(j1)) - (f.before(j4) - f.before(j1))
            direction = np.cross(f.now(j3) - f.now(j1), f.now(j2) - f.now(j1))
            along = _dot(velocity, direction) / _norm(direction)
            value = (along / time_per_frame) > param
        elif kind == "plane":
            a, b, c, p = (f.now(j) for j in joints)
            normal = np.cross(c - a, b - a)
            value = (_dot(normal, p - a) / _norm(normal)) > param
        elif kind == "nplane":
            n1, n2, a, p = (f.now(j) for j in joints)
            normal = n2 - n1
            value = (_dot(normal, p - a) / _norm(normal)) > param
        elif kind == "angle":
            a1, a2, b1, b2 = (f.now(j) for j in joints)
            u, v = a2 - a1, b2 - b1
            cosine = _dot(u, v) / (_norm(u) * _norm(v))
            if corrected:
                cosine = np.clip(cosine, -1.0, 1.0)
            angle = np.degrees(np.arccos(cosine))
            lo, hi = param
            value = (angle > lo) & (angle < hi)
        elif kind == "fast":
            (j,) = joints
            value = (_norm(f.now(j) - f.before(j)) / time_per_frame) > param
        else:  # pragma: no cover - table is static
            raise AssertionError(kind)
        columns.append(value)
    booleans = np.stack(columns, axis=-1).astype(np.float32)  # (..., T-1, 32)
    return booleans.mean(axis=-2)


def geometric_features(
    motion: np.ndarray | Sequence[np.ndarray],
    *,
    variant: GeometricVariant = "compat",
    fps: float = 60.0,
    time_per_frame: float | None = None,
) -> np.ndarray:
    """Geometric (manual) features of one motion or a batch (METRICS.md §1.2).

    Args:
        motion: SMPL-24 joint positions in metres, y up: ``(T, 24, 3)``, ``(N, T, 24, 3)`` or a list of
            ``(T_n, 24, 3)`` arrays. T ≥ 2.
        variant: ``"compat"`` (reference) or ``"corrected"`` (see the module docstring).
        fps: the motion's frame rate; used by ``"corrected"`` (time per frame = 1/fps).
        time_per_frame: override the time per frame in seconds (default: 1/120 for ``"compat"`` — the
            reference's constant — and 1/fps for ``"corrected"``).

    Returns:
        float32 ``(32,)`` or ``(N, 32)``: the fraction of frames 1..T-1 where each relation holds.

    Raises:
        ValueError: not 24 joints × 3 coordinates, fewer than 2 frames (the reference averages an empty list
            → NaN), non-finite positions, or an unknown variant.
    """
    if variant not in GEOMETRIC_VARIANTS:
        raise ValueError(f"variant must be one of {GEOMETRIC_VARIANTS}, got {variant!r}")
    if time_per_frame is None:
        if not fps > 0:
            raise ValueError(f"fps must be > 0, got {fps!r}")
        tpf = 1.0 / 120.0 if variant == "compat" else 1.0 / float(fps)
    else:
        if not time_per_frame > 0:
            raise ValueError(f"time_per_frame must be > 0 seconds, got {time_per_frame!r}")
        tpf = float(time_per_frame)

    if isinstance(motion, (list, tuple)):
        if not motion:
            raise ValueError("motion: empty list of sequences")
        return np.stack([geometric_features(m, variant=variant, time_per_frame=tpf) for m in motion])
    x = np.asarray(motion)
    if not np.issubdtype(x.dtype, np.floating):
        x = x.astype(np.float64)
    if x.ndim not in (3, 4) or x.shape[-2:] != (24, 3):
        raise ValueError(
            "motion: geometric features need SMPL-24 positions (T, 24, 3) or (N, T, 24, 3), "
            f"got shape {x.shape}"
        )
    if x.shape[-3] < 2:
        raise ValueError(f"motion: geometric features need at least 2 frames, got {x.shape[-3]}")
    if not np.all(np.isfinite(x)):
        raise ValueError("motion: contains NaN or inf positions")
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
        return _geometric_single(x, variant, tpf)
