"""Skeleton drawing and animation (matplotlib, Agg backend; imported lazily).

Projection convention (the one :func:`momu.features.kinematics.directogram` uses): 3D joint positions
(metres, Y up, the body facing +Z, its left side towards +X) are drawn on the **front plane**,
``plane=(0, 1)`` keeps x (right) and y (up) — the view of a camera in front of the dancer looking
along −Z, so the dancer's left side appears on the viewer's right, as in a video. 2D motion is
image-plane keypoints (OpenPose / COCO pixels: origin top-left, v grows **down**), so by default its
second axis is flipped to draw the figure upright (``y_down=None`` means "``True`` for 2D motion, ``False``
for 3D").

Bones come from :func:`momu.features.skeletons.get_skeleton` (``Skeleton.bones``, parent → child);
left-side bones (child joint named ``l_*``) are drawn in blue, right-side bones (``r_*``) in red and
midline bones in black, the usual convention of pose visualisers.

:func:`skeleton_animation` draws the static part of the figure once and blits only the moving
artists for each frame, then writes an animated GIF with Pillow (which ships with matplotlib; no
ffmpeg). A GIF has no sound track: with ``audio`` the animation gets a waveform panel with a moving
play head. An ``.mp4`` (H.264 + AAC, the audio as its sound track with its channels) needs an ffmpeg
binary, taken from the ``imageio-ffmpeg`` package, run within time limits by :mod:`momu.render.ffmpeg`.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from momu.features.kinematics import check_motion, project_plane
from momu.features.skeletons import Skeleton, get_skeleton
from momu.io import atomic_path
from momu.render.ffmpeg import ffmpeg_exe, write_mp4

if TYPE_CHECKING:  # pragma: no cover - typing only
    from matplotlib.artist import Artist
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure
    from matplotlib.lines import Line2D
    from matplotlib.text import Text

    from momu.data.types import Clip

__all__ = [
    "LEFT_COLOR",
    "RIGHT_COLOR",
    "CENTRE_COLOR",
    "resolve_skeleton",
    "screen_coordinates",
    "bone_colors",
    "draw_skeleton",
    "skeleton_animation",
    "clip_animation",
]

logger = logging.getLogger(__name__)

LEFT_COLOR = "tab:blue"
"""Colour of bones ending at a left-side joint (``l_*``)."""
RIGHT_COLOR = "tab:red"
"""Colour of bones ending at a right-side joint (``r_*``)."""
CENTRE_COLOR = "black"
"""Colour of midline bones."""

_ANIMATION_SUFFIXES = (".gif", ".mp4")


def resolve_skeleton(skeleton: str | Skeleton, num_joints: int | None = None) -> Skeleton:
    """The :class:`Skeleton` named ``skeleton`` (or ``skeleton`` itself), checked against ``num_joints``.

    Raises:
        ValueError: unknown skeleton name (the message lists the valid names), or the motion has a
            different number of joints than the skeleton.
    """
    if isinstance(skeleton, Skeleton):
        skel = skeleton
    elif isinstance(skeleton, str):
        try:
            skel = get_skeleton(skeleton)
        except KeyError as exc:
            raise ValueError(f"skeleton: {exc.args[0]}") from None
    else:
        raise TypeError(f"skeleton: expected a skeleton name or a Skeleton, got {type(skeleton).__name__}")
    if num_joints is not None and num_joints != skel.num_joints:
        raise ValueError(
            f"skeleton {skel.name!r} has {skel.num_joints} joints but the motion has {num_joints} "
            "(pass the skeleton the motion was recorded with)"
        )
    return skel


def screen_coordinates(
    motion: Any,
    *,
    plane: tuple[int, int] = (0, 1),
    y_down: bool | None = None,
    name: str = "motion",
) -> np.ndarray:
    """``(T, J, 2)`` drawing coordinates (x right, y up) of ``(T, J, 2|3)`` joint positions.

    Args:
        motion: joint positions, metres (3D, Y up) or pixels (2D, v down); a single ``(J, D)`` frame is
            accepted and returned as ``(1, J, 2)``.
        plane: the two coordinate axes drawn (default x–y, the front plane of the features).
        y_down: whether the second drawn axis grows downwards (image pixels) and must be flipped;
            ``None`` = ``True`` for 2D motion, ``False`` for 3D.
        name: argument name used in error messages.

    Raises:
        ValueError: wrong shape, NaN/inf values, or a bad ``plane``.
    """
    x = np.asarray(motion.detach().cpu().numpy() if hasattr(motion, "detach") else motion)
    if x.ndim == 2:
        x = x[None]
    x = check_motion(x, name=name)
    flip = (x.shape[-1] == 2) if y_down is None else bool(y_down)
    xy = project_plane(x, plane).copy()
    if flip:
        xy[..., 1] = -xy[..., 1]
    return xy


def bone_colors(skeleton: Skeleton) -> list[str]:
    """Bone colours, ``bones`` order: :data:`LEFT_COLOR`, :data:`RIGHT_COLOR` or :data:`CENTRE_COLOR`."""
    colors = []
    for _, child in skeleton.bones:
        joint = skeleton.joint_names[child]
        colors.append(
            LEFT_COLOR if joint.startswith("l_") else RIGHT_COLOR if joint.startswith("r_") else CENTRE_COLOR
        )
    return colors


def draw_skeleton(
    ax: Axes,
    frame: Any,
    skeleton: str | Skeleton,
    *,
    plane: tuple[int, int] = (0, 1),
    y_down: bool | None = None,
    offset: Sequence[float] = (0.0, 0.0),
    scale: float = 1.0,
    color: str | None = None,
    linewidth: float = 2.0,
    joint_size: float = 8.0,
    alpha: float = 1.0,
) -> list[Line2D]:
    """Draw one pose on ``ax``: one line per bone of ``skeleton`` plus the joints as dots.

    Args:
        ax: a matplotlib ``Axes``.
        frame: ``(J, 2|3)`` joint positions (see :func:`screen_coordinates` for the projection).
        skeleton: a skeleton name from :mod:`momu.features.skeletons` or a :class:`Skeleton`.
        plane, y_down: projection options of :func:`screen_coordinates`.
        offset, scale: the drawn points are ``scale * p + offset`` (to lay several poses side by side).
        color: one colour for every bone; ``None`` = left blue / right red / midline black.
        linewidth, joint_size, alpha: line width (points), joint marker size (points²), opacity.

    Returns:
        The bone ``Line2D`` artists, in ``skeleton.bones`` order (the joint scatter is not included);
        ``line.get_xydata()`` are the drawn end points.

    Raises:
        ValueError: ``frame`` is not ``(J, 2|3)`` finite values, or ``J`` differs from the skeleton's.
    """
    pts = np.asarray(frame.detach().cpu().numpy() if hasattr(frame, "detach") else frame)
    if pts.ndim != 2:
        raise ValueError(f"frame: expected one pose of shape (J, 2|3), got shape {pts.shape}")
    skel = resolve_skeleton(skeleton, pts.shape[0])
    if not np.isfinite(scale) or scale <= 0:
        raise ValueError(f"scale: must be a positive finite number, got {scale}")
    off = np.asarray(offset, dtype=np.float64)
    if off.shape != (2,):
        raise ValueError(f"offset: expected (x, y), got {offset!r}")
    xy = screen_coordinates(pts, plane=plane, y_down=y_down, name="frame")[0] * scale + off
    colors = [color] * len(skel.bones) if color is not None else bone_colors(skel)
    lines: list[Line2D] = []
    for (parent, child), c in zip(skel.bones, colors, strict=True):
        (line,) = ax.plot(
            xy[[parent, child], 0],
            xy[[parent, child], 1],
            color=c,
            linewidth=linewidth,
            alpha=alpha,
            solid_capstyle="round",
        )
        lines.append(line)
    if joint_size > 0:
        ax.scatter(xy[:, 0], xy[:, 1], s=joint_size, color=color or "0.2", alpha=alpha, zorder=3)
    return lines


def new_figure(figsize: tuple[float, float], dpi: int) -> Figure:
    """A ``Figure`` on its own Agg canvas (no pyplot: no global figure registry, no backend change)."""
    if dpi <= 0 or min(figsize) <= 0:
        raise ValueError(f"figsize/dpi: must be positive, got figsize={figsize}, dpi={dpi}")
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=figsize, dpi=dpi)
    FigureCanvasAgg(fig)
    return fig


def _bounds(xy: np.ndarray, margin: float = 0.08) -> tuple[float, float, float, float]:
    """Square limits ``(x0, x1, y0, y1)`` enclosing every point of ``(T, J, 2)``, with a relative margin."""
    lo, hi = xy.reshape(-1, 2).min(0), xy.reshape(-1, 2).max(0)
    centre = (lo + hi) / 2.0
    half = float(max(hi[0] - lo[0], hi[1] - lo[1], 1e-6)) * (0.5 + margin)
    return centre[0] - half, centre[0] + half, centre[1] - half, centre[1] + half


def output_frames(num_frames: int, fps: float, out_fps: float) -> list[int]:
    """Motion frames shown at ``out_fps``: ``round(k · fps / out_fps)`` for ``k = 0, 1, ...`` below ``T``."""
    step = float(fps) / float(out_fps)
    count = int(np.floor((num_frames - 1) / step + 1e-9)) + 1
    return [int(i) for i in np.minimum(np.round(np.arange(count) * step), num_frames - 1)]


def _blit_frames(
    fig: Figure,
    update: Callable[[int], list[Artist]],
    animated: list[Artist],
    frames: list[int],
    clock: Text | None = None,
) -> Iterator[np.ndarray]:
    """``(H, W, 4)`` uint8 RGBA images of ``fig`` after ``update(i)`` for each ``i`` in ``frames``.

    The static part of the figure (axes, ticks, waveform) is drawn once and restored for every frame;
    only ``animated`` artists are redrawn (matplotlib blitting: ~10x faster than a full redraw). The
    ``clock`` text, if given among them, is drawn only when its text changes and its pixels pasted back
    otherwise (text is the costliest artist: drawing it every frame took 60 % of a 3-minute mp4). Each
    image is a view of the canvas, valid until the next one is requested (no copy per frame).
    """
    for artist in animated:
        artist.set_animated(True)
    canvas: Any = fig.canvas
    canvas.draw()
    background = canvas.copy_from_bbox(fig.bbox)
    shown, pixels = None, None
    for i in frames:
        canvas.restore_region(background)
        for artist in update(i):
            if artist is not clock:
                fig.draw_artist(artist)
            elif clock.get_text() == shown:
                canvas.restore_region(pixels)
            else:
                fig.draw_artist(clock)
                shown = clock.get_text()
                box = clock.get_window_extent(canvas.get_renderer()).padded(2.0)
                pixels = canvas.copy_from_bbox(box)
        yield np.asarray(canvas.buffer_rgba())


def _reported(images: Iterator[np.ndarray], progress: Callable[[int], Any]) -> Iterator[np.ndarray]:
    """``images``, calling ``progress(1)`` once each has been consumed (written)."""
    for image in images:
        yield image
        progress(1)


def _write_gif(path: Path, images: Iterator[np.ndarray], out_fps: float) -> int:
    """Write RGBA frames (alpha ignored) as a looping GIF at ``out_fps``; returns the number of frames."""
    from PIL import Image

    # One adaptive palette per frame (what Pillow does for RGB frames), converted as we go to keep
    # one byte per pixel in memory.
    pal = [
        Image.fromarray(np.ascontiguousarray(im[..., :3])).quantize(
            colors=255, method=Image.Quantize.FASTOCTREE
        )
        for im in images
    ]
    if not pal:
        raise ValueError("motion: no frames to animate")
    delay_ms = int(round(1000.0 / out_fps))
    pal[0].save(path, format="GIF", save_all=True, append_images=pal[1:], duration=delay_ms, loop=0)
    return len(pal)


def _audio_channels(audio: Any, sample_rate: int) -> tuple[np.ndarray, np.ndarray]:
    """``(mono (S,), channels (S, C))`` float32 of a mono ``(S,)`` or multi-channel ``(S, C)`` waveform."""
    from momu.features.audio import check_waveform

    x = np.asarray(audio.detach().cpu().numpy() if hasattr(audio, "detach") else audio)
    if x.ndim == 2 and 1 < x.shape[1] <= 8 and x.shape[0] > x.shape[1]:
        mono = check_waveform(x.mean(axis=1, dtype=np.float32), sample_rate)  # NaN in a channel shows here
        return mono, np.asarray(x, dtype=np.float32)
    mono = check_waveform(x, sample_rate)
    return mono, mono[:, None]


def skeleton_animation(
    path: str | Path,
    motion: Any,
    fps: float,
    skeleton: str | Skeleton,
    audio: Any = None,
    sample_rate: int | None = None,
    *,
    plane: tuple[int, int] = (0, 1),
    y_down: bool | None = None,
    trajectory: Any = None,
    out_fps: float | None = None,
    title: str | None = None,
    figsize: tuple[float, float] = (4.0, 4.0),
    dpi: int = 80,
    progress: Callable[[int], Any] | None = None,
) -> Path:
    """Write an animation of ``motion`` to ``path`` (``.gif``; ``.mp4`` with ``imageio-ffmpeg``).

    Args:
        path: output file; the suffix chooses the format. Written atomically.
        motion: ``(T, J, 2|3)`` joint positions at ``fps`` (projection: :func:`screen_coordinates`).
        fps: motion frame rate (frames per second, > 0); the animation plays in real time.
        skeleton: the motion's skeleton name (or :class:`Skeleton`).
        audio: optional waveform at ``sample_rate`` Hz: mono ``(S,)`` or ``(S, C)`` channels (``C`` <= 8,
            fewer than ``S``). A GIF shows it as a waveform panel with a play head (GIFs carry no
            sound); an MP4 also gets it as its AAC sound track, with its channels (stereo stays stereo;
            more than two are mixed down to stereo) and samples beyond full scale clipped to ±1.
        sample_rate: audio sample rate in Hz (required with ``audio``).
        plane, y_down: projection options of :func:`screen_coordinates`.
        trajectory: optional ``(T, 3)`` global root trajectory (``Clip.trajectory`` of root-centred
            clips) added back to every joint before drawing (3D motion only).
        out_fps: frames per second of the written animation; motion frames are picked at the nearest
            times ``k / out_fps`` so the animation plays in real time at any ``fps``.
            ``None`` = ``min(fps, 25)`` for a GIF (GIF frame delays are whole centiseconds and browsers
            slow delays under 20 ms down to 100 ms: use 50, 25, 20, 10 ... for exact timing) and ``fps``
            for an MP4.
        title, figsize, dpi: figure title, size in inches and resolution.
        progress: called with 1 after each frame is written (a progress bar's ``update``).

    Returns:
        ``Path(path)``.

    Raises:
        ValueError: unsupported suffix, bad motion/audio/fps/out_fps, unknown skeleton, joint-count mismatch.
        RuntimeError: ``.mp4`` without ``imageio-ffmpeg`` installed (the message says what to install).
        momu.render.ffmpeg.FfmpegError: ffmpeg failed or ran past its time limits
            (:mod:`momu.render.ffmpeg`; nothing is left at ``path``).
    """
    path = Path(path)
    suffix = path.suffix.lower()
    if suffix not in _ANIMATION_SUFFIXES:
        raise ValueError(
            f"path: unsupported animation format {path.suffix!r} (use one of {_ANIMATION_SUFFIXES})"
        )
    if not fps or not np.isfinite(fps) or fps <= 0:
        raise ValueError(f"fps: must be a positive frame rate, got {fps!r}")
    if out_fps is None:
        out_fps = min(float(fps), 25.0) if suffix == ".gif" else float(fps)
    if not np.isfinite(out_fps) or out_fps <= 0 or out_fps > fps:
        raise ValueError(f"out_fps: must be in (0, fps={fps}], got {out_fps!r}")
    if suffix == ".mp4":
        ffmpeg_exe()  # fail before any drawing
    x = check_motion(np.asarray(motion), name="motion")
    skel = resolve_skeleton(skeleton, x.shape[1])
    if trajectory is not None:
        traj = np.asarray(trajectory, dtype=np.float64)
        if x.shape[-1] != 3 or traj.shape != (x.shape[0], 3) or not np.all(np.isfinite(traj)):
            raise ValueError(
                f"trajectory: expected finite (T, 3) = ({x.shape[0]}, 3) for 3D motion, got {traj.shape} "
                f"with motion {x.shape}"
            )
        x = x + traj[:, None, :]
    wave, sound = None, None
    if audio is not None:
        if sample_rate is None:
            raise ValueError("sample_rate: required when audio is given")
        wave, sound = _audio_channels(audio, sample_rate)
    xy = screen_coordinates(x, plane=plane, y_down=y_down)
    frames = output_frames(xy.shape[0], fps, out_fps)
    play_fps = float(out_fps)

    fig = new_figure(figsize=(figsize[0], figsize[1] * (1.3 if wave is not None else 1.0)), dpi=dpi)
    if wave is not None:
        ax, ax_audio = fig.subplots(2, 1, gridspec_kw={"height_ratios": [4, 1]})
    else:
        ax, ax_audio = fig.subplots(), None
    x0, x1, y0, y1 = _bounds(xy)
    colors = bone_colors(skel)
    from matplotlib.collections import LineCollection

    bones = np.asarray(skel.bones, dtype=np.int64).reshape(-1, 2)  # (B, 2) parent, child
    lines = LineCollection([], colors=colors, linewidths=2.0, capstyle="round")  # one artist for all bones
    ax.add_collection(lines)
    joints = ax.plot([], [], "o", color="0.2", markersize=2.5)[0]
    ax.set_xlim(x0, x1)
    ax.set_ylim(y0, y1)
    ax.set_aspect("equal", adjustable="box")
    ax.set_xticks([])
    ax.set_yticks([])
    # the title is drawn once with the background; only the clock is redrawn each frame (text is the
    # costliest artist to draw: half the glyphs, a third less drawing time per frame)
    ax.set_title(title or "", loc="left")
    clock = ax.set_title("", loc="right")
    head = None
    if ax_audio is not None and wave is not None and sample_rate is not None:
        from momu.render.beat_plot import waveform_envelope

        t_env, lo, hi = waveform_envelope(wave, sample_rate)
        ax_audio.fill_between(t_env, lo, hi, color="0.5", linewidth=0)
        ax_audio.set_xlim(0.0, max(len(wave) / sample_rate, xy.shape[0] / fps))
        ax_audio.set_yticks([])
        ax_audio.set_xlabel("time (s)")
        head = ax_audio.axvline(0.0, color="tab:red", linewidth=1.5)

    # an mp4's clock shows tenths, so it is drawn 10 times a second (_blit_frames); a GIF's shows
    # hundredths, so that no two frames are identical (Pillow would merge them into one GIF frame)
    decimals = 2 if suffix == ".gif" else 1

    def update(i: int) -> list[Artist]:
        pose = xy[i]
        lines.set_segments(list(pose[bones]))  # (B, 2 ends, 2 coordinates)
        joints.set_data(pose[:, 0], pose[:, 1])
        clock.set_text(f"t = {i / fps:5.{decimals}f} s")
        artists: list[Artist] = [lines, joints, clock]
        if head is not None:
            head.set_xdata([i / fps, i / fps])
            artists.append(head)
        return artists

    animated: list[Artist] = [lines, joints, clock] + ([head] if head is not None else [])
    images = _blit_frames(fig, update, animated, frames, clock)
    if progress is not None:
        images = _reported(images, progress)
    with atomic_path(path) as tmp:
        if suffix == ".gif":
            _write_gif(tmp, images, play_fps)
        else:
            write_mp4(tmp, images, play_fps, sound, sample_rate, len(frames))
    logger.debug("wrote %d-frame animation %s (%.2f fps)", len(frames), path, play_fps)
    return path


def clip_animation(path: str | Path, clip: Clip, *, with_audio: bool = True, **kwargs: Any) -> Path:
    """:func:`skeleton_animation` of a :class:`~momu.data.types.Clip`.

    Uses the clip's motion, fps and skeleton, its ``trajectory`` (root-centred clips are drawn moving
    through space) and, with ``with_audio``, its audio. ``title`` defaults to the clip id; other keyword
    arguments are passed on. Raises ``ValueError`` naming the clip when it has no motion or skeleton.
    """
    if clip.motion is None:
        raise ValueError(f"clip {clip.id!r}: has no motion to animate")
    if not clip.skeleton:
        raise ValueError(f"clip {clip.id!r}: has no skeleton name")
    kwargs.setdefault("title", clip.id)
    kwargs.setdefault("trajectory", clip.trajectory)
    audio = clip.audio if with_audio and clip.sample_rate else None
    return skeleton_animation(
        path,
        clip.motion,
        clip.fps,
        clip.skeleton,
        audio=audio,
        sample_rate=clip.sample_rate if audio is not None else None,
        **kwargs,
    )
