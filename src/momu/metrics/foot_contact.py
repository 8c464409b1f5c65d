"""Physical Foot Contact score, PFC (EDGE ``eval/eval_pfc.py::calc_physical_score``; METRICS.md §1.9).

Per sequence, SMPL-24 joints ``(S, 24, 3)``, **z-up**, DT = 1/30 s:

* ``root_v = (p_{1:,0} − p_{:−1,0}) / DT``; ``root_a = (root_v_{1:} − root_v_{:−1}) / DT`` (S−2, 3);
  the up component is clamped at 0 (``max(a_up, 0)``); ``a = ‖root_a‖``; ``a ← a / max(a)``;
* feet = joints (7, 10, 8, 11) (left ankle, left foot, right ankle, right foot);
  ``foot_v = ‖(feet_{2:} − feet_{1:−1})`` over the two horizontal axes‖ — displacement per frame, **not**
  divided by DT, so the score depends on the frame rate;
* ``m_L = min(foot_v[:,0], foot_v[:,1])``, ``m_R = min(foot_v[:,2], foot_v[:,3])``;
  ``loss = mean_t(m_L · m_R · a)``; dataset PFC = mean over sequences × 10000 (lower is better).

A motion whose root never accelerates has ``max(a) = 0`` and the reference returns NaN; momu raises a
``ValueError`` (or, with ``static="zero"``, scores it 0: no root acceleration, no foot-sliding penalty).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from momu.data.types import Clip
from momu.metrics._checks import as_motion
from momu.metrics._clips import ClipMetric, clip_motion
from momu.metrics.base import MetricResult
from momu.registry import METRICS

__all__ = ["pfc_sequence", "pfc", "PFCConfig", "PFCMetric", "EDGE_FOOT_JOINTS"]

EDGE_FOOT_JOINTS: tuple[int, int, int, int] = (7, 10, 8, 11)
"""SMPL-24 indices of left ankle, left foot, right ankle, right foot (EDGE's ``foot_idx``)."""


def pfc_sequence(
    joints: np.ndarray,
    *,
    up_axis: int = 2,
    fps: float = 30.0,
    root: int = 0,
    feet: Sequence[int] = EDGE_FOOT_JOINTS,
    static: str = "raise",
) -> float:
    """EDGE's per-sequence physical foot-contact loss (not yet ×10000).

    Args:
        joints: joint positions ``(S, J, 3)`` in metres, ``S >= 3``.
        up_axis: index of the vertical axis (EDGE: 2, z-up; momu clips are y-up: 1).
        fps: frame rate giving DT = 1/fps (EDGE: 30). Only the root acceleration uses DT, and it is
            max-normalised, so the value depends on ``fps`` through rounding only; the foot speed is a
            per-frame displacement.
        root: index of the root joint; feet: (left ankle, left foot, right ankle, right foot).
        static: ``"raise"`` (default) or ``"zero"`` when the root never accelerates (reference: NaN).
    """
    p = as_motion(joints, "joints", min_frames=3)
    if p.shape[2] != 3:
        raise ValueError(f"joints: PFC needs 3-D positions (S, J, 3), got {p.shape}")
    if up_axis not in (0, 1, 2):
        raise ValueError(f"up_axis: must be 0, 1 or 2, got {up_axis}")
    idx = [root, *feet]
    if len(feet) != 4 or max(idx) >= p.shape[1] or min(idx) < 0:
        raise ValueError(f"joints: has {p.shape[1]} joints; root {root} and feet {tuple(feet)} must index it")
    if static not in ("raise", "zero"):
        raise ValueError(f"static: expected 'raise' or 'zero', got {static!r}")
    dt = 1 / fps
    flat = [i for i in range(3) if i != up_axis]
    root_v = (p[1:, root, :] - p[:-1, root, :]) / dt
    root_a = (root_v[1:] - root_v[:-1]) / dt
    root_a[:, up_axis] = np.maximum(root_a[:, up_axis], 0)
    acc = np.linalg.norm(root_a, axis=-1)
    scale = acc.max()
    if scale == 0:
        if static == "zero":
            return 0.0
        raise ValueError(
            "joints: the root never accelerates (static or constant-velocity root); EDGE's PFC divides by "
            "max acceleration 0 and returns NaN (pass static='zero' to score it 0)"
        )
    acc = acc / scale
    foot = p[:, list(feet)]
    foot_v = np.linalg.norm(foot[2:][:, :, flat] - foot[1:-1][:, :, flat], axis=-1)
    left = np.minimum(foot_v[:, 0], foot_v[:, 1])
    right = np.minimum(foot_v[:, 2], foot_v[:, 3])
    return float((left * right * acc).mean())


def pfc(
    motions: Sequence[np.ndarray],
    *,
    up_axis: int = 2,
    fps: float = 30.0,
    root: int = 0,
    feet: Sequence[int] = EDGE_FOOT_JOINTS,
    static: str = "raise",
) -> float:
    """Dataset PFC = mean over sequences of :func:`pfc_sequence` × 10000 (EDGE Table 1; lower is better).

    Inputs follow EDGE: SMPL-24 joints, z-up, 30 fps. (EDGE samples 1000 files at random when given more;
    momu scores all of them.)
    """
    if len(motions) == 0:
        raise ValueError("pfc: no motions")
    scores = [pfc_sequence(m, up_axis=up_axis, fps=fps, root=root, feet=feet, static=static) for m in motions]
    return float(np.mean(scores) * 10000)


@dataclass
class PFCConfig:
    """Parameters of the registered ``pfc`` metric.

    Attributes:
        up_axis: vertical axis of the clips' motion; momu clips are Y-up (1). Use 2 for EDGE's z-up files.
        root: root joint index; feet: (left ankle, left foot, right ankle, right foot) indices (SMPL-24).
        static: ``"raise"`` or ``"zero"`` for a motion whose root never accelerates.
    """

    up_axis: int = 1
    root: int = 0
    feet: tuple[int, int, int, int] = EDGE_FOOT_JOINTS
    static: str = "raise"


class PFCMetric(ClipMetric):
    """Registered ``pfc``: EDGE's PFC over the generated clips (DT from each clip's fps)."""

    def __call__(self, generated: Sequence[Clip], reference: Sequence[Clip] | None = None) -> MetricResult:
        cfg: PFCConfig = self.cfg
        scores = []
        for clip in self._require(generated):
            try:
                scores.append(
                    pfc_sequence(
                        clip_motion(clip, self.name),
                        up_axis=cfg.up_axis,
                        fps=clip.fps,
                        root=cfg.root,
                        feet=tuple(cfg.feet),
                        static=cfg.static,
                    )
                )
            except ValueError as exc:
                raise ValueError(f"{self.name}: clip {clip.id!r}: {exc}") from None
        return {self.name: float(np.mean(scores) * 10000)}


@METRICS.register("pfc", config=PFCConfig)
def build_pfc(cfg: PFCConfig) -> PFCMetric:
    """``pfc`` (EDGE; METRICS.md §1.9)."""
    return PFCMetric(cfg, name="pfc", needs_reference=False, spec="METRICS.md §1.9 (EDGE eval_pfc.py)")
