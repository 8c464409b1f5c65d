"""Properties of momu.render's pure helpers: frame picking, waveform envelope, projection, bone lines."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra.numpy import arrays

pytest.importorskip("matplotlib")

from momu.features.skeletons import get_skeleton  # noqa: E402
from momu.render import draw_skeleton, screen_coordinates, waveform_envelope  # noqa: E402
from momu.render.skeleton import new_figure, output_frames  # noqa: E402

finite = st.floats(-1e3, 1e3, allow_nan=False, width=32)


@given(
    num_frames=st.integers(1, 400),
    fps=st.sampled_from([20.0, 25.0, 30.0, 50.0, 60.0]),
    out_fps=st.sampled_from([5.0, 10.0, 20.0, 25.0]),
)
@settings(deadline=None)
def test_output_frames_follow_real_time(num_frames: int, fps: float, out_fps: float) -> None:
    out_fps = min(out_fps, fps)
    frames = np.asarray(output_frames(num_frames, fps, out_fps))
    assert frames[0] == 0 and np.all(np.diff(frames) > 0) and frames[-1] < num_frames
    # frame k is the motion frame nearest to time k / out_fps ...
    k = np.arange(frames.size)
    assert np.all(np.abs(frames / fps - k / out_fps) <= 0.5 / fps + 1e-9)
    # ... and there is one for every output time inside the clip
    assert frames.size == int(np.floor((num_frames - 1) * out_fps / fps + 1e-9)) + 1


@given(wave=arrays(np.float32, st.integers(1, 300), elements=finite), bins=st.integers(1, 50))
@settings(deadline=None)
def test_waveform_envelope_brackets_every_sample(wave: np.ndarray, bins: int) -> None:
    t, lo, hi = waveform_envelope(wave, 100, bins=bins)
    assert t.size == lo.size == hi.size == min(bins, wave.size)
    assert np.all(lo <= hi) and t[0] == 0 and np.all(np.diff(t) > 0)
    assert lo.min() == wave.min() and hi.max() == wave.max()
    starts = np.round(t * 100).astype(int)
    for a, b, low, high in zip(starts, [*starts[1:], wave.size], lo, hi, strict=True):
        assert low == wave[a:b].min() and high == wave[a:b].max()


@given(
    frame=arrays(np.float64, (24, 3), elements=finite),
    shift=st.tuples(finite, finite, finite),
)
@settings(deadline=None)
def test_bones_translate_with_the_pose(frame: np.ndarray, shift: tuple[float, float, float]) -> None:
    ax = new_figure((1, 1), 10).subplots()
    base = [np.asarray(line.get_xydata()) for line in draw_skeleton(ax, frame, "smpl24")]
    moved = [np.asarray(line.get_xydata()) for line in draw_skeleton(ax, frame + np.array(shift), "smpl24")]
    for a, b in zip(base, moved, strict=True):
        np.testing.assert_allclose(b - a, np.broadcast_to(np.array(shift[:2]), a.shape), atol=1e-6)
    assert len(base) == len(get_skeleton("smpl24").bones)


@given(motion=arrays(np.float64, (3, 5, 2), elements=finite))
@settings(deadline=None)
def test_image_keypoints_flip_only_the_vertical_axis(motion: np.ndarray) -> None:
    xy = screen_coordinates(motion)
    np.testing.assert_array_equal(xy[..., 0], motion[..., 0])
    np.testing.assert_array_equal(xy[..., 1], -motion[..., 1])
    np.testing.assert_array_equal(screen_coordinates(xy, y_down=True), motion)
