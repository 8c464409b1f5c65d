"""How many beats a ballroom dancer's movement spans, read from the motion (issue 32).

A music model conditioned on a dance's rhythm (``motion_rhythm``) reads the beats at the dominant
period of the dancer's movements. Ballroom dancers move once per bar in a waltz (3 beats) and once per
half bar in the Latin dances and the tango (2 beats), so that period is not the song's beat;
``momu generate music --beats-per-movement N`` splits it into N beats. This module reads N from the
motion alone, with a cue that does not change when the dance is played faster or slower: the dominant
tempo of the **feet's** kinematic onsets over the **whole body's**. A waltz's feet move several times
per rise and fall of the body (2.8-5.6 times on the Dance with Melody waltzes); a rumba's, cha-cha's or
tango's move with it (0.7-1.5) (``benchmarks/dance_feet_body_ratio.py``). :data:`WALTZ_RATIO` is the
threshold between the *train* split's two groups.

It is a ballroom rule, fixed from 10 dances (the cue was noticed looking at all 23): a dance of any
other kind, whose feet move with its body, is read as 2 beats per movement. Use it for ballroom dances.

``auto`` (the default of ``momu generate music`` and of the benchmark) answers 3 only for a dancer who
moves once per *waltz bar*: waltz feet (the ratio above :data:`WALTZ_RATIO`) under a body that rises
and falls slower than :data:`BAR_BPM` times a minute; every other dance gets 1, how the model was
trained. Dancers who move on every beat (``synth_dance``'s, whose waltzers' feet also step several
times per movement, but 50 or more times a minute) keep the music at their own period, and for the Latin
dances 2 and 1 are the same tempo up to an octave, which the benchmark's tempo match tolerates.
"""

from __future__ import annotations

import numpy as np

from momu.features.skeletons import get_skeleton

__all__ = [
    "WALTZ_RATIO",
    "MAX_BEATS_PER_MOVEMENT",
    "BAR_BPM",
    "movement_tempi",
    "feet_body_ratio",
    "auto_beats",
    "ballroom_beats_per_movement",
    "beats_for_ratio",
    "parse_beats_per_movement",
    "read_beats",
    "beats_for",
]

WALTZ_RATIO = 2.17
"""Feet-over-body tempo ratio above which a dance is read as a waltz: the geometric mean of the train
split's largest other-style ratio (1.548) and smallest waltz ratio (3.048)
(``benchmarks/results/dance_feet_body_ratio.json``)."""
BODY_BPM = (20.0, 200.0)
"""Where the body's period is searched: ``motion_rhythm``'s ``periodogram_bpm``, as the shipped model's."""
BAR_BPM = 43.4
"""Body movements per minute below which a dance with waltz feet is read as moving once per bar
(``auto``): the geometric mean of the train split's fastest waltz bar (37.7, played ×1.25) and the
slowest ``synth_dance`` train dancer with waltz feet (50.0, a waltz danced on the beat, played ×0.8),
over the benchmark's stretches (``benchmarks/results/dance_feet_body_ratio.json``)."""
MAX_BEATS_PER_MOVEMENT = 8
"""Largest N of ``--beats-per-movement`` (a movement spanning two bars of 4/4)."""
FEET_BPM = (20.0, 400.0)
"""Where the feet's is: a waltz's feet move about five times per bar (~150 BPM; ~190 played ×1.25)."""


def movement_tempi(motion: np.ndarray, fps: float, skeleton: str) -> tuple[float, float]:
    """Dominant tempi (per minute) of the whole body's kinematic onsets (θ_a's reading, 20-200) and of
    the feet's (20-400); NaN where there is none."""
    from momu.features.rhythm import ENVELOPE_RATE, motion_envelope  # librosa: not for option parsing
    from momu.following.tempo import periodogram_tempo  # momu.following imports momu.features

    x = np.asarray(motion, dtype=np.float64)
    body = periodogram_tempo(motion_envelope(x, fps), ENVELOPE_RATE, BODY_BPM)
    names = get_skeleton(skeleton).joint_names
    feet = [i for i, n in enumerate(names) if n.endswith(("ankle", "heel", "toe", "foot"))]
    steps = periodogram_tempo(motion_envelope(x[:, feet], fps), ENVELOPE_RATE, FEET_BPM)
    return float(body), float(steps)


def feet_body_ratio(motion: np.ndarray, fps: float, skeleton: str) -> float:
    """Dominant tempo of the feet's kinematic onsets over the whole body's (NaN when either has none)."""
    body, feet = movement_tempi(motion, fps, skeleton)
    return feet / body


def auto_beats(body_bpm: float, feet_bpm: float) -> int:
    """``auto``: 3 when the feet move more than :data:`WALTZ_RATIO` times per body movement and the body
    moves slower than :data:`BAR_BPM` times a minute (a waltz danced once per bar), else 1."""
    return 3 if beats_for_ratio(feet_bpm / body_bpm) == 3 and body_bpm < BAR_BPM else 1


def beats_for_ratio(ratio: float) -> int:
    """3 (a waltz: one movement per bar) when the feet move more than :data:`WALTZ_RATIO` times per
    body movement, else 2 (one per half bar)."""
    return 3 if np.isfinite(ratio) and ratio > WALTZ_RATIO else 2


def ballroom_beats_per_movement(motion: np.ndarray, fps: float, skeleton: str) -> int:
    """:func:`beats_for_ratio` of ``(T, J, 3)`` world positions of ``skeleton``."""
    return beats_for_ratio(feet_body_ratio(motion, fps, skeleton))


def parse_beats_per_movement(text: str) -> int | str:
    """``--beats-per-movement``: a whole number 1 to :data:`MAX_BEATS_PER_MOVEMENT`, ``"ballroom"`` or
    ``"auto"``.

    Raises:
        ValueError: anything else (the message names the option and the value).
    """
    if text.strip().lower() in ("ballroom", "auto"):
        return text.strip().lower()
    try:
        beats = int(text)
    except ValueError:
        beats = 0
    if not 1 <= beats <= MAX_BEATS_PER_MOVEMENT:
        raise ValueError(
            f"--beats-per-movement: must be 1 to {MAX_BEATS_PER_MOVEMENT}, ballroom or auto, got {text!r}"
        )
    return beats


def read_beats(beats: int | str, motion: np.ndarray, fps: float, skeleton: str) -> tuple[int, str]:
    """``beats`` as a number, ``"ballroom"`` or ``"auto"`` read from ``(T, J, 3)`` world positions of
    ``skeleton``, with a line saying what was read (empty for a number)."""
    if beats not in ("ballroom", "auto"):
        return int(beats), ""
    body, feet = movement_tempi(motion, fps, skeleton)
    n = beats_for_ratio(feet / body) if beats == "ballroom" else auto_beats(body, feet)
    read = (
        f"the body moves {body:.1f} times a minute, the feet {feet / body:.2f} times per body movement"
        if np.isfinite(feet / body)
        else "no steady movement of the body and feet found"
    )
    return n, f"{beats}: {read}: {n} beat{'s' if n > 1 else ''} per movement"


def beats_for(beats: int | str, motion: np.ndarray, fps: float, skeleton: str) -> int:
    """``beats`` as a number (:func:`read_beats` without its line)."""
    return read_beats(beats, motion, fps, skeleton)[0]
