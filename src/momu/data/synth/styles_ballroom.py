"""Travelling ballroom styles of ``synth_dance``: dancers that step and cross the floor.

The first four styles dance mostly in place; real Dance with Melody dancers travel 15–55 m a minute
with an ankle speed near 0.7 m/s (issue 32). These styles walk: on every beat one leg steps forward
(or back, or to the side) while the root moves ``step_z`` metres along the facing direction, the
other leg trails, and turning figures add yaw. The arms hold each style's position (a closed hold
for waltz and quickstep, Latin arms for rumba and cha-cha). Tempo ranges are disjoint (a few beats
per minute apart, so tempo tells them apart) and together span 60–160 beats per minute; the moves
and the waltz's 3/4 meter tell them from the in-place styles of overlapping tempo.

Each key is built by :func:`_step`: which leg leads, how far the body travels (metres, in the facing
frame: +z forward, +x the dancer's left) and how much it turns (radians) over the beat leading to it.
"""

from __future__ import annotations

from momu.data.synth.style_schema import Key, Move, Style, move

__all__ = ["BALLROOM_STYLES"]

_HOLD: dict[str, float] = {
    "l_sh_abd": 1.35,
    "l_elbow": 1.4,
    "r_sh_abd": 1.1,
    "r_sh_flex": 0.35,
    "r_elbow": 0.9,
}
"""Arms in a closed ballroom hold (waltz, quickstep): left hand raised, right arm around the partner."""

_STRIDE = 1.2
"""Every step length (``dz``, ``dx`` of :func:`_step`) is multiplied by this, so the four styles
travel about 29 m a minute at their mid tempi, the median of the real Dance with Melody dancers."""

_OPEN: dict[str, float] = {"l_sh_abd": 0.5, "l_elbow": 1.7, "r_sh_abd": 1.55, "r_elbow": 0.15, "twist": 0.15}
"""Latin open position (rumba): the right arm stretched out at shoulder height, the left bent low."""

_LATIN: dict[str, float] = {
    "l_sh_abd": 0.55,
    "r_sh_abd": 0.55,
    "l_sh_flex": 0.5,
    "r_sh_flex": 0.5,
    "l_elbow": 1.8,
    "r_elbow": 1.8,
}
"""Cha-cha arms: both bent at the waist, elbows out."""


def _step(
    lead: str,
    dz: float = 0.0,
    dx: float = 0.0,
    turn: float = 0.0,
    rise: float = 0.0,
    arms: dict[str, float] = _HOLD,
    **pose: float,
) -> Key:
    """A stepping key: ``lead`` (``"l"``/``"r"``) leg reaches in the travel direction, the other
    trails; ``rise`` straightens the knees (a waltz's rise and fall); ``arms`` is the style's arm
    position; ``pose`` overrides controls."""
    trail = "r" if lead == "l" else "l"
    sign = 1.0 if dz >= 0 else -1.0
    key: dict[str, float] = dict(arms)
    key.update(
        {
            f"{lead}_hip_flex": 0.38 * sign if dz else 0.05,
            f"{trail}_hip_flex": -0.22 * sign if dz else 0.0,
            f"{lead}_hip_abd": 0.25 if dx and ((dx > 0) == (lead == "l")) else 0.0,
            f"{lead}_knee": max(0.0, 0.15 - rise),
            f"{trail}_knee": max(0.0, 0.45 - rise),
            "lean_fwd": 0.05 * sign,
            "step_z": dz * _STRIDE,
            "step_x": dx * _STRIDE,
            "turn": turn,
        }
    )
    key.update(pose)
    return key


def _walk(
    name: str,
    beats: int,
    dz: float,
    *,
    turn: float = 0.0,
    weight: float = 1.0,
    rise: float = 0.0,
    arms: dict[str, float] = _HOLD,
    **pose: float,
) -> Move:
    """``beats`` alternating steps of ``dz`` metres, turning ``turn`` radians per step."""
    keys = [
        _step("l" if b % 2 == 0 else "r", dz=dz, turn=turn, rise=rise * (b % 3 != 0), arms=arms, **pose)
        for b in range(beats)
    ]
    return move(name, *keys, weight=weight)


_WALTZ = Style(
    name="waltz",
    bpm=(60.0, 84.0),
    beats_per_bar=3,
    kick=(1.0, 0.0, 0.0),
    snare=(0.0, 0.6, 0.6),
    pluck=(0.8, 0.4, 0.4),
    brightness=0.45,
    octave=43,
    moves=(
        _walk("progressive", 3, 0.5, rise=0.3, weight=2.0),
        _walk("natural_turn", 3, 0.42, turn=0.7, rise=0.3, weight=1.5),
        _walk("reverse_turn", 3, 0.42, turn=-0.7, rise=0.3, weight=1.5),
        move(
            "box_step",
            _step("l", dz=0.3),
            _step("r", dx=-0.3, rise=0.3),
            _step("l", dz=0.0, rise=0.1),
        ),
        move(
            "sway",
            _step("l", dz=0.35, lean_side=0.25, twist=0.3),
            _step("r", dz=0.35, lean_side=-0.2, rise=0.3),
            _step("l", dz=0.3, lean_side=0.15, twist=-0.2, rise=0.2),
        ),
    ),
)

_RUMBA = Style(
    name="rumba",
    bpm=(90.0, 108.0),
    beats_per_bar=4,
    kick=(1.0, 0.0, 0.7, 0.0),
    snare=(0.0, 0.5, 0.0, 1.0),
    pluck=(0.5, 0.0, 0.5, 0.5),
    brightness=0.5,
    octave=38,
    moves=(
        _walk("walks", 4, 0.36, weight=2.0, arms=_OPEN, lean_side=0.1),
        _walk("spiral", 4, 0.3, turn=0.8, arms=_OPEN),
        move(
            "cucaracha",
            _step("l", dx=0.25, lean_side=-0.15, twist=0.2, arms=_OPEN),
            _step("r", dx=-0.25, lean_side=0.15, twist=-0.2, arms=_OPEN),
            _step("l", dz=0.25, arms=_OPEN, l_sh_abd=0.8, l_sh_flex=1.4, l_elbow=0.3),
            _step("r", dz=0.25, arms=_OPEN, r_sh_abd=0.8, r_sh_flex=1.4, r_elbow=0.3),
        ),
        move(
            "fan",
            _step("l", dz=-0.3, arms=_OPEN, l_sh_abd=1.6, l_elbow=0.2, twist=0.4),
            _step("r", dz=0.3, arms=_OPEN, twist=-0.2),
            _step("l", dz=0.3, turn=0.5, arms=_OPEN),
            _step("r", dz=0.3, turn=0.5, arms=_OPEN, r_sh_abd=1.6, r_elbow=0.2),
        ),
    ),
)

_CHA_CHA = Style(
    name="cha_cha",
    bpm=(114.0, 130.0),
    beats_per_bar=4,
    kick=(1.0, 0.0, 1.0, 0.0),
    snare=(0.0, 0.8, 0.0, 0.8),
    pluck=(0.6, 0.3, 0.6, 0.6),
    brightness=0.7,
    octave=41,
    moves=(
        _walk("walks", 4, 0.3, weight=2.0, arms=_LATIN),
        move(
            "chasse",
            _step("l", dx=0.25, twist=0.2, arms=_LATIN),
            _step("r", dx=0.22, arms=_LATIN),
            _step("l", dx=0.25, twist=-0.2, arms=_LATIN),
            _step("r", dz=0.25, arms=_LATIN),
        ),
        move(
            "new_york",
            _step("l", dz=0.3, turn=0.6, arms=_LATIN, l_sh_abd=1.6, l_elbow=0.1),
            _step("r", dz=0.2, arms=_LATIN),
            _step("r", dz=0.3, turn=-0.6, arms=_LATIN, r_sh_abd=1.6, r_elbow=0.1),
            _step("l", dz=0.2, arms=_LATIN),
        ),
        _walk("turn", 4, 0.2, turn=1.2, arms=_LATIN),
    ),
)

_QUICKSTEP = Style(
    name="quickstep",
    bpm=(136.0, 160.0),
    beats_per_bar=4,
    kick=(1.0, 0.4, 1.0, 0.4),
    snare=(0.0, 1.0, 0.0, 1.0),
    pluck=(0.4, 0.4, 0.4, 0.4),
    brightness=0.8,
    octave=45,
    moves=(
        _walk("forward", 4, 0.33, weight=2.0, lean_fwd=0.2, l_knee=0.5, r_knee=0.5),
        _walk("quarter_turn", 4, 0.25, turn=0.4, lean_fwd=0.2),
        _walk("reverse", 4, 0.25, turn=-0.4, lean_fwd=0.2),
        move(
            "lock_step",
            _step("l", dz=0.3, rise=0.3),
            _step("r", dz=0.15, dx=0.1, rise=0.3),
            _step("l", dz=0.3),
            _step("r", dz=0.3, lean_side=0.2),
        ),
    ),
)

BALLROOM_STYLES: tuple[Style, ...] = (_WALTZ, _RUMBA, _CHA_CHA, _QUICKSTEP)
"""The travelling styles, registered beside the built-in ones in :mod:`momu.data.synth.styles`."""
