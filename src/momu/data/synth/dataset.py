"""``synth_dance``: the built-in procedural dataset of paired music and dance (issue 3 §1).

Clip ``i`` of a configuration is a pure function of ``(cfg, i)``: its generator is seeded by
``SeedSequence([cfg.seed, i])``, its style is ``cfg.styles[i % len(cfg.styles)]`` and its split
is fixed by ``i`` (see :func:`split_of`), so clip ``i`` is the same whatever ``num_clips`` is.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from momu.data.synth.captions import caption, move_records
from momu.data.synth.motion import (
    CameraConfig,
    beat_phase,
    choose_keys,
    ease_keys,
    pose,
    project,
    segment_rotations,
    smooth_noise,
)
from momu.data.synth.music import beat_grid, render_music
from momu.data.synth.styles import STYLE_NAMES, get_style
from momu.data.types import Clip
from momu.features.skeletons import SKELETON_NAMES, get_skeleton

__all__ = [
    "CameraConfig",
    "SynthConfig",
    "SynthDance",
    "generate_clip",
    "split_of",
    "SPLITS",
    "DEFAULT_STYLES",
]

log = logging.getLogger(__name__)

SPLITS: tuple[str, ...] = ("train", "val", "test")
# Split of block b = i // len(styles) is _SPLIT_CYCLE[b % 10]: 80/10/10 per ten blocks, every style in
# every split, and the first three blocks already cover all splits.
_SPLIT_CYCLE: tuple[str, ...] = ("train", "val", "test") + ("train",) * 7
DEFAULT_STYLES: tuple[str, ...] = ("ballet", "hiphop", "zumba")


@dataclass
class SynthConfig:
    """Configuration of ``synth_dance``.

    Attributes:
        num_clips: number of clips (all splits together).
        min_seconds, max_seconds: clip duration range in seconds; each clip draws uniformly
            (MoMu uses 10-30 s clips, LORIS 25 / 50 s).
        fps: motion frame rate; ``None`` = the skeleton's usual rate (60 for smpl24/openpose14,
            25 for dwm21).
        sample_rate: audio sample rate in Hz (mono; MoMu and MoFusion use 16 kHz).
        skeleton: joint layout (:mod:`momu.features.skeletons`): ``smpl24`` (3D, metres),
            ``openpose14`` (2D pixels), ``dwm21`` (3D, metres), or any other registered layout.
        styles: styles to cycle through (``ballet``, ``hiphop``, ``zumba``, ``techno``).
        seed: dataset seed.
        phase_jitter: standard deviation (seconds) of each motion beat's offset from its music beat.
        attack, release: shape of every move's speed profile ``u^attack (1 - u)^release`` over its
            beat (``u`` from 0 to 1; 1, 1 = smoothstep). A small ``attack`` starts moves sharply on
            the beat (more MoMu Eq. 2 kinematic beats detected) but moves Bailando-style smoothed
            velocity minima away from it (lower BAS); the defaults balance the two.
        motion_noise: standard deviation (radians) of smooth noise added to every joint angle.
        noise_smoothing: time constant (seconds) of that noise's Gaussian smoothing.
        amplitude_range: range of the per-move amplitude factor applied to key poses.
        audio_noise: standard deviation of white noise added to the music (peak 0.85).
        break_prob: probability that a bar (from the third on) opens a *break*: its downbeat
            sounds, then only the held chord until the break ends, while the dancer hits a pose on
            that downbeat and flows slowly, in one move, to the next section (0 = no breaks).
        max_break_bars: a break lasts 1 to this many bars.
        trajectory_radius: the dancer's steps stay within this many metres of the origin
            (0 = dance in place).
        root_centred: store motion relative to the root joint and the root's path in
            ``Clip.trajectory`` (3D skeletons only; DwM's convention).
        camera: virtual camera for 2D skeletons.
        bpm_range: ``[low, high]`` beats per minute every clip draws its tempo from, whatever its
            style (``None``: each style's own range, :attr:`Style.bpm`). A tempo augmentation: with
            the ballroom styles' disjoint ranges the tempo tells the style, and a model can learn a
            style's typical period instead of following the beats (issue 32).
    """

    num_clips: int = 64
    min_seconds: float = 10.0
    max_seconds: float = 10.0
    fps: float | None = None
    sample_rate: int = 16000
    skeleton: str = "smpl24"
    styles: list[str] = field(default_factory=lambda: list(DEFAULT_STYLES))
    seed: int = 0
    phase_jitter: float = 0.02
    attack: float = 1.0
    release: float = 1.0
    motion_noise: float = 0.01
    noise_smoothing: float = 0.05
    amplitude_range: list[float] = field(default_factory=lambda: [0.75, 1.25])
    audio_noise: float = 0.005
    break_prob: float = 0.25
    max_break_bars: int = 2
    trajectory_radius: float = 1.0
    root_centred: bool = False
    camera: CameraConfig = field(default_factory=CameraConfig)
    bpm_range: list[float] | None = None


def validate_config(cfg: SynthConfig) -> None:
    """Raise ``ValueError`` naming the first invalid field of ``cfg``."""
    if cfg.num_clips < 0:
        raise ValueError(f"num_clips must be >= 0, got {cfg.num_clips}")
    if not 0 < cfg.min_seconds <= cfg.max_seconds:
        raise ValueError(f"need 0 < min_seconds <= max_seconds, got {cfg.min_seconds} and {cfg.max_seconds}")
    if cfg.fps is not None and not cfg.fps > 0:
        raise ValueError(f"fps must be positive, got {cfg.fps}")
    if cfg.sample_rate < 4000:
        raise ValueError(f"sample_rate must be at least 4000 Hz, got {cfg.sample_rate}")
    if cfg.skeleton not in SKELETON_NAMES:
        raise ValueError(f"unknown skeleton {cfg.skeleton!r}; valid: {', '.join(SKELETON_NAMES)}")
    if not cfg.styles:
        raise ValueError("styles must name at least one style")
    bad = [s for s in cfg.styles if s not in STYLE_NAMES]
    if bad:
        raise ValueError(f"unknown styles {bad}; valid: {', '.join(STYLE_NAMES)}")
    if not (cfg.attack > 0 and cfg.release > 0):
        raise ValueError(f"attack and release must be > 0, got {cfg.attack} and {cfg.release}")
    if not 0.0 <= cfg.break_prob <= 1.0:
        raise ValueError(f"break_prob must be in [0, 1], got {cfg.break_prob}")
    if cfg.max_break_bars < 1:
        raise ValueError(f"max_break_bars must be >= 1, got {cfg.max_break_bars}")
    for name in ("phase_jitter", "motion_noise", "noise_smoothing", "audio_noise", "trajectory_radius"):
        if getattr(cfg, name) < 0:
            raise ValueError(f"{name} must be >= 0, got {getattr(cfg, name)}")
    lo, hi = (list(cfg.amplitude_range) + [None, None])[:2]
    if len(cfg.amplitude_range) != 2 or lo is None or hi is None or not 0 <= lo <= hi:
        raise ValueError(
            f"amplitude_range must be [low, high] with 0 <= low <= high, got {cfg.amplitude_range}"
        )
    if cfg.bpm_range is not None:
        bpm = [float(x) for x in cfg.bpm_range]
        if len(bpm) != 2 or not 0 < bpm[0] <= bpm[1]:
            raise ValueError(f"bpm_range must be [low, high] with 0 < low <= high, got {cfg.bpm_range}")
    if cfg.root_centred and get_skeleton(cfg.skeleton).dims == 2:
        raise ValueError("root_centred applies to 3D skeletons only")


def resolved_fps(cfg: SynthConfig) -> float:
    """The motion frame rate: ``cfg.fps`` or the skeleton's usual rate."""
    return float(cfg.fps) if cfg.fps is not None else get_skeleton(cfg.skeleton).fps


def split_of(index: int, num_styles: int) -> str:
    """Split (``train``/``val``/``test``) of clip ``index`` when cycling through ``num_styles`` styles."""
    return _SPLIT_CYCLE[(index // max(num_styles, 1)) % len(_SPLIT_CYCLE)]


def plan_breaks(
    rng: np.random.Generator, num_bars: int, prob: float, max_bars: int
) -> tuple[np.ndarray, np.ndarray]:
    """Which bars are breaks: ``(is_break, opens)``, both ``(num_bars,)`` bool.

    From the third bar on, a bar opens a break with probability ``prob``; the break lasts 1 to
    ``max_bars`` bars (uniform) and is followed by at least one normal bar. ``opens`` marks each
    break's first bar (the one whose downbeat still sounds).
    """
    is_break = np.zeros(num_bars, bool)
    opens = np.zeros(num_bars, bool)
    draws = rng.random(num_bars)
    spans = rng.integers(1, max(1, max_bars) + 1, num_bars)
    b = 2
    while b < num_bars:
        if draws[b] < prob:
            span = int(min(spans[b], num_bars - b))
            opens[b] = True
            is_break[b : b + span] = True
            b += span + 1
        else:
            b += 1
    return is_break, opens


def _span(is_break: np.ndarray, opens: np.ndarray, b: int) -> int:
    n = 1
    while b + n < is_break.size and is_break[b + n] and not opens[b + n]:
        n += 1
    return n


def _clip_rng(seed: int, index: int) -> np.random.Generator:
    return np.random.Generator(np.random.PCG64(np.random.SeedSequence([int(seed), int(index)])))


def generate_clip(cfg: SynthConfig, index: int) -> Clip:
    """Generate clip ``index`` of ``cfg`` (deterministic; independent of ``cfg.num_clips``).

    Returns a :class:`Clip` with ``motion`` ``(T, J, D)`` float32 (metres for 3D, pixels for 2D),
    ``audio`` ``(S,)`` float32 at ``cfg.sample_rate`` with ``S = round(T / fps * sample_rate)``,
    ``style``, and ``meta`` holding (seconds) ``beat_times`` / ``downbeat_times`` (the music's beat
    grid, continuing through breaks), ``onset_times`` (the beats that sound an attack),
    ``break_times`` (``[start, end]`` of each break), ``motion_beat_times`` (the jittered beats on
    which the dancer reaches a key pose), ``moves`` (the named moves danced, with their times,
    mirroring and turn: :func:`momu.data.synth.captions.move_records`), plus ``bpm``,
    ``beats_per_bar``, ``split`` and ``index``; ``text`` holds the clip's template caption
    (:func:`momu.data.synth.captions.caption`, the synthetic stand-in for HumanML3D's texts).
    """
    if index < 0:
        raise IndexError(f"clip index must be >= 0, got {index}")
    skeleton = get_skeleton(cfg.skeleton)
    style = get_style(cfg.styles[index % len(cfg.styles)])
    fps = resolved_fps(cfg)
    rng = _clip_rng(cfg.seed, index)

    duration = float(rng.uniform(cfg.min_seconds, cfg.max_seconds))
    num_frames = max(2, int(round(duration * fps)))
    duration = num_frames / fps
    num_samples = int(round(duration * cfg.sample_rate))

    bpm = float(rng.uniform(*(style.bpm if cfg.bpm_range is None else cfg.bpm_range)))
    period = 60.0 / bpm
    first_beat = float(rng.uniform(0.1, 0.1 + period))
    first_index = int(rng.integers(style.beats_per_bar))
    grid = beat_grid(first_beat, period, duration, style.beats_per_bar, first_index)

    bpb = style.beats_per_bar
    is_break, opens = plan_breaks(rng, grid["bar_starts"].size, cfg.break_prob, cfg.max_break_bars)

    # Beats of the grid extended one before and two after (index k = -1 .. N + 1), each jittered.
    k = np.arange(-1, grid["beats"].size + 2)
    bar = grid["beat_bar"][0] + (k + first_index) // bpb if grid["beats"].size else k * 0
    in_range = (bar >= 0) & (bar < is_break.size)
    bar_c = np.clip(bar, 0, is_break.size - 1)
    in_break = in_range & is_break[bar_c]
    hit = in_break & opens[bar_c] & ((k + first_index) % bpb == 0)
    keyed = ~in_break | hit  # beats on which the dancer reaches a key pose
    jitter = np.clip(rng.normal(0.0, cfg.phase_jitter, k.size), -0.3 * period, 0.3 * period)
    motion_beats = first_beat + k * period + jitter
    drawn: list[dict[str, Any]] = []
    poses, root = choose_keys(
        style,
        int(keyed.sum()),
        rng,
        amplitude_range=cfg.amplitude_range,
        radius=cfg.trajectory_radius,
        moves_out=drawn,
    )
    times = np.arange(num_frames) / fps
    phase = beat_phase(times, motion_beats)
    key_phases = (k + 1)[keyed].astype(np.float64)
    controls = ease_keys(
        np.concatenate([poses, root], axis=1), phase, key_phases, attack=cfg.attack, release=cfg.release
    )
    controls[:, : poses.shape[1]] += smooth_noise(
        rng, (num_frames, poses.shape[1]), cfg.motion_noise, cfg.noise_smoothing * fps
    )
    segs = segment_rotations(controls[:, : poses.shape[1]], controls[:, poses.shape[1]])
    positions = pose(skeleton, segs, controls[:, poses.shape[1] + 1 :])

    grid_beats = slice(1, 1 + grid["beats"].size)  # extended index -> grid beats
    audio = render_music(
        style,
        grid,
        first_index,
        num_samples,
        cfg.sample_rate,
        rng,
        sounded=~in_break[grid_beats],
        hits=hit[grid_beats],
        held_bars=is_break & ~opens,
        noise=cfg.audio_noise,
    )

    trajectory = None
    if skeleton.dims == 2:
        motion = project(positions, cfg.camera)
    elif cfg.root_centred:
        trajectory = positions[:, skeleton.root].astype(np.float32)
        motion = positions - positions[:, skeleton.root : skeleton.root + 1]
    else:
        motion = positions
    inside = keyed & (motion_beats >= 0) & (motion_beats < duration)
    sounding = (~in_break | hit)[grid_beats]
    bar_len = bpb * period
    breaks = [
        [
            float(grid["bar_starts"][b]),
            float(grid["bar_starts"][b] + bar_len * _span(is_break, opens, int(b))),
        ]
        for b in np.flatnonzero(opens)
    ]
    meta: dict[str, Any] = {
        "index": index,
        "split": split_of(index, len(cfg.styles)),
        "bpm": bpm,
        "beats_per_bar": style.beats_per_bar,
        "beat_times": [float(x) for x in grid["beats"]],
        "downbeat_times": [float(x) for x in grid["downbeats"]],
        "onset_times": [float(x) for x in grid["beats"][sounding]],
        "break_times": breaks,
        "motion_beat_times": [float(x) for x in motion_beats[inside]],
        "moves": move_records(drawn, motion_beats[keyed], duration),
        "source": "synth_dance",
    }
    return Clip(
        id=f"synth_{index:05d}",
        motion=np.ascontiguousarray(motion, dtype=np.float32),
        fps=fps,
        audio=audio,
        sample_rate=cfg.sample_rate,
        skeleton=skeleton.name,
        style=style.name,
        trajectory=trajectory,
        text=[caption(meta["moves"], style.name)],
        meta=meta,
    )


class SynthDance:
    """In-memory ``synth_dance``: clips generated lazily, on each ``dataset[i]``.

    Args:
        cfg: the configuration (validated here; errors name the bad field).
        split: ``"train"``, ``"val"``, ``"test"``, or ``"all"`` / ``None`` for every clip.
    """

    def __init__(self, cfg: SynthConfig | None = None, split: str | None = None) -> None:
        self.cfg = cfg if cfg is not None else SynthConfig()
        validate_config(self.cfg)
        if split == "all":
            split = None
        if split is not None and split not in SPLITS:
            raise ValueError(f"synth_dance: split must be one of {', '.join(SPLITS)}, all; got {split!r}")
        self.split = split
        n_styles = len(self.cfg.styles)
        self.indices: tuple[int, ...] = tuple(
            i for i in range(self.cfg.num_clips) if split is None or split_of(i, n_styles) == split
        )

    @property
    def fps(self) -> float:
        return resolved_fps(self.cfg)

    @property
    def skeleton(self) -> str:
        return self.cfg.skeleton

    def __len__(self) -> int:
        return len(self.indices)

    def split_at(self, index: int) -> str:
        """The split of clip ``index`` without generating it (``Clip.meta["split"]`` of ``self[index]``)."""
        return split_of(self.indices[index], len(self.cfg.styles))

    def __getitem__(self, index: int) -> Clip:
        if not -len(self) <= index < len(self):
            raise IndexError(f"synth_dance index {index} out of range for {len(self)} clips")
        return generate_clip(self.cfg, self.indices[index])

    def __repr__(self) -> str:
        return (
            f"SynthDance(clips={len(self)}, split={self.split!r}, skeleton={self.cfg.skeleton!r}, "
            f"fps={self.fps}, styles={list(self.cfg.styles)})"
        )
