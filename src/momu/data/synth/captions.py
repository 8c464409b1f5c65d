"""Template captions of ``synth_dance`` clips from the named moves they dance (MoFusion §4.2 stand-in).

Every clip records the moves its generator drew (:func:`move_records`: name, start and end time,
mirroring, turn). A caption names them in order, e.g. ``"a person dances hiphop: a bounce, then a
punch with the left arm, then a side step turning left."`` — the synthetic counterpart of
HumanML3D's texts, so text→motion (MoFusion Table 2) can be trained and scored on data that needs no
download. Captions are deterministic functions of the records.

Sides: a move whose keys are not their own mirror image is *one-sided*; its side is the side whose
controls move more (``l_*`` vs ``r_*``), swapped when the move was mirrored. Turns: a summed yaw
above ``TURN_RADIANS`` reads "turning left" (positive yaw turns the dancer, who faces +Z with the
left side at +X, towards the left), below ``-TURN_RADIANS`` "turning right".
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from functools import cache
from typing import Any

import numpy as np

from momu.data.synth.styles import STYLES, Move

__all__ = ["TURN_RADIANS", "move_records", "move_phrase", "caption", "caption_window", "one_sided_side"]

TURN_RADIANS = 0.5
_ARMS = ("sh_flex", "sh_abd", "elbow")


def move_records(drawn: Sequence[Mapping[str, Any]], key_times: np.ndarray, duration: float) -> list[dict]:
    """Moves as JSON records with times: ``start`` (the key before its first, or 0) and ``end``
    (its last key's time), both clipped to ``[0, duration]``; moves that end before 0 or start after
    ``duration`` are dropped."""
    times = np.asarray(key_times, dtype=np.float64)
    out = []
    for rec in drawn:
        first, n = int(rec["first_key"]), int(rec["num_keys"])
        if n <= 0:
            continue
        start = float(times[first - 1]) if first > 0 else 0.0
        end = float(times[first + n - 1])
        if end <= 0.0 or start >= duration:
            continue
        out.append(
            {
                "name": str(rec["name"]),
                "mirrored": bool(rec["mirrored"]),
                "turn": float(rec["turn"]),
                "start": max(0.0, start),
                "end": min(float(duration), end),
            }
        )
    return out


@cache
def _moves_by_name() -> dict[str, Move]:
    return {m.name: m for style in STYLES.values() for m in style.moves}


@cache
def one_sided_side(name: str) -> str | None:
    """``"left"`` / ``"right"``: the side a move works (unmirrored), ``None`` for symmetric moves."""
    move = _moves_by_name().get(name)
    if move is None:
        return None
    left = sum(abs(v) for key in move.keys for k, v in key.items() if k.startswith("l_"))
    right = sum(abs(v) for key in move.keys for k, v in key.items() if k.startswith("r_"))
    if abs(left - right) < 1e-9:
        return None
    return "left" if left > right else "right"


def _limb(name: str) -> str:
    """``"arm"`` or ``"leg"``: which limb's controls move more in the move's one-sided keys."""
    move = _moves_by_name().get(name)
    sided = [
        (k[2:], abs(v))
        for key in (move.keys if move else ())
        for k, v in key.items()
        if k[:2] in ("l_", "r_")
    ]
    arms = sum(v for k, v in sided if k in _ARMS)
    return "arm" if arms >= sum(v for _, v in sided) - arms else "leg"


def move_phrase(record: Mapping[str, Any]) -> str:
    """``"a punch with the left arm"``, ``"a pirouette turning left"``, ``"a plie"``."""
    name = str(record["name"])
    words = name.replace("_", " ")
    text = f"{'an' if words[0] in 'aeiou' else 'a'} {words}"
    side = one_sided_side(name)
    if side is not None:
        if record.get("mirrored"):
            side = "right" if side == "left" else "left"
        text += f" with the {side} {_limb(name)}"
    turn = float(record.get("turn", 0.0))
    if turn > TURN_RADIANS:
        text += " turning left"
    elif turn < -TURN_RADIANS:
        text += " turning right"
    return text


def caption(records: Sequence[Mapping[str, Any]], style: str | None = None) -> str:
    """The caption of a sequence of move records: ``"a person dances <style>: A, then B, then C."``."""
    phrases = [move_phrase(r) for r in records]
    head = f"a person dances {style}" if style else "a person dances"
    if not phrases:
        return head + "."
    return f"{head}: " + ", then ".join(phrases) + "."


def caption_window(
    records: Sequence[Mapping[str, Any]], start: float, end: float, style: str | None = None
) -> str:
    """The caption of the moves of ``[start, end)`` seconds (a crop): every move overlapping it."""
    inside = [r for r in records if float(r["end"]) > start and float(r["start"]) < end]
    return caption(inside, style)
