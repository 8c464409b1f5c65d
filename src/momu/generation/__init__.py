"""Generation beyond one model window: long sequences stitched by latent inpainting.

* :mod:`momu.generation.windows` — window plans (``two_pass`` and ``sequential`` schedules), window seeds;
* :mod:`momu.generation.stitching` — :func:`stitched_sample`, the seam statistic;
* :mod:`momu.generation.momu_long` — music → motion and motion → music of any length with a MoMuModel.
"""

from momu.generation.momu_long import motion_to_music_long, music_to_motion_long, window_frames
from momu.generation.stitching import seam_jumps, stitched_sample, velocity_jumps
from momu.generation.windows import SCHEDULES, WindowPlan, plan_windows

__all__ = [
    "SCHEDULES",
    "WindowPlan",
    "motion_to_music_long",
    "music_to_motion_long",
    "plan_windows",
    "seam_jumps",
    "stitched_sample",
    "velocity_jumps",
    "window_frames",
]
