"""The vocabulary of ``synth_dance`` styles: pose controls, key poses, moves and styles.

:mod:`momu.data.synth.styles` holds the built-in styles written in it. Pose controls are angles in
radians (see :data:`CONTROLS`); ``turn`` (radians of yaw) and ``step_x``/``step_z`` (metres, in the
body's facing frame; +x = the dancer's left, +z = forward) are *increments* applied over the beat
leading to the key.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

__all__ = ["CONTROLS", "INCREMENTS", "NEUTRAL", "Key", "Move", "Style", "move"]

# Pose controls (radians). Positive: lean_fwd = trunk pitches forward, lean_side = trunk leans to the
# dancer's left, twist = chest turns left, nod = head pitches down, *_sh_flex = arm raised forward
# (pi = straight up), *_sh_abd = arm raised sideways, *_elbow = elbow bent, *_hip_flex = thigh raised
# forward (negative: leg back), *_hip_abd = leg out sideways, *_knee = knee bent.
CONTROLS: tuple[str, ...] = (
    "lean_fwd",
    "lean_side",
    "twist",
    "nod",
    "l_sh_flex",
    "r_sh_flex",
    "l_sh_abd",
    "r_sh_abd",
    "l_elbow",
    "r_elbow",
    "l_hip_flex",
    "r_hip_flex",
    "l_hip_abd",
    "r_hip_abd",
    "l_knee",
    "r_knee",
)
INCREMENTS: tuple[str, ...] = ("turn", "step_x", "step_z")

# The rest of every key pose: arms hanging slightly away from the body, elbows and knees soft.
NEUTRAL: Mapping[str, float] = {
    "l_sh_abd": 0.15,
    "r_sh_abd": 0.15,
    "l_elbow": 0.25,
    "r_elbow": 0.25,
    "l_knee": 0.08,
    "r_knee": 0.08,
    "l_hip_flex": 0.04,
    "r_hip_flex": 0.04,
}

Key = Mapping[str, float]


@dataclass(frozen=True)
class Move:
    """A named movement: ``keys[i]`` is the pose reached on the ``i``-th beat of the move."""

    name: str
    keys: tuple[Key, ...]
    weight: float = 1.0


@dataclass(frozen=True)
class Style:
    """One dance style.

    Attributes:
        name: style label (``Clip.style``).
        bpm: ``(low, high)`` tempo range in beats per minute; each clip draws its tempo uniformly.
        beats_per_bar: meter (the harmonic layer changes chord every bar).
        kick: kick-drum gain per beat of the bar (0 = none).
        snare: snare/clap gain per beat of the bar.
        pluck: gain of a tonal pluck (chord note) per beat of the bar.
        brightness: harmonic roll-off of the chord pad (higher = more upper partials).
        octave: MIDI note of the chord root's lowest octave.
        moves: the movement vocabulary.
    """

    name: str
    bpm: tuple[float, float]
    beats_per_bar: int
    kick: tuple[float, ...]
    snare: tuple[float, ...]
    pluck: tuple[float, ...]
    brightness: float
    octave: int
    moves: tuple[Move, ...]


def move(name: str, *keys: Key, weight: float = 1.0) -> Move:
    """A :class:`Move` from its name and its key poses, one per beat."""
    return Move(name, tuple(keys), weight)
