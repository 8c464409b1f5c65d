"""Input validation shared by the beat and harmony metrics.

Every public metric function checks its arrays here so that a wrong shape, a NaN or an empty
sequence becomes a ``ValueError`` naming the argument, never a NaN score or a crash deep in numpy.
"""

from __future__ import annotations

from typing import Any

import numpy as np

__all__ = ["EmptyBeatsError", "as_motion", "as_frames", "as_times", "as_waveform"]


class EmptyBeatsError(ValueError):
    """A score is undefined because a beat set it averages over is empty.

    The reference implementations crash in these cases (``min`` of an empty array,
    ``ZeroDivisionError``); momu raises this ``ValueError`` subclass with a message instead.
    """


def as_motion(motion: Any, name: str = "motion", *, min_frames: int = 2) -> np.ndarray:
    """Validate joint positions ``(T, J, D)`` with ``D`` in {2, 3}; returns the array (dtype kept).

    Raises:
        ValueError: not 3-D, ``D`` not 2 or 3, fewer than ``min_frames`` frames, no joints, or
            non-finite values.
    """
    arr = np.asarray(motion)
    if arr.ndim != 3:
        raise ValueError(f"{name}: expected joint positions of shape (T, J, D), got shape {arr.shape}")
    if arr.shape[2] not in (2, 3):
        raise ValueError(
            f"{name}: last axis must hold 2 or 3 coordinates (T, J, D), got D={arr.shape[2]} "
            f"(shape {arr.shape}; are the axes in the wrong order?)"
        )
    if arr.shape[1] == 0:
        raise ValueError(f"{name}: has no joints (shape {arr.shape})")
    if arr.shape[0] < min_frames:
        raise ValueError(f"{name}: needs at least {min_frames} frames, got {arr.shape[0]}")
    if not np.issubdtype(arr.dtype, np.floating):
        arr = arr.astype(np.float64)
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name}: contains NaN or infinite positions")
    return arr


def as_frames(beats: Any, name: str) -> np.ndarray:
    """Validate beat frame indices: 1-D, integer-valued, non-negative; returns sorted unique int64.

    A boolean array is read as a one-hot vector (its nonzero indices).
    """
    arr = np.asarray(beats)
    if arr.dtype == bool:
        if arr.ndim != 1:
            raise ValueError(f"{name}: a one-hot beat vector must be 1-D, got shape {arr.shape}")
        return np.flatnonzero(arr).astype(np.int64)
    if arr.ndim == 0:
        arr = arr.reshape(1)
    if arr.ndim != 1:
        raise ValueError(f"{name}: beat frame indices must be 1-D, got shape {arr.shape}")
    if arr.size == 0:
        return np.zeros(0, dtype=np.int64)
    if not np.issubdtype(arr.dtype, np.number) or not np.all(np.isfinite(arr)):
        raise ValueError(f"{name}: beat frame indices must be finite numbers")
    if np.any(arr != np.round(arr)):
        raise ValueError(f"{name}: beat frame indices must be integers (frames), got {arr[:5]} ...")
    if np.any(arr < 0):
        raise ValueError(f"{name}: beat frame indices must be >= 0")
    return np.unique(arr.astype(np.int64))


def as_times(times: Any, name: str) -> np.ndarray:
    """Validate beat times in seconds: 1-D, finite, >= 0; returns float64 (order kept)."""
    arr = np.asarray(times, dtype=np.float64)
    if arr.ndim == 0:
        arr = arr.reshape(1)
    if arr.ndim != 1:
        raise ValueError(f"{name}: beat times must be 1-D (seconds), got shape {arr.shape}")
    if not np.all(np.isfinite(arr)) or np.any(arr < 0):
        raise ValueError(f"{name}: beat times must be finite and >= 0 seconds")
    return arr


def as_waveform(audio: Any, sr: Any, name: str = "audio") -> tuple[np.ndarray, int]:
    """Validate a waveform ``(S,)`` or multichannel ``(C, S)`` and its sample rate.

    Returns a mono float32 waveform (channel mean, as ``librosa.to_mono``) and ``int(sr)``.
    """
    arr = np.asarray(audio)
    if not np.issubdtype(arr.dtype, np.floating):
        raise ValueError(f"{name}: expected a float waveform in [-1, 1], got dtype {arr.dtype}")
    if arr.ndim == 2:
        if arr.shape[0] > arr.shape[1]:
            raise ValueError(
                f"{name}: multichannel audio must be (channels, samples), got {arr.shape}; transpose it"
            )
        arr = np.mean(arr, axis=0)
    elif arr.ndim != 1:
        raise ValueError(f"{name}: expected a waveform of shape (S,) or (C, S), got shape {arr.shape}")
    if arr.size == 0:
        raise ValueError(f"{name}: the waveform is empty")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{name}: contains NaN or infinite samples")
    try:
        rate = int(sr)
    except (TypeError, ValueError):
        raise ValueError(f"{name}: sample rate must be a positive integer, got {sr!r}") from None
    if rate <= 0 or rate != sr:
        raise ValueError(f"{name}: sample rate must be a positive integer in Hz, got {sr!r}")
    return arr.astype(np.float32, copy=False), rate
