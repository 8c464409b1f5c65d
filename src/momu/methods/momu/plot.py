"""A MoMu Figure 4/5-style beat-matching plot of one generated sample (matplotlib, Agg backend).

Rows: the music's onset beats (LORIS detector) and the motion's kinematic amplitude ``Q`` (MoMu
Eq. 2) with its kinematic beats, for the ground truth and for the generated sample, on one time
axis, so a reader sees whether generated beats line up with the beats they should follow.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from momu.data.types import Clip
from momu.features.kinematics import motion_kinematic_amplitude
from momu.metrics.kinematic_beats import kinematic_beat_frames
from momu.metrics.loris_scores import onset_times

__all__ = ["beat_plot"]


def beat_plot(truth: Clip, music: Clip, motion: Clip, path: str | Path, *, joint: bool = False) -> Path:
    """Write ``path`` (PNG): music onsets and motion kinematic beats, ground truth vs generated.

    ``joint``: the generated music and motion were generated together (no ground-truth pairing);
    the ground-truth rows are then shown for reference only.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    rows = [("ground-truth music", truth), ("generated music", music)]
    fig, axes = plt.subplots(4, 1, figsize=(10, 6), sharex=True)
    for ax, (label, clip) in zip(axes[:2], rows):
        assert clip.audio is not None and clip.sample_rate
        t = np.arange(len(clip.audio)) / clip.sample_rate
        ax.plot(t, clip.audio, lw=0.3, color="0.5")
        for x in onset_times(clip.audio, int(clip.sample_rate)):
            ax.axvline(x, color="tab:blue", lw=0.8)
        ax.set_ylabel(label, rotation=0, ha="right", fontsize=8)
    for ax, (label, clip) in zip(axes[2:], [("ground-truth motion", truth), ("generated motion", motion)]):
        assert clip.motion is not None
        q = motion_kinematic_amplitude(np.asarray(clip.motion, dtype=np.float64))
        ax.plot((np.arange(len(q)) + 1) / clip.fps, q, lw=0.8, color="tab:orange")
        for f in kinematic_beat_frames(clip.motion, clip.fps):
            ax.axvline(f / clip.fps, color="tab:red", lw=0.8, alpha=0.7)
        ax.set_ylabel(label, rotation=0, ha="right", fontsize=8)
    axes[-1].set_xlabel("time (s)")
    title = "joint generation (cross guidance)" if joint else "cross generation (conditioned on ground truth)"
    fig.suptitle(
        f"MoMu beat matching: {truth.id} — {title}; blue: music onsets, red: kinematic beats", fontsize=9
    )
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
