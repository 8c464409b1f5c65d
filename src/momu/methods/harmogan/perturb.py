"""Perturbations of ground-truth clips for HarmoGAN's calibration rows and for Fig. 11 (momu's analysis).

Every HarmoGAN table prints what the harmony score gives for ground truth under changes a viewer would
notice (issue 15's calibration rows), with the same metric code at the paper's 6-s clip length:

* :func:`shifted_audio` — the clip's audio taken half a beat earlier or later (phase shift, tempo kept);
* :func:`static_pose` — the clip's mean pose held still plus Gaussian noise of 0.1 mm;
* :func:`time_warped` — the dance played ``factor`` × faster (×1.25) or slower (×0.8) against
  unchanged music, by linear interpolation of the whole dance from the clip's start;
* :func:`chunk_permuted` — the clip's motion cut into 1-s chunks in a random order (HarmoGAN Fig. 11's
  "permuting ... the original visual sequences").

Shuffled ground truth (clip π(i)'s motion against clip i's music) uses
:func:`momu.methods.momu.scoring.derangement`'s π(i) = (i + 1) mod N.
"""

from __future__ import annotations

import librosa
import numpy as np

from momu.methods.harmogan.data import Dance, Window

__all__ = ["beat_period", "shifted_audio", "static_pose", "time_warped", "chunk_permuted"]


def beat_period(dance: Dance) -> float:
    """The dance music's beat period in seconds (librosa's tempo estimate over the whole song)."""
    tempo = librosa.feature.tempo(y=dance.audio.astype(np.float32), sr=dance.sample_rate)
    bpm = float(np.atleast_1d(tempo)[0])
    if not bpm > 0:
        raise ValueError(f"dance {dance.id!r}: no tempo could be estimated")
    return 60.0 / bpm


def shifted_audio(dance: Dance, window: Window, seconds: float) -> np.ndarray:
    """The window's audio taken ``seconds`` earlier — or the other way where the shift would leave the song
    (a half-beat shift moves the phase by half a beat either way) — with the same length.

    Raises:
        ValueError: the song is too short for the shift either way.
    """
    a0, a1 = dance.samples(window.start, window.start + window.frames)
    shift = int(round(seconds * dance.sample_rate))
    if a0 - shift < 0 or a1 - shift > len(dance.audio):
        shift = -shift
    if a0 - shift < 0 or a1 - shift > len(dance.audio):
        raise ValueError(f"dance {dance.id!r}: a shift of {seconds:.3f} s leaves the song")
    return dance.audio[a0 - shift : a1 - shift]


def static_pose(motion: np.ndarray, noise_m: float, rng: np.random.Generator) -> np.ndarray:
    """The clip's mean pose in every frame plus i.i.d. Gaussian noise of ``noise_m`` metres per coordinate."""
    x = np.asarray(motion, dtype=np.float64)
    still = np.broadcast_to(x.mean(axis=0), x.shape)
    return (still + rng.normal(0.0, noise_m, size=x.shape)).astype(np.float32)


def time_warped(dance: Dance, window: Window, factor: float) -> np.ndarray:
    """``window.frames`` poses of the dance at ``factor`` × speed from the window's start (interpolated).

    Frame ``t`` is the dance at ``s + factor · t`` frames, ``s`` the window's start moved earlier when
    the sped-up span would run past the dance's end.
    """
    if factor <= 0:
        raise ValueError(f"time_warped: factor must be > 0, got {factor}")
    total = dance.motion.shape[0]
    span = factor * (window.frames - 1)
    if span > total - 1:
        raise ValueError(
            f"dance {dance.id!r}: {total} frames are too few for a ×{factor} warp of {window.frames}"
        )
    start = min(float(window.start), total - 1 - span)
    pos = start + factor * np.arange(window.frames)
    lo = np.floor(pos).astype(np.int64)
    hi = np.minimum(lo + 1, total - 1)
    w = (pos - lo)[:, None, None]
    return ((1 - w) * dance.motion[lo] + w * dance.motion[hi]).astype(np.float32)


def chunk_permuted(motion: np.ndarray, chunk_frames: int, rng: np.random.Generator) -> np.ndarray:
    """The motion's consecutive chunks of ``chunk_frames`` in a random order that moves every chunk
    (the tail shorter than a chunk stays last)."""
    x = np.asarray(motion)
    n = x.shape[0] // chunk_frames
    if n < 2:
        raise ValueError(f"chunk_permuted: {x.shape[0]} frames hold fewer than 2 chunks of {chunk_frames}")
    order = rng.permutation(n)
    while np.any(order == np.arange(n)):  # a derangement: no chunk stays in place
        order = rng.permutation(n)
    chunks = [x[i * chunk_frames : (i + 1) * chunk_frames] for i in order]
    return np.concatenate([*chunks, x[n * chunk_frames :]], axis=0)
