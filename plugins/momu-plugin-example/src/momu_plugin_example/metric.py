"""Motion jerk: the mean magnitude of the third derivative of joint positions."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from momu.data.types import Clip
from momu.registry import METRICS


@dataclass
class MotionJerkConfig:
    max_seconds: float = 0.0  # 0: the whole clip


class MotionJerk:
    """Mean ||d³x/dt³|| over joints and frames of the generated clips (units of the motion per s³)."""

    name = "motion_jerk"
    needs_reference = False

    def __init__(self, cfg: MotionJerkConfig) -> None:
        self.cfg = cfg

    def __call__(
        self, generated: Sequence[Clip], reference: Sequence[Clip] | None = None
    ) -> dict[str, float]:
        values = []
        for clip in generated:
            if clip.motion is None:
                raise ValueError(f"clip {clip.id!r} has no motion")
            motion = np.asarray(clip.motion, dtype=np.float64)
            if self.cfg.max_seconds > 0:
                motion = motion[: int(round(self.cfg.max_seconds * clip.fps))]
            if motion.shape[0] < 4:
                raise ValueError(f"clip {clip.id!r} has {motion.shape[0]} frames; jerk needs at least 4")
            jerk = np.diff(motion, n=3, axis=0) * clip.fps**3
            values.append(np.linalg.norm(jerk, axis=-1).mean())
        if not values:
            raise ValueError("motion_jerk needs at least one generated clip")
        return {self.name: float(np.mean(values))}

    def provenance(self) -> dict[str, Any]:
        return {"metric": self.name, "max_seconds": self.cfg.max_seconds}


@METRICS.register("motion_jerk", config=MotionJerkConfig)
def build_motion_jerk(cfg: MotionJerkConfig) -> MotionJerk:
    return MotionJerk(cfg)
