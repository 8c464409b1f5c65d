"""Figures and animations of generated samples: beat-matching plots and skeleton renderings.

``import momu.render`` does not import matplotlib (the ``render`` extra); each function imports it when
called and draws on its own Agg canvas (no pyplot state, no backend switch).

- :func:`beat_matching_figure`: MoMu-Diffusion Figure 4/5-style plot (music with its beats, the motion's
  kinematic amplitude with its beats, poses at the beats) — :mod:`momu.render.beat_plot`.
- :func:`draw_skeleton`: one pose on a matplotlib ``Axes`` — :mod:`momu.render.skeleton`.
- :func:`skeleton_animation`: an animated GIF (or MP4 with sound, with ``imageio-ffmpeg``).
- :func:`clip_beat_figure` / :func:`clip_animation`: the same from a :class:`~momu.data.types.Clip`.
"""

from momu.render.beat_plot import BeatFigureSummary, beat_matching_figure, clip_beat_figure, waveform_envelope
from momu.render.skeleton import clip_animation, draw_skeleton, screen_coordinates, skeleton_animation

__all__ = [
    "BeatFigureSummary",
    "beat_matching_figure",
    "clip_animation",
    "clip_beat_figure",
    "draw_skeleton",
    "screen_coordinates",
    "skeleton_animation",
    "waveform_envelope",
]
