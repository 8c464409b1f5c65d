"""Beat-matching figures: MoMu-Diffusion Figures 4/5 and 8–10, HarmoGAN's audio/visual beat alignment.

MoMu's qualitative figures show the music (waveform) with the extracted musical beats as **red dashes**
and, under it, frames of the dancer with red arrows from the beats to the frames at those moments
(Figure 4, 8–10: motion→music, frames at the musical beats of the generated music; Figure 5:
music→motion, frames of the synthesized motion at its kinematic beats). :func:`beat_matching_figure`
draws the same three rows for one clip:

1. **music**: the waveform (min/max envelope; ``music_curve="waveform"``) or librosa's onset strength
   (``music_curve="onset"``, normalised to [0, 1]), with the musical beats as red dashed lines. Default
   beats: :func:`momu.features.audio.onset_times`, the ``librosa.onset.onset_detect`` call of MoMu
   App. B.4 / LORIS that the beat metrics use.
2. **motion**: MoMu's kinematic amplitude ``Q`` (Eq. 1–2,
   :func:`momu.features.kinematics.motion_kinematic_amplitude`, ``Q[r]`` at time ``r / fps``;
   ``motion_curve="kinematic"``) with the kinematic beats as red dashed lines —
   by default :func:`momu.metrics.kinematic_beats.kinematic_beat_frames`, the peaks the
   music→motion beat scores count. ``motion_curve="velocity"`` plots HarmoGAN's joint velocity sum
   (Eq. 2, normalised to [0, 1], value ``i`` at frame ``i + 1``) with its visual beats (Eq. 3 local
   extrema, :func:`momu.features.kinematics.visual_beats`) instead. The musical beats are repeated
   here as light grey dotted lines so the alignment can be read off one panel.
3. **strip**: up to ``max_strip`` skeleton poses (:func:`momu.render.skeleton.draw_skeleton`, front-plane
   projection) at evenly chosen beats of ``strip_at`` (``"music"`` as Figure 4, ``"motion"`` as Figure 5),
   with red arrows from the beat times to the poses. All poses share one scale and keep their height
   above the clip's lowest point, so squats and jumps stay visible.

All times are in seconds from the start of the clip (audio sample 0 = motion frame 0).
"""

from __future__ import annotations

import logging
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from momu.features.audio import OnsetConfig, check_waveform
from momu.features.kinematics import check_motion
from momu.io import atomic_path
from momu.render.skeleton import draw_skeleton, new_figure, resolve_skeleton, screen_coordinates

if TYPE_CHECKING:  # pragma: no cover - typing only
    from matplotlib.axes import Axes

    from momu.data.types import Clip
    from momu.features.skeletons import Skeleton

__all__ = [
    "MUSIC_BEAT_COLOR",
    "BeatFigureSummary",
    "waveform_envelope",
    "beat_matching_figure",
    "clip_beat_figure",
]

logger = logging.getLogger(__name__)

MUSIC_BEAT_COLOR = "red"
"""Colour of the beat dashes (MoMu Figures 4/5: red dashes)."""

_FIGURE_SUFFIXES = (".png", ".pdf", ".svg")
_MUSIC_CURVES = ("waveform", "onset")
_MOTION_CURVES = ("kinematic", "velocity")
_STRIP_AT = ("music", "motion")

# Artist ids (Line2D.get_gid()) of the drawn beat lines, read back into the summary.
GID_MUSIC_BEAT = "music_beat"
GID_MOTION_BEAT = "motion_beat"
GID_MUSIC_BEAT_REF = "music_beat_ref"


@dataclass(frozen=True)
class BeatFigureSummary:
    """What :func:`beat_matching_figure` drew, read back from the figure's artists.

    Attributes:
        path: the written file.
        duration: the time axis spans ``[0, duration]`` seconds (the longer of audio and motion).
        music_beats: x positions (s) of the red dashed beat lines on the music panel, ascending.
        motion_beats: x positions (s) of the red dashed beat lines on the motion panel, ascending.
        strip_frames: motion frame indices of the poses in the strip, left to right.
        strip_times: the beat times (s) the strip's arrows start from (``strip_frames = round(t·fps)``);
            empty when the clip has no beat of ``strip_at`` and the strip shows evenly spaced frames.
        music_curve, motion_curve, strip_at: the options used.
    """

    path: Path
    duration: float
    music_beats: tuple[float, ...]
    motion_beats: tuple[float, ...]
    strip_frames: tuple[int, ...]
    strip_times: tuple[float, ...]
    music_curve: str
    motion_curve: str
    strip_at: str


def waveform_envelope(
    audio: Any, sample_rate: int | float, bins: int = 2000
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Min/max envelope of a waveform for plotting: ``(times_s, low, high)``, each ``(≤ bins,)``.

    The waveform is cut into ``min(bins, S)`` consecutive chunks of (nearly) equal length; chunk ``k``
    is placed at the time of its first sample and carries its minimum and maximum sample, so a
    ``fill_between`` of the envelope looks like the full waveform at a fraction of the points.
    """
    x = check_waveform(audio, sample_rate)
    if bins < 1:
        raise ValueError(f"bins: must be >= 1, got {bins}")
    n = min(int(bins), x.size)
    starts = (np.arange(n) * x.size) // n
    low = np.minimum.reduceat(x, starts)
    high = np.maximum.reduceat(x, starts)
    return starts / float(sample_rate), low, high


def _beat_array(beats: Any, name: str) -> np.ndarray:
    """Validate beat times in seconds: finite, non-negative, 1-D; returned sorted as float64."""
    b = np.asarray(beats, dtype=np.float64)
    if b.ndim != 1:
        raise ValueError(f"{name}: expected a 1-D array of beat times in seconds, got shape {b.shape}")
    if not np.all(np.isfinite(b)):
        raise ValueError(f"{name}: beat times must be finite (got NaN/inf)")
    if np.any(b < 0):
        raise ValueError(f"{name}: beat times must be >= 0 s, got {b[b < 0][:3].tolist()}")
    return np.sort(b)


def _in_range(beats: np.ndarray, duration: float, name: str) -> np.ndarray:
    keep = beats <= duration
    if not keep.all():
        dropped = int((~keep).sum())
        logger.debug("%s: %d beat(s) after the clip end (%.2f s) not drawn", name, dropped, duration)
    return beats[keep]


def _beat_lines(ax: Axes, beats: np.ndarray, gid: str, **style: Any) -> None:
    for t in beats:
        ax.axvline(float(t), gid=gid, **style)


def _drawn(ax: Axes, gid: str) -> tuple[float, ...]:
    return tuple(sorted(float(line.get_xdata()[0]) for line in ax.get_lines() if line.get_gid() == gid))  # type: ignore[arg-type,index]


def _choose(n: int, k: int) -> np.ndarray:
    """Up to ``k`` evenly spread indices into ``range(n)``, first and last included."""
    if n == 0 or k == 0:
        return np.zeros(0, dtype=np.int64)
    return np.unique(np.round(np.linspace(0, n - 1, min(n, k))).astype(np.int64))


def beat_matching_figure(
    path: str | Path,
    *,
    audio: Any,
    sample_rate: int,
    motion: Any,
    fps: float,
    skeleton: str | Skeleton,
    music_beats: Any = None,
    motion_beats: Any = None,
    title: str | None = "Beat matching",
    music_curve: str = "waveform",
    motion_curve: str = "kinematic",
    strip_at: str = "music",
    max_strip: int = 8,
    plane: tuple[int, int] = (0, 1),
    y_down: bool | None = None,
    onset_config: OnsetConfig | None = None,
    figsize: tuple[float, float] = (10.0, 6.5),
    dpi: int = 100,
) -> BeatFigureSummary:
    """Write a MoMu Figure 4/5-style beat-matching plot of one clip (see the module doc for the rows).

    Args:
        path: output image (``.png``, ``.pdf`` or ``.svg``), written atomically.
        audio: mono waveform ``(S,)`` at ``sample_rate`` Hz (the generated or the reference music).
        sample_rate: audio sample rate in Hz.
        motion: ``(T, J, 2|3)`` joint positions at ``fps`` frames/s, ``T ≥ 3`` (the generated or the
            reference dance; projection as :func:`momu.render.skeleton.screen_coordinates`).
        fps: motion frame rate.
        skeleton: the motion's skeleton name from :mod:`momu.features.skeletons` (or a ``Skeleton``).
        music_beats: musical beat times in seconds; ``None`` = onset detection on ``audio``
            (:func:`momu.features.audio.onset_times` with ``onset_config``).
        motion_beats: motion beat times in seconds; ``None`` = kinematic beats
            (:func:`momu.metrics.kinematic_beats.kinematic_beat_frames` ``/ fps``) or, with
            ``motion_curve="velocity"``, HarmoGAN's visual beats.
        title: figure title (``None`` for none).
        music_curve: ``"waveform"`` or ``"onset"`` (onset strength) for the music panel.
        motion_curve: ``"kinematic"`` (MoMu Eq. 2) or ``"velocity"`` (HarmoGAN Eq. 2) for the motion panel.
        strip_at: ``"music"`` (poses at musical beats, Figure 4) or ``"motion"`` (at motion beats, Figure 5).
        max_strip: most poses in the strip (0 = no strip row).
        plane, y_down: projection of the poses (:func:`momu.render.skeleton.screen_coordinates`).
        onset_config: onset detection settings for the default music beats and the onset curve.
        figsize, dpi: figure size in inches and resolution.

    Returns:
        A :class:`BeatFigureSummary` of what was drawn (beat line positions read back from the axes).

    Raises:
        ValueError: empty/non-finite audio, bad motion shape, joint-count mismatch, unknown skeleton,
            non-positive fps/sample rate, bad beat arrays, unknown option values or file suffix.
    """
    path = Path(path)
    if path.suffix.lower() not in _FIGURE_SUFFIXES:
        raise ValueError(f"path: unsupported figure format {path.suffix!r} (use one of {_FIGURE_SUFFIXES})")
    for value, choices, name in (
        (music_curve, _MUSIC_CURVES, "music_curve"),
        (motion_curve, _MOTION_CURVES, "motion_curve"),
        (strip_at, _STRIP_AT, "strip_at"),
    ):
        if value not in choices:
            raise ValueError(f"{name}: expected one of {choices}, got {value!r}")
    if int(max_strip) != max_strip or max_strip < 0:
        raise ValueError(f"max_strip: must be a non-negative integer, got {max_strip!r}")
    if not fps or not np.isfinite(fps) or fps <= 0:
        raise ValueError(f"fps: must be a positive frame rate, got {fps!r}")
    wave = check_waveform(audio, sample_rate)
    x = check_motion(
        motion.detach().cpu().numpy() if hasattr(motion, "detach") else motion, name="motion", min_frames=3
    )
    skel = resolve_skeleton(skeleton, x.shape[1])
    cfg = onset_config or OnsetConfig()
    num_frames = x.shape[0]
    duration = max(wave.size / float(sample_rate), num_frames / float(fps))

    # ---- beats (seconds)
    if music_beats is None:
        from momu.features.audio import onset_times

        m_beats = onset_times(wave, sample_rate, cfg)
    else:
        m_beats = _beat_array(music_beats, "music_beats")
    if motion_curve == "kinematic":
        from momu.features.kinematics import motion_kinematic_amplitude

        curve = motion_kinematic_amplitude(x)
        curve_t = np.arange(curve.size) / float(fps)  # Q[r] belongs to frame r
        curve_label = "kinematic amplitude Q\n(MoMu Eq. 2)"
    else:
        from momu.features.kinematics import velocity_sum

        j = velocity_sum(x, fps)
        curve = j / j.max() if j.max() > 0 else j
        curve_t = (np.arange(curve.size) + 1) / float(fps)  # j[i] is the paper's j_t at t = i + 1
        curve_label = "velocity sum\n(HarmoGAN Eq. 2)"
    if motion_beats is None:
        if motion_curve == "kinematic":
            from momu.metrics.kinematic_beats import kinematic_beat_frames

            v_beats = kinematic_beat_frames(x, fps) / float(fps)
        else:
            from momu.features.kinematics import visual_beats

            v_beats = visual_beats(x, fps)[0] / float(fps)
    else:
        v_beats = _beat_array(motion_beats, "motion_beats")
    m_beats = _in_range(m_beats, duration, "music_beats")
    v_beats = _in_range(v_beats, num_frames / float(fps), "motion_beats")

    # ---- figure
    rows = 3 if max_strip > 0 else 2
    fig = new_figure(figsize=figsize, dpi=dpi)
    grid = fig.add_gridspec(rows, 1, height_ratios=[1.0, 1.0, 1.5][:rows], hspace=0.45)
    ax_music = fig.add_subplot(grid[0])
    ax_motion = fig.add_subplot(grid[1], sharex=ax_music)
    beat_style = {"color": MUSIC_BEAT_COLOR, "linestyle": "--", "linewidth": 1.0}

    if music_curve == "waveform":
        t_env, low, high = waveform_envelope(wave, sample_rate)
        ax_music.fill_between(t_env, low, high, color="0.45", linewidth=0)
        ax_music.set_ylabel("waveform")
    else:
        from momu.features.audio import onset_envelope

        env = onset_envelope(wave, sample_rate, cfg).astype(np.float64)
        env = env / env.max() if env.max() > 0 else env
        ax_music.plot(np.arange(env.size) / cfg.frame_rate, env, color="0.3", linewidth=1.0)
        ax_music.set_ylabel("onset strength")
    _beat_lines(ax_music, m_beats, GID_MUSIC_BEAT, **beat_style)
    ax_music.set_title(f"music: {m_beats.size} beats (red dashes)", fontsize=9, loc="left")
    ax_music.set_xlim(0.0, duration)
    ax_music.tick_params(labelbottom=False)

    ax_motion.plot(curve_t, curve, color="0.2", linewidth=1.0)
    _beat_lines(ax_motion, m_beats, GID_MUSIC_BEAT_REF, color="0.6", linestyle=":", linewidth=0.8)
    _beat_lines(ax_motion, v_beats, GID_MOTION_BEAT, **beat_style)
    ax_motion.set_ylabel(curve_label, fontsize=8)
    ax_motion.set_ylim(-0.05, 1.05)
    ax_motion.set_xlabel("time (s)")
    kind = "kinematic" if motion_curve == "kinematic" else "visual"
    ax_motion.set_title(
        f"motion: {v_beats.size} {kind} beats (red dashes; music beats dotted grey)", fontsize=9, loc="left"
    )

    strip_frames: np.ndarray = np.zeros(0, dtype=np.int64)
    strip_times: np.ndarray = np.zeros(0)
    if max_strip > 0:
        source = m_beats if strip_at == "music" else v_beats
        source = source[source < num_frames / float(fps)]  # beats inside the motion
        strip_times = source[_choose(source.size, int(max_strip))]
        if strip_times.size:
            strip_frames = np.clip(np.round(strip_times * fps).astype(np.int64), 0, num_frames - 1)
        else:
            strip_frames = _choose(num_frames, int(max_strip))
        ax_strip = fig.add_subplot(grid[2])
        _draw_strip(fig, ax_strip, ax_motion, x, skel, strip_frames, strip_times, fps, plane, y_down)
    if title:
        fig.suptitle(title)

    summary = BeatFigureSummary(
        path=path,
        duration=float(duration),
        music_beats=_drawn(ax_music, GID_MUSIC_BEAT),
        motion_beats=_drawn(ax_motion, GID_MOTION_BEAT),
        strip_frames=tuple(int(f) for f in strip_frames),
        strip_times=tuple(float(t) for t in strip_times),
        music_curve=music_curve,
        motion_curve=motion_curve,
        strip_at=strip_at,
    )
    with atomic_path(path) as tmp:
        fig.savefig(tmp, format=path.suffix.lower().lstrip("."), dpi=dpi)
    logger.debug("wrote beat-matching figure %s", path)
    return summary


def clip_beat_figure(path: str | Path, clip: Clip, **kwargs: Any) -> BeatFigureSummary:
    """:func:`beat_matching_figure` of a :class:`~momu.data.types.Clip` (its audio, motion, fps, skeleton).

    ``title`` defaults to the clip id; other keyword arguments are passed on. Raises ``ValueError``
    naming the clip when it has no audio, no motion or no skeleton name.
    """
    if clip.audio is None or not clip.sample_rate:
        raise ValueError(f"clip {clip.id!r}: has no audio (or no sample rate) to plot")
    if clip.motion is None:
        raise ValueError(f"clip {clip.id!r}: has no motion to plot")
    if not clip.skeleton:
        raise ValueError(f"clip {clip.id!r}: has no skeleton name")
    kwargs.setdefault("title", clip.id)
    return beat_matching_figure(
        path,
        audio=clip.audio,
        sample_rate=int(clip.sample_rate),
        motion=clip.motion,
        fps=clip.fps,
        skeleton=clip.skeleton,
        **kwargs,
    )


def _draw_strip(
    fig: Any,
    ax: Axes,
    ax_from: Axes,
    motion: np.ndarray,
    skel: Skeleton,
    frames: np.ndarray,
    times: np.ndarray,
    fps: float,
    plane: tuple[int, int],
    y_down: bool | None,
) -> None:
    """Poses at ``frames`` side by side on ``ax``; red arrows from ``times`` on ``ax_from`` when given."""
    from matplotlib.patches import ConnectionPatch

    xy = screen_coordinates(motion, plane=plane, y_down=y_down)
    centre_x = xy[..., 0].mean(axis=1)  # (T,) each pose centred on its own mean x
    width = float((xy[..., 0].max(1) - xy[..., 0].min(1)).max())
    y_min, y_max = float(xy[..., 1].min()), float(xy[..., 1].max())
    size = max(width, y_max - y_min, 1e-9)
    scale = 1.0 / size  # the tallest/widest extent of the clip becomes 1
    slot = max(1.25 * width * scale, 0.6)
    for i, f in enumerate(frames):
        offset = (i * slot - scale * centre_x[f], -scale * y_min)
        draw_skeleton(
            ax,
            motion[f],
            skel,
            plane=plane,
            y_down=y_down,
            offset=offset,
            scale=scale,
            linewidth=1.5,
            joint_size=4,
        )
        ax.text(i * slot, -0.08, f"{f / fps:.2f} s", ha="center", va="top", fontsize=7)
        if times.size:
            arrow = ConnectionPatch(
                xyA=(float(times[i]), 0.0),
                coordsA=ax_from.get_xaxis_transform(),
                xyB=(i * slot, (y_max - y_min) * scale + 0.05),
                coordsB=ax.transData,
                arrowstyle="->",
                color=MUSIC_BEAT_COLOR,
                linewidth=0.8,
                alpha=0.7,
            )
            fig.add_artist(arrow)
    n = max(len(frames), 1)
    ax.set_xlim(-0.5 * slot, (n - 0.5) * slot)
    ax.set_ylim(-0.2, (y_max - y_min) * scale + 0.1)
    ax.set_aspect("equal", adjustable="box")
    ax.axis("off")
    label = "poses at the beats" if times.size else "no beats: evenly spaced frames"
    ax.set_title(label, fontsize=9, loc="left")
