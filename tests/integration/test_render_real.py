"""Real data: a MoMu Figure 4/5-style plot and a GIF of one Dance with Melody dance (dwm21, 25 fps)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("matplotlib")
from PIL import Image  # noqa: E402
from tests.helpers.shared_data import shared_data_dir  # noqa: E402

from momu.features.audio import onset_times  # noqa: E402
from momu.metrics.kinematic_beats import kinematic_beat_frames  # noqa: E402
from momu.registry import DATASETS  # noqa: E402
from momu.render import clip_animation, clip_beat_figure  # noqa: E402

DATA = shared_data_dir() / "dance_with_melody"
pytestmark = pytest.mark.skipif(not DATA.is_dir(), reason=f"{DATA} not available")


def test_beat_figure_and_gif_of_a_real_dance(tmp_path: Path) -> None:
    import momu.data  # noqa: F401  (registers the loaders)

    ds = DATASETS.build(
        "dance_with_melody",
        {"root": str(DATA), "window_seconds": 8.0, "window_offset_seconds": 10.0, "sample_rate": 22050},
    )
    clip = ds[0]
    assert clip.skeleton == "dwm21" and clip.motion is not None and clip.audio is not None
    summary = clip_beat_figure(tmp_path / "beats.png", clip, strip_at="motion", figsize=(8.0, 5.0), dpi=60)
    with Image.open(tmp_path / "beats.png") as im:
        assert im.format == "PNG" and im.size == (480, 300)
    # the figure shows exactly the beats the beat metrics count
    np.testing.assert_allclose(summary.music_beats, onset_times(clip.audio, 22050))
    np.testing.assert_allclose(summary.motion_beats, kinematic_beat_frames(clip.motion, clip.fps) / clip.fps)
    assert len(summary.music_beats) > 4 and len(summary.motion_beats) > 0
    beat_frames = {int(round(t * clip.fps)) for t in summary.motion_beats}
    assert set(summary.strip_frames) <= beat_frames
    assert len(summary.strip_frames) == min(8, len(beat_frames))

    short = type(clip)(
        id=clip.id, motion=clip.motion[:10], fps=clip.fps, skeleton=clip.skeleton,
        trajectory=None if clip.trajectory is None else clip.trajectory[:10],
    )  # fmt: skip
    clip_animation(tmp_path / "dance.gif", short, figsize=(2.0, 2.0), dpi=30)
    with Image.open(tmp_path / "dance.gif") as im:
        assert im.size == (60, 60) and im.info["duration"] == 40  # 25 fps
