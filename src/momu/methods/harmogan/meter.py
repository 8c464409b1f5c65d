"""Meter segmentation (HarmoGAN §IV-A, Fig. 6): strong/weak beats, meters, meter units, TI and Eq. 12.

The paper labels each audio beat strong (1) "if its saliency is greater than that of the preceding
beat; otherwise ... weak (0)", maps strong–weak combinations to four common meters with a table that
appears only in Fig. 6, and cuts the music into *meter units* of one unified length ``T_u`` holding a
whole meter plus "a few beats from the preceding meter". The text gives neither the table nor ``T_u``
nor the number of transition beats; momu's choices (config fields of :class:`MeterConfig`):

* **Strong beats** (:func:`strong_weak`): the first beat is strong; beat ``i`` is strong iff
  ``s_i > (1 + strong_margin) · s_{i−1}`` (``strong_margin = 0``: the paper's rule).
* **Groups**: a group runs from a strong beat that follows a weak one (or the first beat) to the beat
  before the next such beat; its length ``L`` is its number of beats. A rising run of strong beats
  therefore stays in one group.
* **Mapping table** (:func:`segment_meters`; the four common meters of Acuff & Evridge [48]):

  | strong–weak combination | meter |
  |---|---|
  | ``1 0`` followed by a weaker ``1 0`` (strong, weak, medium, weak) | 4/4 |
  | ``1 0 0`` followed by a weaker ``1 0 0`` | 6/8 |
  | ``1 0`` | 2/4 |
  | ``1 0 0`` | 3/4 |
  | ``1 0 0 0`` | 4/4 |
  | ``1 0 0 0 0 0`` | 6/8 |
  | 5 or more than 6 beats | split into 4/4 meters, the remainder as 3/4 or 2/4 (5 = 3/4 + 2/4) |

  Music with a single meter and music mixing meters are handled alike: every group is mapped on its
  own.
* **Meter units** (:func:`meter_units`): unit ``k`` starts ``transition_beats`` beats before meter
  ``k`` (at 0 for the first meter if it has fewer predecessors) and lasts ``unit_seconds``; a meter
  that would not fit in its unit is split at its last beat that does (or at the unit's end), so the
  span from a unit's start to its meter's end never exceeds ``T_u``. Frames before the meter's start
  are the transition: ``TI`` has ``e_t = 1`` there (:func:`transition_indices`, at least one frame).
* **Eq. 12** (:func:`initial_pose_input`): ``vf_t = v_t`` where ``e_t = 1``, else the mean of the
  transition poses.

Recurrent generation (Fig. 7, right) writes unit ``k``'s frames ``[meter_start_k, meter_end_k)``; the
meters tile the music, so K units cover it whatever its length (:func:`meter_units` ends the last meter
at the music's end).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = [
    "METER_BEATS",
    "MeterConfig",
    "Meter",
    "MeterUnit",
    "strong_weak",
    "segment_meters",
    "meter_units",
    "transition_indices",
    "initial_pose_input",
]

METER_BEATS: dict[str, int] = {"2/4": 2, "3/4": 3, "4/4": 4, "6/8": 6}
"""The four meter types of the mapping table and their beats per meter."""

_BY_BEATS = {v: k for k, v in METER_BEATS.items()}


@dataclass
class MeterConfig:
    """Meter segmentation and meter units (HarmoGAN §IV-A; values are momu's choices).

    Attributes:
        unit_seconds: the unified unit length ``T_u`` in seconds.
        transition_beats: beats of the preceding meter at the start of each unit.
        strong_margin: relative margin of the strong-beat test (0: the paper's "greater than").
    """

    unit_seconds: float = 2.0
    transition_beats: int = 2
    strong_margin: float = 0.0

    def __post_init__(self) -> None:
        if not self.unit_seconds > 0:
            raise ValueError(f"meter.unit_seconds must be > 0, got {self.unit_seconds}")
        if self.transition_beats < 0:
            raise ValueError(f"meter.transition_beats must be >= 0, got {self.transition_beats}")
        if self.strong_margin < 0:
            raise ValueError(f"meter.strong_margin must be >= 0, got {self.strong_margin}")


@dataclass(frozen=True)
class Meter:
    """One meter: its first beat (index into the beats), its number of beats and its type."""

    first_beat: int
    num_beats: int
    meter: str


@dataclass(frozen=True)
class MeterUnit:
    """A meter unit in motion frames: ``[start, start + length)``, its meter ``[meter_start, meter_end)``."""

    start: int
    meter_start: int
    meter_end: int
    length: int
    meter: str

    @property
    def transition_frames(self) -> int:
        """Frames of the preceding meter at the unit's start (``e_t = 1``), at least 1."""
        return max(1, self.meter_start - self.start)


def strong_weak(saliency: np.ndarray, margin: float = 0.0) -> np.ndarray:
    """HarmoGAN §IV-A: 1 for a strong beat (saliency above the preceding beat's), else 0; the first: 1."""
    s = np.asarray(saliency, dtype=np.float64).reshape(-1)
    labels = np.zeros(s.size, dtype=np.int64)
    if s.size:
        labels[0] = 1
        labels[1:] = s[1:] > (1.0 + margin) * s[:-1]
    return labels


def _split_long(first: int, length: int) -> list[Meter]:
    """A group of 5 or more than 6 beats as 4/4 meters and a 3/4 or 2/4 remainder (5 = 3/4 + 2/4)."""
    parts: list[int] = []
    rest = length
    while rest > 4:
        if rest == 5:
            parts += [3, 2]
            rest = 0
        else:
            parts.append(4)
            rest -= 4
    if rest:
        parts.append(rest)
    if parts and parts[-1] == 1:  # 4 + 1: make it 3 + 2
        parts[-2:] = [3, 2]
    out, at = [], first
    for n in parts:
        out.append(Meter(at, n, _BY_BEATS[n]))
        at += n
    return out


def segment_meters(saliency: np.ndarray, margin: float = 0.0) -> list[Meter]:
    """The meters of a beat sequence by the mapping table of the module docstring (beats in time order)."""
    labels = strong_weak(saliency, margin)
    s = np.asarray(saliency, dtype=np.float64).reshape(-1)
    # a group starts at the first beat and at every strong beat after a weak one: a rising run of
    # strong beats stays in one group, which starts at the run's first beat
    starts = [i for i in range(labels.size) if i == 0 or (labels[i] == 1 and labels[i - 1] == 0)]
    bounds = [*starts, labels.size]
    joined = [(bounds[i], bounds[i + 1] - bounds[i]) for i in range(len(starts))]
    meters: list[Meter] = []
    i = 0
    while i < len(joined):
        first, length = joined[i]
        if i + 1 < len(joined) and length in (2, 3):
            nxt_first, nxt_length = joined[i + 1]
            if nxt_length == length and s[nxt_first] < s[first]:  # strong + weaker "medium" strong
                meters.append(Meter(first, 2 * length, "4/4" if length == 2 else "6/8"))
                i += 2
                continue
        if length in _BY_BEATS:
            meters.append(Meter(first, length, _BY_BEATS[length]))
        elif length == 1:
            meters.append(Meter(first, 1, "2/4"))  # a single beat: the shortest meter
        else:
            meters.extend(_split_long(first, length))
        i += 1
    return meters


def meter_units(
    beat_times: np.ndarray, saliency: np.ndarray, duration: float, fps: float, cfg: MeterConfig | None = None
) -> list[MeterUnit]:
    """Meter units covering ``[0, duration)`` seconds, in frames at ``fps`` (module docstring).

    Meter ``k`` runs from its first beat to meter ``k+1``'s (the first meter from 0, the last to
    ``duration``), so the units' meters tile the music; a meter longer than its unit allows is split.
    Without beats the music is one meter split into units.
    """
    cfg = cfg or MeterConfig()
    times = np.asarray(beat_times, dtype=np.float64).reshape(-1)
    total = int(np.floor(duration * fps + 1e-6))
    length = max(2, int(round(cfg.unit_seconds * fps)))
    if total < 1:
        return []
    meters = segment_meters(saliency, cfg.strong_margin) if times.size else []
    beat_frames = np.round(times * fps).astype(np.int64)
    starts = [0] + [int(beat_frames[m.first_beat]) for m in meters[1:]]
    firsts = [m.first_beat for m in meters] or [0]
    kinds = [m.meter for m in meters] or ["4/4"]
    units: list[MeterUnit] = []
    for k, meter_start in enumerate(starts):
        meter_end = starts[k + 1] if k + 1 < len(starts) else total
        if meter_end <= meter_start:
            continue
        back = firsts[k] - cfg.transition_beats
        start = int(beat_frames[back]) if k > 0 and back >= 0 else meter_start - 1
        # at least one and at most half a unit of transition frames, never before the music
        transition = min(max(1, meter_start - start), length // 2)
        at = meter_start
        while at < meter_end:  # split a meter that does not fit in its unit
            start = max(0, at - transition)
            limit = start + length
            end = meter_end
            if end > limit:
                inner = beat_frames[(beat_frames > at) & (beat_frames < limit)]
                end = int(inner[-1]) if inner.size else limit
            units.append(MeterUnit(start, at, end, length, kinds[k]))
            at = end
    return units


def transition_indices(unit: MeterUnit) -> np.ndarray:
    """``TI`` of a unit: ``(length,)`` float32, 1 on the transition frames (HarmoGAN §IV-A)."""
    e = np.zeros(unit.length, dtype=np.float32)
    e[: min(unit.length, unit.transition_frames)] = 1.0
    return e


def initial_pose_input(motion: np.ndarray, transition: np.ndarray) -> np.ndarray:
    """HarmoGAN Eq. 12: ``vf_t = v_t`` where ``e_t = 1``, else the mean of the transition poses.

    Args:
        motion: ``(T, ...)`` poses (only the transition frames are read).
        transition: ``(T,)`` binary ``TI`` with at least one 1.
    """
    e = np.asarray(transition, dtype=bool).reshape(-1)
    v = np.asarray(motion)
    if e.shape[0] != v.shape[0]:
        raise ValueError(f"initial_pose_input: {v.shape[0]} frames but TI has {e.shape[0]}")
    if not e.any():
        raise ValueError("initial_pose_input: TI marks no transition frame (Eq. 12 is undefined)")
    out = np.empty_like(v)
    out[e] = v[e]
    out[~e] = v[e].mean(axis=0)
    return out
