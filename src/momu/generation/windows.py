"""Where the windows of a long sequence lie, in two schedules, and each window's noise seed.

A MoMu denoiser generates windows of ``W`` latent frames; a song is cut into overlapping windows and
each window after the first is sampled by inpainting on frames another window generated
(MoFusion §4.4, :mod:`momu.generation.stitching`). Two schedules place them:

``sequential``
    window ``k`` starts ``W − O`` frames after window ``k − 1`` and its first ``O`` frames are the
    last ``O`` that window ``k − 1`` generated. Every window waits for the previous one, so a
    3-minute song is 61 reverse processes one after another.

``two_pass``
    the windows alternate between *anchors* (even positions, sampled from the condition alone, all in
    one batch) and *bridges* (odd positions, all in a second batch): a bridge lies between two anchors
    and knows its first ``O`` frames from the anchor before it and its last ``O`` frames from the
    anchor after it, so it generates the ``W − 2O`` frames that join them. Two batched reverse
    processes instead of one per window; the number of windows stays the same (an anchor and a bridge
    advance ``2(W − O)`` frames, as two sequential windows do), every window is ``W`` frames long
    (the trained window) unless the whole sequence is shorter, and window 0 is the sequential
    schedule's window 0. Needs ``W > 2O``.

Seeds: window 0 of an item draws its noise from ``torch.Generator().manual_seed(seed)`` (as one-window
generation does), window ``k > 0`` from a generator seeded by :func:`window_seed` ``(seed, k)``, so an
item's windows do not depend on how the windows are batched.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import torch

__all__ = ["SCHEDULES", "WindowPlan", "plan_windows", "window_seed", "window_generator"]

SCHEDULES = ("two_pass", "sequential")
"""The window schedules: two batched passes (anchors, then bridges), or one window after another."""


@dataclass(frozen=True)
class WindowPlan:
    """Where the windows of one sequence lie (latent frames).

    Attributes:
        length: total frames ``L``.
        starts: start frame of each window, in order along the sequence.
        ends: end frame (exclusive) of each window.
        overlap: ``O``, the frames a window takes from each neighbour it is inpainted on.
        schedule: ``"sequential"`` or ``"two_pass"`` (module docstring).
    """

    length: int
    starts: tuple[int, ...]
    ends: tuple[int, ...]
    overlap: int
    schedule: str = "sequential"

    def known(self, k: int) -> tuple[int, int]:
        """Frames of window ``k`` known before it is sampled: ``(at its start, at its end)``."""
        if k == 0 or (self.schedule == "two_pass" and k % 2 == 0):
            return 0, 0
        return (self.overlap, self.overlap) if self.schedule == "two_pass" else (self.overlap, 0)

    def passes(self) -> tuple[tuple[int, ...], ...]:
        """Window indices by batch: one window per pass (sequential), or the anchors then the bridges."""
        n = len(self.starts)
        if self.schedule == "two_pass":
            return tuple(p for p in (tuple(range(0, n, 2)), tuple(range(1, n, 2))) if p)
        return tuple((k,) for k in range(n))

    @property
    def boundaries(self) -> tuple[int, ...]:
        """Frames where a seam could show: every edge between known and newly generated frames."""
        out: list[int] = []
        for k, (s, e) in enumerate(zip(self.starts, self.ends)):
            head, tail = self.known(k)
            if head:
                out.append(s + head)
            if tail:
                out.append(e - tail)
        return tuple(out)


def _check(length: int, window: int, overlap: int) -> None:
    if window < 2 or not 0 < overlap < window:
        raise ValueError(f"need window >= 2 and 0 < overlap < window, got window={window}, overlap={overlap}")
    if length < 1:
        raise ValueError(f"length must be >= 1, got {length}")


def _sequential(length: int, window: int, overlap: int) -> WindowPlan:
    starts, ends = [0], [min(window, length)]
    while ends[-1] < length:
        start = ends[-1] - overlap
        starts.append(start)
        ends.append(min(start + window, length))
    return WindowPlan(length, tuple(starts), tuple(ends), overlap, "sequential")


def _two_pass(length: int, window: int, overlap: int) -> WindowPlan:
    if 2 * overlap >= window:
        raise ValueError(
            f"the two_pass schedule needs window > 2 * overlap (a bridge knows {overlap} frames at each "
            f"end), got window={window}, overlap={overlap}; use schedule='sequential'"
        )
    if length <= window:
        return WindowPlan(length, (0,), (length,), overlap, "two_pass")
    # anchors of W frames from 0 to L − W, at most 2(W − O) apart (so a W-frame bridge centred between
    # two anchors knows O frames of each), as evenly spaced as integers allow
    span = length - window
    gaps = -(-span // (2 * (window - overlap)))
    anchors = [(k * span + gaps // 2) // gaps for k in range(gaps + 1)]
    starts: list[int] = []
    for a, b in zip(anchors, anchors[1:]):
        starts += [a, a + (b - a) // 2]
    starts.append(anchors[-1])
    return WindowPlan(length, tuple(starts), tuple(s + window for s in starts), overlap, "two_pass")


def plan_windows(length: int, window: int, overlap: int, schedule: str = "sequential") -> WindowPlan:
    """Windows of ``window`` frames covering ``length`` frames, placed by ``schedule`` (module docstring).

    A sequence no longer than ``window`` is one window. Sequential: windows overlap by ``overlap``
    and the last is shortened to end at ``length`` (it always generates at least one new frame).
    Two-pass: every window is ``window`` frames long; a bridge's first and last ``overlap`` frames lie
    inside the anchors before and after it, and no bridge reaches into another bridge's frames.
    """
    _check(length, window, overlap)
    if schedule == "sequential":
        return _sequential(length, window, overlap)
    if schedule == "two_pass":
        return _two_pass(length, window, overlap)
    raise ValueError(f"schedule {schedule!r} not one of {SCHEDULES}")


def window_seed(seed: int, k: int) -> int:
    """The seed of window ``k`` of an item seeded ``seed``: ``seed`` itself for window 0, otherwise a
    64-bit value drawn from ``numpy.random.SeedSequence([seed, k])`` (distinct per window)."""
    if k == 0:
        return int(seed)
    state = np.random.SeedSequence([int(seed) & 0xFFFF_FFFF_FFFF_FFFF, int(k)]).generate_state(2, np.uint32)
    return int(state[0]) | (int(state[1] & 0x7FFF_FFFF) << 32)


def window_generator(seed: int, k: int) -> torch.Generator:
    """A CPU generator seeded with :func:`window_seed` ``(seed, k)``."""
    return torch.Generator().manual_seed(window_seed(seed, k))
