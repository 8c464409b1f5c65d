"""momu.render: skeleton drawing, beat-matching figures and animations (tiny clips, low DPI)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("matplotlib")
from PIL import Image, ImageSequence  # noqa: E402  (Pillow ships with matplotlib)

from momu.features.audio import onset_times  # noqa: E402
from momu.features.skeletons import get_skeleton  # noqa: E402
from momu.metrics.kinematic_beats import kinematic_beat_frames  # noqa: E402
from momu.render import (  # noqa: E402
    BeatFigureSummary,
    beat_matching_figure,
    draw_skeleton,
    screen_coordinates,
    skeleton_animation,
    waveform_envelope,
)
from momu.render.skeleton import LEFT_COLOR, RIGHT_COLOR, new_figure, output_frames  # noqa: E402

PNG_MAGIC = b"\x89PNG\r\n\x1a\n"
FPS = 30.0
SR = 8000


def _rest_motion(skeleton: str, frames: int, dims: int | None = None) -> np.ndarray:
    """``(T, J, D)`` rest pose of ``skeleton`` repeated ``frames`` times (metres, Y up)."""
    skel = get_skeleton(skeleton)
    pose = skel.rest_pose()
    if dims == 2:
        pose = pose[:, :2]
    return np.repeat(pose[None], frames, axis=0).astype(np.float64)


def _jerky_motion(frames: int, jerks: list[int]) -> np.ndarray:
    """smpl24 rest pose, the right wrist jumping 10 cm sideways between frame r and r + 1 for r in ``jerks``.

    Each jump makes one non-zero directogram row, so ``Q`` (MoMu Eq. 2) is 1 at exactly those ``r``
    and 0 elsewhere: the kinematic beats are the frames ``jerks``.
    """
    motion = _rest_motion("smpl24", frames)
    wrist = get_skeleton("smpl24").index("r_wrist")
    for r in jerks:
        motion[r + 1 :, wrist, 0] += 0.1 if (jerks.index(r) % 2 == 0) else -0.1
    return motion


def _clicks(times: list[float], seconds: float, sr: int = SR) -> np.ndarray:
    """Decaying 1 kHz bursts starting at ``times`` (s) over silence, ``seconds`` long."""
    audio = np.zeros(int(seconds * sr), dtype=np.float32)
    n = int(0.05 * sr)
    burst = np.sin(2 * np.pi * 1000 * np.arange(n) / sr) * np.exp(-np.arange(n) / (0.01 * sr))
    for t in times:
        i = int(t * sr)
        audio[i : i + n] += burst[: audio.size - i].astype(np.float32)
    return audio


# ----------------------------------------------------------------------------------- import / helpers
def test_import_does_not_import_matplotlib() -> None:
    code = "import sys, momu.render; print('matplotlib' in sys.modules)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "False"


def test_screen_coordinates_projects_front_plane_and_flips_image_y() -> None:
    m3 = np.array([[[1.0, 2.0, 3.0], [4.0, 5.0, 6.0]]])
    np.testing.assert_array_equal(screen_coordinates(m3), [[[1.0, 2.0], [4.0, 5.0]]])  # x right, y up
    np.testing.assert_array_equal(screen_coordinates(m3, plane=(0, 2)), [[[1.0, 3.0], [4.0, 6.0]]])
    m2 = m3[..., :2]  # image pixels, v down: drawn upright
    np.testing.assert_array_equal(screen_coordinates(m2), [[[1.0, -2.0], [4.0, -5.0]]])
    np.testing.assert_array_equal(screen_coordinates(m2, y_down=False), m2)
    np.testing.assert_array_equal(screen_coordinates(m3, y_down=True), [[[1.0, -2.0], [4.0, -5.0]]])


def test_waveform_envelope_hand_case() -> None:
    t, lo, hi = waveform_envelope(np.array([0, 1, -1, 2, 3, -3, 0, 0], dtype=np.float32), 4, bins=2)
    np.testing.assert_array_equal(t, [0.0, 1.0])
    np.testing.assert_array_equal(lo, [-1.0, -3.0])
    np.testing.assert_array_equal(hi, [2.0, 3.0])
    with pytest.raises(ValueError, match="empty"):
        waveform_envelope(np.zeros(0), 4)


def test_output_frames_pick_real_time_frames() -> None:
    # 60 fps shown at 25 fps: motion frames nearest to k / 25 s, i.e. round(2.4 k)
    assert output_frames(10, 60.0, 25.0) == [0, 2, 5, 7]
    assert output_frames(4, 25.0, 25.0) == [0, 1, 2, 3]
    assert output_frames(1, 60.0, 25.0) == [0]


# ----------------------------------------------------------------------------------- draw_skeleton
def test_draw_skeleton_one_line_per_bone_at_the_projected_joints() -> None:
    skel = get_skeleton("smpl24")
    frame = np.random.default_rng(0).normal(size=(24, 3))
    ax = new_figure((2, 2), 40).subplots()
    lines = draw_skeleton(ax, frame, "smpl24", offset=(1.0, -2.0), scale=2.0)
    assert len(lines) == len(skel.bones) == 23
    for line, (p, c) in zip(lines, skel.bones, strict=True):
        expected = frame[[p, c]][:, :2] * 2.0 + np.array([1.0, -2.0])
        np.testing.assert_allclose(np.asarray(line.get_xydata()), expected)
    colours = {skel.joint_names[c]: line.get_color() for line, (_, c) in zip(lines, skel.bones, strict=True)}
    assert colours["l_wrist"] == LEFT_COLOR and colours["r_wrist"] == RIGHT_COLOR
    assert colours["spine1"] == "black"


def test_draw_skeleton_2d_keypoints_are_drawn_upright() -> None:
    frame = _rest_motion("openpose14", 1, dims=2)[0]
    frame[:, 1] *= -1  # image convention: v grows downwards, so the head has the smallest v
    ax = new_figure((2, 2), 40).subplots()
    lines = draw_skeleton(ax, frame, "openpose14")
    skel = get_skeleton("openpose14")
    nose_neck = np.asarray(lines[[c for _, c in skel.bones].index(skel.index("nose"))].get_xydata())
    assert nose_neck[1, 1] > nose_neck[0, 1]  # child (nose) drawn above parent (neck)


@pytest.mark.parametrize(
    ("frame", "skeleton", "match"),
    [
        (np.zeros((14, 3)), "smpl24", "24 joints but the motion has 14"),
        (np.zeros((24, 3)), "no_such_skeleton", "valid names"),
        (np.zeros((2, 24, 3)), "smpl24", r"one pose of shape \(J, 2\|3\)"),
        (np.full((24, 3), np.nan), "smpl24", "non-finite"),
        (np.zeros((24, 4)), "smpl24", "D in"),
    ],
)
def test_draw_skeleton_rejects_bad_input(frame: np.ndarray, skeleton: str, match: str) -> None:
    ax = new_figure((2, 2), 40).subplots()
    with pytest.raises(ValueError, match=match):
        draw_skeleton(ax, frame, skeleton)


# ----------------------------------------------------------------------------------- beat figure
def _figure(tmp_path: Path, **kwargs: object) -> tuple[Path, BeatFigureSummary]:
    path = tmp_path / "beats.png"
    args: dict[str, object] = {
        "audio": _clicks([0.5, 1.0, 1.5], 2.0),
        "sample_rate": SR,
        "motion": _jerky_motion(60, [15, 45]),
        "fps": FPS,
        "skeleton": "smpl24",
        "figsize": (4.0, 3.0),
        "dpi": 50,
    }
    args.update(kwargs)
    return path, beat_matching_figure(path, **args)  # type: ignore[arg-type]


def test_beat_figure_is_a_png_of_the_requested_size(tmp_path: Path) -> None:
    path, summary = _figure(tmp_path, music_beats=[0.5, 1.0, 1.5])
    assert path.read_bytes()[:8] == PNG_MAGIC
    with Image.open(path) as im:
        assert im.format == "PNG" and im.size == (200, 150)
    assert summary.path == path
    assert [p.name for p in tmp_path.iterdir()] == ["beats.png"]  # no temporary left behind


def test_beat_figure_draws_given_beats_at_their_times(tmp_path: Path) -> None:
    _, s = _figure(tmp_path, music_beats=[1.5, 0.5, 1.0, 7.0], motion_beats=[0.25, 1.75], max_strip=2)
    assert s.duration == pytest.approx(2.0)
    assert s.music_beats == (0.5, 1.0, 1.5)  # sorted, 7 s is past the clip
    assert s.motion_beats == (0.25, 1.75)
    # two poses at evenly chosen musical beats (first and last): frames round(t * 30)
    assert s.strip_times == (0.5, 1.5)
    assert s.strip_frames == (15, 45)


def test_beat_figure_default_beats_are_the_metrics_beats(tmp_path: Path) -> None:
    audio, motion = _clicks([0.5, 1.0, 1.5], 2.0), _jerky_motion(60, [15, 45])
    _, s = _figure(tmp_path, audio=audio, motion=motion, strip_at="motion")
    # music: MoMu's onset_detect call; the click onsets are found within two onset frames (46 ms)
    np.testing.assert_allclose(s.music_beats, onset_times(audio, SR))
    np.testing.assert_allclose(s.music_beats, [0.5, 1.0, 1.5], atol=0.047)
    # motion: kinematic beats of the beat metric = the two jerk frames (Q = 1 there, 0 elsewhere)
    assert s.motion_beats == (0.5, 1.5)
    np.testing.assert_array_equal(kinematic_beat_frames(motion, FPS), [15, 45])
    assert s.strip_frames == (15, 45) and s.strip_at == "motion"


def test_beat_figure_velocity_curve_uses_harmogan_visual_beats(tmp_path: Path) -> None:
    from momu.features.kinematics import visual_beats

    motion = _jerky_motion(60, [15, 45])
    _, s = _figure(tmp_path, motion=motion, motion_curve="velocity", music_curve="onset", max_strip=0)
    frames, _ = visual_beats(motion, FPS)
    assert s.motion_beats == tuple(frames / FPS)
    assert s.strip_frames == ()


def test_beat_figure_without_beats_shows_evenly_spaced_frames(tmp_path: Path) -> None:
    still = _rest_motion("smpl24", 61)  # motionless: Q = 0, no kinematic beats
    _, s = _figure(tmp_path, motion=still, strip_at="motion", max_strip=3)
    assert s.motion_beats == () and s.strip_times == ()
    assert s.strip_frames == (0, 30, 60)


@pytest.mark.parametrize(
    ("kwargs", "exc", "match"),
    [
        ({"audio": np.zeros(0, dtype=np.float32)}, ValueError, "audio: the waveform is empty"),
        ({"audio": np.full(100, np.nan, dtype=np.float32)}, ValueError, "non-finite"),
        ({"sample_rate": 0}, ValueError, "sample rate must be positive"),
        ({"motion": np.zeros((2, 24, 3))}, ValueError, "at least 3 frames"),
        ({"motion": np.zeros((10, 24))}, ValueError, r"shape \(T, J, D\)"),
        ({"skeleton": "openpose14"}, ValueError, "14 joints but the motion has 24"),
        ({"skeleton": "nope"}, ValueError, "unknown skeleton 'nope'"),
        ({"fps": 0.0}, ValueError, "fps"),
        ({"music_beats": [[0.5]]}, ValueError, "music_beats: expected a 1-D array"),
        ({"motion_beats": [np.nan]}, ValueError, "motion_beats: beat times must be finite"),
        ({"music_beats": [-1.0]}, ValueError, "music_beats: beat times must be >= 0"),
        ({"strip_at": "video"}, ValueError, "strip_at"),
        ({"music_curve": "mel"}, ValueError, "music_curve"),
        ({"max_strip": -1}, ValueError, "max_strip"),
    ],
)
def test_beat_figure_rejects_bad_input(
    tmp_path: Path, kwargs: dict[str, object], exc: type, match: str
) -> None:
    with pytest.raises(exc, match=match):
        _figure(tmp_path, **kwargs)
    assert list(tmp_path.iterdir()) == []  # nothing written


@pytest.mark.parametrize(("suffix", "magic"), [(".pdf", b"%PDF"), (".svg", b"<?xml")])
def test_beat_figure_vector_formats(tmp_path: Path, suffix: str, magic: bytes) -> None:
    import torch

    path = tmp_path / f"beats{suffix}"
    beat_matching_figure(
        path, audio=torch.from_numpy(_clicks([0.5], 1.0)), sample_rate=SR,
        motion=torch.from_numpy(_jerky_motion(30, [10])), fps=FPS, skeleton="smpl24", max_strip=1,
        figsize=(3.0, 2.0), dpi=30,
    )  # fmt: skip
    assert path.read_bytes()[: len(magic)] == magic


def test_beat_figure_rejects_unknown_suffix(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match="unsupported figure format '.jpg'"):
        beat_matching_figure(
            tmp_path / "x.jpg", audio=_clicks([0.5], 1.0), sample_rate=SR, motion=_jerky_motion(30, [10]),
            fps=FPS, skeleton="smpl24",
        )  # fmt: skip


# ----------------------------------------------------------------------------------- animation
def test_gif_animation_has_one_frame_per_output_time(tmp_path: Path) -> None:
    path = tmp_path / "dance.gif"
    motion = _jerky_motion(12, [3, 8])  # 12 frames at 30 fps = 0.4 s
    out = skeleton_animation(path, motion, FPS, "smpl24", figsize=(2.0, 2.0), dpi=40)
    assert out == path and path.read_bytes()[:4] == b"GIF8"
    with Image.open(path) as im:
        assert im.size == (80, 80)
        frames = len(list(ImageSequence.Iterator(im)))
        assert frames == len(output_frames(12, FPS, 25.0)) == 10  # shown at 25 fps: 40 ms per frame
        assert im.info["duration"] == 40


def test_gif_animation_with_audio_adds_a_waveform_panel(tmp_path: Path) -> None:
    path = tmp_path / "dance.gif"
    motion = _rest_motion("openpose14", 4, dims=2)
    skeleton_animation(
        path, motion, 10.0, "openpose14", audio=_clicks([0.1], 0.4), sample_rate=SR, figsize=(2.0, 2.0),
        dpi=40,
    )  # fmt: skip
    with Image.open(path) as im:
        assert im.size == (80, 104) and im.info["duration"] == 100  # 10 fps: 100 ms per frame
        assert len(list(ImageSequence.Iterator(im))) == 4


def test_animation_adds_trajectory_back(tmp_path: Path) -> None:
    motion = _rest_motion("smpl24", 3)
    with pytest.raises(ValueError, match="trajectory"):
        skeleton_animation(tmp_path / "a.gif", motion, FPS, "smpl24", trajectory=np.zeros((2, 3)))
    walk = np.zeros((3, 3))
    walk[:, 0] = [0.0, 2.0, 4.0]  # the root moves 2 m a frame along +x (screen right in the default plane)
    moved = {}
    for name, trajectory in (("still", None), ("walk", walk)):
        path = skeleton_animation(
            tmp_path / f"{name}.gif", motion, FPS, "smpl24", trajectory=trajectory, out_fps=FPS,
            figsize=(2.0, 2.0), dpi=40,
        )  # fmt: skip
        with Image.open(path) as im:
            drawn = [np.asarray(f.convert("L")) < 200 for f in ImageSequence.Iterator(im)]
        appeared, vanished = drawn[-1] & ~drawn[0], drawn[0] & ~drawn[-1]  # the axes box is in both
        moved[name] = (int(appeared.sum() + vanished.sum()), appeared, vanished)
    assert moved["still"][0] < 20 < moved["walk"][0]  # a resting body stays put; a walking one moves
    _, appeared, vanished = moved["walk"]
    assert np.nonzero(appeared)[1].mean() - np.nonzero(vanished)[1].mean() > 20.0  # to the right (+x)


@pytest.mark.parametrize(
    ("name", "kwargs", "match"),
    [
        ("a.avi", {}, "unsupported animation format '.avi'"),
        ("a.gif", {"fps": -1.0}, "fps"),
        ("a.gif", {"out_fps": 100.0}, "out_fps"),
        ("a.gif", {"skeleton": "dwm21"}, "21 joints but the motion has 24"),
        ("a.gif", {"audio": np.zeros(10, dtype=np.float32)}, "sample_rate: required"),
        ("a.gif", {"audio": np.zeros(0, dtype=np.float32), "sample_rate": SR}, "empty"),
    ],
)
def test_animation_rejects_bad_input(
    tmp_path: Path, name: str, kwargs: dict[str, object], match: str
) -> None:
    args: dict[str, object] = {"motion": _rest_motion("smpl24", 3), "fps": FPS, "skeleton": "smpl24"}
    args.update(kwargs)
    with pytest.raises(ValueError, match=match):
        skeleton_animation(tmp_path / name, **args)  # type: ignore[arg-type]
    assert list(tmp_path.iterdir()) == []


def test_mp4_without_imageio_ffmpeg_says_what_to_install(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setitem(sys.modules, "imageio_ffmpeg", None)  # as if not installed: its import fails
    with pytest.raises(RuntimeError, match="pip install imageio-ffmpeg"):
        skeleton_animation(tmp_path / "a.mp4", _rest_motion("smpl24", 3), FPS, "smpl24")
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("audio_seconds", [1.0, 0.2])
def test_mp4_has_video_and_audio_streams(tmp_path: Path, audio_seconds: float) -> None:
    imageio_ffmpeg = pytest.importorskip("imageio_ffmpeg")
    path = tmp_path / "a.mp4"
    motion = _jerky_motion(10, [3])
    audio = _clicks([0.1], audio_seconds)
    # odd pixel sizes (99 x 128) are padded to even ones for yuv420p
    skeleton_animation(path, motion, 20.0, "smpl24", audio=audio, sample_rate=SR, figsize=(1.0, 1.0), dpi=99)
    probe = subprocess.run(
        [imageio_ffmpeg.get_ffmpeg_exe(), "-hide_banner", "-i", str(path)], capture_output=True, text=True
    )
    streams = [line for line in probe.stderr.splitlines() if "Stream #" in line]
    assert any("Video: h264" in s and "20 fps" in s for s in streams)
    assert any("Audio: aac" in s for s in streams)
    assert "Duration: 00:00:00.50" in probe.stderr  # sound cut or padded to the 0.5 s motion
    assert sorted(p.name for p in tmp_path.iterdir()) == ["a.mp4"]


# ----------------------------------------------------------------------------------- Clip helpers
def test_clip_helpers_use_the_clips_fields(tmp_path: Path) -> None:
    from momu.data.types import Clip
    from momu.render import clip_animation, clip_beat_figure

    motion = _jerky_motion(60, [15, 45]).astype(np.float32)
    clip = Clip(
        id="c0", motion=motion, fps=FPS,
        audio=_clicks([0.5, 1.0, 1.5], 2.0), sample_rate=SR, skeleton="smpl24",
    )  # fmt: skip
    s = clip_beat_figure(tmp_path / "c0.png", clip, music_beats=[0.5], figsize=(3.0, 2.0), dpi=30)
    assert s.music_beats == (0.5,) and s.motion_beats == (0.5, 1.5)
    with Image.open(tmp_path / "c0.png") as im:
        assert im.size == (90, 60)
    short = Clip(id="c1", motion=motion[:4], fps=FPS, skeleton="smpl24", trajectory=np.zeros((4, 3)))
    clip_animation(tmp_path / "c1.gif", short, figsize=(1.0, 1.0), dpi=20)
    with Image.open(tmp_path / "c1.gif") as im:
        assert im.size == (20, 20)  # no audio: no waveform panel
    with pytest.raises(ValueError, match="clip 'c1': has no audio"):
        clip_beat_figure(tmp_path / "c1.png", short)
    with pytest.raises(ValueError, match="clip 'm': has no motion"):
        clip_animation(tmp_path / "m.gif", Clip(id="m", motion=None, fps=FPS, skeleton="smpl24"))


def test_the_clock_is_pasted_back_pixel_for_pixel_between_its_changes() -> None:
    from momu.render.skeleton import _blit_frames, new_figure

    def frames(cache: bool) -> list[np.ndarray]:
        fig = new_figure((3.0, 3.0), 60)
        ax = fig.subplots()
        ax.set_xlim(0, 1)
        ax.set_ylim(0, 1)
        ax.set_title("a title", loc="left")
        clock = ax.set_title("", loc="right")
        line = ax.plot([], [])[0]

        def update(i: int) -> list:
            line.set_data([0.0, 1.0], [0.1 * i, 1.0 - 0.1 * i])
            clock.set_text(f"t = {i // 3:5.1f} s")  # changes every third frame
            return [line, clock]

        images = _blit_frames(fig, update, [line, clock], list(range(8)), clock if cache else None)
        return [im.copy() for im in images]

    for cached, drawn in zip(frames(True), frames(False), strict=True):
        np.testing.assert_array_equal(cached, drawn)
