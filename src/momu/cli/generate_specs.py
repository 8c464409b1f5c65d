"""``momu generate inbetween`` / ``edit``: what to keep and what to regenerate, from the command line.

Times are seconds from the start of the motion; each rounds to the nearest frame at the model's rate
(MoFusion: 20 fps, so a time is exact to 0.025 s). Every error is one
:class:`~momu.cli.generate_io.GenerateInputError` line naming the option.

* ``--keyframes 0,1.5,3,end`` — the frames kept by in-betweening (MoFusion §4.4): times in seconds,
  ``end`` (the last frame), and ``every:STEP`` (a keyframe every STEP seconds from 0, and the last
  frame: the in-betweening preset of :func:`momu.samplers.inpainting.inbetween_mask`).
* ``--time START:END[,START:END ...]`` — the stretches a text edit regenerates, ``END`` exclusive;
  ``:END`` starts at 0 and ``START:`` runs to the end.
* ``--joints NAME[,NAME+ ...]`` — the joints a text edit regenerates (the model's skeleton's names;
  ``NAME+`` is the joint and every joint below it, e.g. ``l_shoulder+`` is the left arm).
"""

from __future__ import annotations

import numpy as np

from momu.cli.generate_io import GenerateInputError

__all__ = ["parse_keyframes", "parse_time", "parse_joints", "edit_region"]


def _seconds(text: str, option: str, what: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise GenerateInputError(f"{option}: {what} {text!r} is not a time in seconds") from None
    if not np.isfinite(value) or value < 0:
        raise GenerateInputError(f"{option}: {what} {text!r} must be a time >= 0 seconds")
    return value


def _items(spec: str | None, option: str) -> list[str]:
    items = [s.strip() for s in (spec or "").split(",")]
    if not any(items):
        raise GenerateInputError(f"{option} is empty")
    if not all(items):
        raise GenerateInputError(f"{option} {spec!r}: an empty item between commas")
    return items


def parse_keyframes(spec: str, frames: int, fps: float) -> list[int]:
    """Sorted, distinct keyframe indices (at ``fps``) of a ``frames``-frame motion."""
    last = frames - 1
    out: set[int] = set()
    for item in _items(spec, "--keyframes"):
        if item.lower() in ("end", "last"):
            out.add(last)
        elif item.lower().startswith("every:"):
            step = _seconds(item[6:], "--keyframes", "every:")
            if step * fps < 1.0 - 1e-9:
                raise GenerateInputError(
                    f"--keyframes {item}: a step under one frame ({1 / fps:g} s at {fps:g} fps)"
                )
            k = np.arange(int(np.floor(last / (step * fps) + 1e-9)) + 1)
            out.update(int(f) for f in np.round(k * step * fps))
            out.add(last)
        else:
            frame = int(round(_seconds(item, "--keyframes", "keyframe") * fps))
            if frame > last:
                raise GenerateInputError(
                    f"--keyframes: {item} s is past the end of the motion (its last frame is at "
                    f"{last / fps:.2f} s)"
                )
            out.add(frame)
    keys = sorted(out)
    if len(keys) == frames:
        raise GenerateInputError(
            f"--keyframes {spec}: every frame is a keyframe ({frames} frames at {fps:g} fps); "
            "nothing is left to in-between"
        )
    return keys


def parse_time(spec: str, frames: int, fps: float) -> np.ndarray:
    """``(frames,)`` bool: the frames inside the ``START:END`` stretches."""
    mask = np.zeros(frames, dtype=bool)
    for item in _items(spec, "--time"):
        if item.count(":") != 1:
            raise GenerateInputError(f"--time {item}: expected START:END in seconds (e.g. 1.5:3)")
        a, b = item.split(":")
        f0 = int(round(_seconds(a, "--time", "start") * fps)) if a.strip() else 0
        f1 = int(round(_seconds(b, "--time", "end") * fps)) if b.strip() else frames
        if f1 > frames:
            raise GenerateInputError(
                f"--time {item}: {b} s is past the end of the motion ({frames / fps:.2f} s)"
            )
        if f1 <= f0:
            raise GenerateInputError(
                f"--time {item}: covers no frame (its end must come after its start, at {fps:g} fps)"
            )
        mask[f0:f1] = True
    return mask


def parse_joints(spec: str, skeleton: str) -> np.ndarray:
    """``(J,)`` bool: the named joints of ``skeleton`` (``NAME+``: with every joint below it)."""
    from momu.features.skeletons import get_skeleton

    skel = get_skeleton(skeleton)
    index = {n.lower(): i for i, n in enumerate(skel.joint_names)}
    mask = np.zeros(skel.num_joints, dtype=bool)
    for item in _items(spec, "--joints"):
        name, below = (item[:-1], True) if item.endswith("+") else (item, False)
        if name.lower() not in index:
            raise GenerateInputError(
                f"--joints: {skeleton} has no joint {name!r} (joints: {', '.join(skel.joint_names)})"
            )
        mask[index[name.lower()]] = True
        if below:
            grown = True
            while grown:  # parents come before children in momu's layouts, but do not rely on it
                before = mask.sum()
                mask |= np.array([p >= 0 and mask[p] for p in skel.parents])
                grown = mask.sum() > before
    return mask


def edit_region(
    time_spec: str | None, joints_spec: str | None, frames: int, fps: float, skeleton: str
) -> np.ndarray:
    """``(frames, J)`` bool, True = regenerate: the ``--time`` stretches (default: all) × the
    ``--joints`` (default: all). At least one of the two must be given, and something must be kept."""
    from momu.features.skeletons import get_skeleton

    if time_spec is None and joints_spec is None:
        raise GenerateInputError(
            "--time START:END and/or --joints NAMES is needed: what to regenerate with the new caption"
        )
    j = get_skeleton(skeleton).num_joints
    when = np.ones(frames, dtype=bool) if time_spec is None else parse_time(time_spec, frames, fps)
    which = np.ones(j, dtype=bool) if joints_spec is None else parse_joints(joints_spec, skeleton)
    region = when[:, None] & which[None, :]
    if region.all():
        raise GenerateInputError(
            "--time/--joints cover the whole motion: nothing would be kept "
            "(for a new motion use `momu generate text`)"
        )
    return region
