"""What a generator does with the control inputs (:mod:`momu.following.inputs`): descriptive rows,
no verdict.

Per control and (song ``i``, seed ``s``), against the output for song ``i`` with the same seed:

* ``differs`` — ``d(control output, o(i, s)) / (that + D_seed(i, s))``: ½ when the control changes the
  output as much as another seed does, ≈ 0 when the model makes the same thing of silence as of a song;
* ``energy`` — dance: mean joint speed of the control output over that of ``o(i, s)``; music: mean
  log-mel level of the control output minus that of ``o(i, s)`` (dB);
* ``tempo_match`` (``click`` / ``metronome`` only) — whether the output's tempo matches the control's
  tempo (song ``i``'s), octave-tolerant within 5 %.
"""

from __future__ import annotations

import numpy as np

from momu.following.analysis import Analysis, MotionAnalysis, distance
from momu.following.inputs import CONTROLS, PER_SONG_CONTROLS, Request
from momu.following.tempo import tempo_matches

__all__ = ["control_stats"]


def control_stats(
    direction: str, outputs: dict[Request, Analysis], tempo: np.ndarray, seeds: list[int]
) -> dict[str, dict[str, np.ndarray]]:
    """``{control: {stat: (songs, seeds)}}`` (module docstring); empty when the row has no control outputs."""
    n, m = len(tempo), len(seeds)
    out: dict[str, dict[str, np.ndarray]] = {}
    for control in CONTROLS[direction]:
        stats = {k: np.full((n, m), np.nan) for k in ("differs", "energy", "tempo_match")}
        found = False
        for i in range(n):
            for k, s in enumerate(seeds):
                o = outputs.get(Request(i, s))
                song = i if control in PER_SONG_CONTROLS else -1
                c = outputs.get(Request(song, s, control=control))
                if o is None or c is None:
                    continue
                found = True
                other_seed = outputs.get(Request(i, seeds[(k + 1) % m]))
                d_ctrl = distance(c, o)
                d_seed = distance(o, other_seed) if m > 1 and other_seed is not None else 0.0
                stats["differs"][i, k] = d_ctrl / (d_ctrl + d_seed) if d_ctrl + d_seed > 0 else 0.0
                if isinstance(o, MotionAnalysis):
                    stats["energy"][i, k] = c.energy / o.energy if o.energy > 0 else np.nan
                else:
                    stats["energy"][i, k] = c.energy - o.energy
                if control in PER_SONG_CONTROLS:
                    stats["tempo_match"][i, k] = float(tempo_matches(c.tempo, tempo[i]))
        if found:
            out[control] = {k: v for k, v in stats.items() if np.isfinite(v).any()}
    return out
