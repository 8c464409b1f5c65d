"""Dance styles of ``synth_dance``: tempo range, meter, drum pattern, timbre and movement vocabulary.

A style's dance is a sequence of *moves*; a move is a short list of key poses, one per beat. The
generator eases every control from one key pose to the next over exactly one (jittered) beat, so
all joints come to rest and change direction on the beat: velocity minima and directional changes
are the kinematic beats MoMu (§3.2, Eq. 1-2) and HarmoGAN (§III-B, Eq. 2-3) look for.

The vocabulary the styles are written in (pose controls, key poses, :class:`Move`, :class:`Style`)
is :mod:`momu.data.synth.style_schema`.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

from momu.data.synth.style_schema import CONTROLS, INCREMENTS, NEUTRAL, Move, Style, move
from momu.data.synth.styles_ballroom import BALLROOM_STYLES

__all__ = ["CONTROLS", "INCREMENTS", "NEUTRAL", "Move", "Style", "STYLES", "STYLE_NAMES", "get_style"]

PI = math.pi

_HIPHOP = Style(
    name="hiphop",
    bpm=(84.0, 100.0),
    beats_per_bar=4,
    kick=(1.0, 0.0, 0.9, 0.0),
    snare=(0.0, 1.0, 0.0, 1.0),
    pluck=(0.0, 0.0, 0.0, 0.0),
    brightness=0.35,
    octave=36,
    moves=(
        move(
            "bounce",
            {
                "l_knee": 0.75,
                "r_knee": 0.75,
                "l_hip_flex": 0.45,
                "r_hip_flex": 0.45,
                "lean_fwd": 0.3,
                "nod": 0.35,
                "l_elbow": 1.4,
                "r_elbow": 1.4,
                "l_sh_flex": 0.4,
                "r_sh_flex": 0.4,
            },
            {
                "l_knee": 0.15,
                "r_knee": 0.15,
                "lean_fwd": 0.05,
                "nod": -0.1,
                "l_elbow": 1.0,
                "r_elbow": 1.0,
                "l_sh_flex": 0.2,
                "r_sh_flex": 0.2,
            },
            weight=2.0,
        ),
        move(
            "arm_pump",
            {"r_sh_flex": 1.7, "r_elbow": 0.5, "l_elbow": 1.6, "l_knee": 0.5, "r_knee": 0.5, "nod": 0.3},
            {"r_sh_flex": 0.4, "r_elbow": 1.9, "l_elbow": 1.2, "l_knee": 0.15, "r_knee": 0.15},
            {"l_sh_flex": 1.7, "l_elbow": 0.5, "r_elbow": 1.6, "l_knee": 0.5, "r_knee": 0.5, "nod": 0.3},
            {"l_sh_flex": 0.4, "l_elbow": 1.9, "r_elbow": 1.2, "l_knee": 0.15, "r_knee": 0.15},
        ),
        move(
            "side_step",
            {
                "step_x": -0.3,
                "r_hip_abd": 0.35,
                "lean_side": -0.2,
                "l_sh_abd": 0.7,
                "r_sh_abd": 0.7,
                "l_knee": 0.45,
                "r_knee": 0.45,
            },
            {
                "step_x": 0.0,
                "l_hip_abd": 0.1,
                "lean_side": 0.1,
                "l_elbow": 1.5,
                "r_elbow": 1.5,
                "l_sh_flex": 0.6,
                "r_sh_flex": 0.6,
            },
            {
                "step_x": 0.3,
                "l_hip_abd": 0.35,
                "lean_side": 0.2,
                "l_sh_abd": 0.7,
                "r_sh_abd": 0.7,
                "l_knee": 0.45,
                "r_knee": 0.45,
            },
            {
                "step_x": 0.0,
                "r_hip_abd": 0.1,
                "lean_side": -0.1,
                "l_elbow": 1.5,
                "r_elbow": 1.5,
                "l_sh_flex": 0.6,
                "r_sh_flex": 0.6,
            },
        ),
        move(
            "shoulder_rock",
            {
                "twist": 0.45,
                "lean_side": 0.15,
                "l_sh_flex": 0.9,
                "l_elbow": 1.7,
                "r_elbow": 0.8,
                "l_knee": 0.4,
                "r_knee": 0.2,
            },
            {
                "twist": -0.45,
                "lean_side": -0.15,
                "r_sh_flex": 0.9,
                "r_elbow": 1.7,
                "l_elbow": 0.8,
                "l_knee": 0.2,
                "r_knee": 0.4,
            },
        ),
        move(
            "drop",
            {
                "l_knee": 1.2,
                "r_knee": 1.2,
                "l_hip_flex": 0.9,
                "r_hip_flex": 0.9,
                "lean_fwd": 0.55,
                "l_hip_abd": 0.3,
                "r_hip_abd": 0.3,
                "l_sh_abd": 0.6,
                "r_sh_abd": 0.6,
                "nod": 0.3,
            },
            {
                "l_knee": 0.2,
                "r_knee": 0.2,
                "lean_fwd": -0.05,
                "l_sh_flex": 2.4,
                "r_sh_flex": 2.4,
                "l_elbow": 0.4,
                "r_elbow": 0.4,
            },
        ),
    ),
)

_ZUMBA = Style(
    name="zumba",
    bpm=(112.0, 128.0),
    beats_per_bar=4,
    kick=(1.0, 0.8, 1.0, 0.8),
    snare=(0.0, 0.7, 0.0, 0.7),
    pluck=(0.0, 0.0, 0.0, 0.0),
    brightness=0.6,
    octave=45,
    moves=(
        move(
            "step_touch",
            {
                "step_x": 0.22,
                "l_hip_abd": 0.3,
                "l_sh_abd": 1.1,
                "r_sh_abd": 1.1,
                "lean_side": 0.15,
                "l_elbow": 0.3,
                "r_elbow": 0.3,
            },
            {
                "r_hip_abd": 0.15,
                "r_knee": 0.5,
                "r_hip_flex": 0.3,
                "l_sh_abd": 0.3,
                "r_sh_abd": 0.3,
                "l_elbow": 1.3,
                "r_elbow": 1.3,
            },
            {
                "step_x": -0.22,
                "r_hip_abd": 0.3,
                "l_sh_abd": 1.1,
                "r_sh_abd": 1.1,
                "lean_side": -0.15,
                "l_elbow": 0.3,
                "r_elbow": 0.3,
            },
            {
                "l_hip_abd": 0.15,
                "l_knee": 0.5,
                "l_hip_flex": 0.3,
                "l_sh_abd": 0.3,
                "r_sh_abd": 0.3,
                "l_elbow": 1.3,
                "r_elbow": 1.3,
            },
            weight=2.0,
        ),
        move(
            "hip_sway",
            {
                "lean_side": 0.3,
                "twist": 0.25,
                "l_sh_flex": 1.3,
                "r_sh_flex": 1.3,
                "l_elbow": 1.1,
                "r_elbow": 1.1,
                "r_knee": 0.4,
            },
            {
                "lean_side": -0.3,
                "twist": -0.25,
                "l_sh_flex": 1.3,
                "r_sh_flex": 1.3,
                "l_elbow": 1.1,
                "r_elbow": 1.1,
                "l_knee": 0.4,
            },
        ),
        move(
            "march",
            {"l_hip_flex": 1.0, "l_knee": 1.3, "r_sh_flex": 0.9, "l_sh_flex": -0.4, "r_elbow": 1.2},
            {"r_hip_flex": 1.0, "r_knee": 1.3, "l_sh_flex": 0.9, "r_sh_flex": -0.4, "l_elbow": 1.2},
        ),
        move(
            "punch",
            {
                "r_sh_flex": 1.55,
                "r_elbow": 0.05,
                "l_elbow": 2.0,
                "l_sh_flex": 0.4,
                "twist": -0.35,
                "l_knee": 0.35,
                "r_knee": 0.35,
            },
            {
                "l_sh_flex": 1.55,
                "l_elbow": 0.05,
                "r_elbow": 2.0,
                "r_sh_flex": 0.4,
                "twist": 0.35,
                "l_knee": 0.35,
                "r_knee": 0.35,
            },
        ),
        move(
            "jumping_jack",
            {
                "l_sh_abd": 2.7,
                "r_sh_abd": 2.7,
                "l_hip_abd": 0.3,
                "r_hip_abd": 0.3,
                "l_elbow": 0.1,
                "r_elbow": 0.1,
            },
            {"l_knee": 0.45, "r_knee": 0.45, "l_hip_flex": 0.25, "r_hip_flex": 0.25},
        ),
    ),
)

_BALLET = Style(
    name="ballet",
    bpm=(60.0, 76.0),
    beats_per_bar=3,
    kick=(0.8, 0.35, 0.35),
    snare=(0.0, 0.0, 0.0),
    pluck=(1.0, 0.8, 0.8),
    brightness=0.8,
    octave=52,
    moves=(
        move(
            "port_de_bras",
            {"l_sh_flex": 1.3, "r_sh_flex": 1.3, "l_elbow": 0.6, "r_elbow": 0.6, "nod": 0.15},
            {
                "l_sh_flex": 2.9,
                "r_sh_flex": 2.9,
                "l_elbow": 0.45,
                "r_elbow": 0.45,
                "nod": -0.2,
                "lean_fwd": -0.1,
            },
            {"l_sh_abd": 1.45, "r_sh_abd": 1.45, "l_elbow": 0.2, "r_elbow": 0.2},
            weight=2.0,
        ),
        move(
            "plie",
            {
                "l_knee": 1.0,
                "r_knee": 1.0,
                "l_hip_flex": 0.5,
                "r_hip_flex": 0.5,
                "l_hip_abd": 0.45,
                "r_hip_abd": 0.45,
                "l_sh_abd": 1.3,
                "r_sh_abd": 1.3,
                "l_elbow": 0.3,
                "r_elbow": 0.3,
            },
            {
                "l_hip_abd": 0.45,
                "r_hip_abd": 0.45,
                "l_sh_flex": 0.6,
                "r_sh_flex": 0.6,
                "l_elbow": 0.7,
                "r_elbow": 0.7,
            },
            {
                "l_knee": 0.5,
                "r_knee": 0.5,
                "l_hip_abd": 0.3,
                "r_hip_abd": 0.3,
                "l_sh_flex": 2.7,
                "r_sh_flex": 2.7,
                "l_elbow": 0.4,
                "r_elbow": 0.4,
            },
        ),
        move(
            "pirouette",
            {
                "turn": PI,
                "r_hip_flex": 0.7,
                "r_hip_abd": 0.6,
                "r_knee": 1.6,
                "l_sh_flex": 1.4,
                "r_sh_flex": 1.4,
                "l_elbow": 1.0,
                "r_elbow": 1.0,
            },
            {
                "turn": PI,
                "r_hip_flex": 0.7,
                "r_hip_abd": 0.6,
                "r_knee": 1.6,
                "l_sh_flex": 2.8,
                "r_sh_flex": 2.8,
                "l_elbow": 0.5,
                "r_elbow": 0.5,
            },
            {"l_sh_abd": 1.3, "r_sh_abd": 1.3, "l_elbow": 0.3, "r_elbow": 0.3},
        ),
        move(
            "arabesque",
            {
                "r_hip_flex": -1.0,
                "r_knee": 0.05,
                "lean_fwd": 0.45,
                "l_sh_flex": 1.6,
                "r_sh_abd": 1.4,
                "l_elbow": 0.2,
                "r_elbow": 0.2,
                "step_z": 0.15,
            },
            {
                "r_hip_flex": -0.4,
                "lean_fwd": 0.15,
                "l_sh_flex": 2.6,
                "r_sh_flex": 2.6,
                "l_elbow": 0.4,
                "r_elbow": 0.4,
            },
            {"l_sh_abd": 1.0, "r_sh_abd": 1.0, "l_elbow": 0.5, "r_elbow": 0.5, "step_z": -0.15},
        ),
        move(
            "glide",
            {
                "step_x": 0.35,
                "lean_side": 0.2,
                "l_sh_abd": 1.5,
                "r_sh_abd": 0.8,
                "r_hip_abd": 0.4,
                "l_knee": 0.4,
            },
            {
                "step_x": 0.15,
                "lean_side": -0.05,
                "l_sh_flex": 2.0,
                "r_sh_flex": 2.0,
                "l_elbow": 0.7,
                "r_elbow": 0.7,
            },
            {"l_sh_abd": 0.9, "r_sh_abd": 1.5, "l_hip_abd": 0.3, "r_knee": 0.4, "lean_side": -0.15},
        ),
    ),
)

_TECHNO = Style(
    name="techno",
    bpm=(132.0, 150.0),
    beats_per_bar=4,
    kick=(1.0, 1.0, 1.0, 1.0),
    snare=(0.0, 0.6, 0.0, 0.6),
    pluck=(0.0, 0.0, 0.0, 0.0),
    brightness=0.95,
    octave=40,
    moves=(
        move(
            "fist_pump",
            {"r_sh_flex": 2.6, "r_elbow": 0.7, "l_elbow": 1.6, "l_knee": 0.35, "r_knee": 0.35, "nod": 0.3},
            {"r_sh_flex": 1.4, "r_elbow": 1.7, "l_elbow": 1.3, "l_knee": 0.08, "r_knee": 0.08, "nod": -0.1},
            weight=2.0,
        ),
        move(
            "shuffle",
            {"step_x": 0.12, "l_hip_flex": 0.5, "l_knee": 0.8, "twist": 0.25, "l_elbow": 1.5, "r_elbow": 1.5},
            {
                "step_x": 0.12,
                "r_hip_flex": 0.5,
                "r_knee": 0.8,
                "twist": -0.25,
                "l_elbow": 1.2,
                "r_elbow": 1.2,
            },
            {
                "step_x": -0.12,
                "l_hip_flex": 0.5,
                "l_knee": 0.8,
                "twist": 0.25,
                "l_elbow": 1.5,
                "r_elbow": 1.5,
            },
            {
                "step_x": -0.12,
                "r_hip_flex": 0.5,
                "r_knee": 0.8,
                "twist": -0.25,
                "l_elbow": 1.2,
                "r_elbow": 1.2,
            },
        ),
        move(
            "head_bang",
            {"nod": 0.55, "lean_fwd": 0.3, "l_knee": 0.4, "r_knee": 0.4, "l_elbow": 1.4, "r_elbow": 1.4},
            {"nod": -0.15, "lean_fwd": 0.0, "l_elbow": 1.0, "r_elbow": 1.0},
        ),
        move(
            "point",
            {
                "l_sh_flex": 2.2,
                "l_sh_abd": 0.6,
                "l_elbow": 0.05,
                "r_elbow": 1.8,
                "lean_side": 0.1,
                "r_knee": 0.4,
            },
            {"l_sh_flex": 0.8, "l_elbow": 1.6, "r_elbow": 1.6, "l_knee": 0.3},
        ),
    ),
)

STYLES: Mapping[str, Style] = {s.name: s for s in (_BALLET, _HIPHOP, _ZUMBA, _TECHNO, *BALLROOM_STYLES)}
STYLE_NAMES: tuple[str, ...] = tuple(STYLES)


def get_style(name: str) -> Style:
    """The built-in :class:`Style` called ``name``; ``KeyError`` naming the valid styles otherwise."""
    try:
        return STYLES[name]
    except KeyError:
        raise KeyError(
            f"unknown synth_dance style {name!r}; valid styles: {', '.join(STYLE_NAMES)}"
        ) from None
