"""Audio preparation exactly as the reference metric scripts get it from ``librosa.load``.

``librosa.load(path, sr=R)`` decodes with soundfile, averages channels (``to_mono``) and then
resamples with ``soxr_hq``. The metric functions take waveforms, so they repeat the last two
steps here; given the same decoded samples they see the same signal as the reference.
"""

from __future__ import annotations

from pathlib import Path

import librosa
import numpy as np
import soundfile as sf

from momu.metrics._checks import as_waveform

__all__ = ["prepare_audio", "read_audio"]


def prepare_audio(audio: np.ndarray, sr: int, target_sr: int, name: str = "audio") -> np.ndarray:
    """Mono float32 waveform at ``target_sr`` Hz (``soxr_hq`` resampling, as ``librosa.load``)."""
    mono, rate = as_waveform(audio, sr, name)
    if rate == target_sr:
        return mono
    return np.asarray(librosa.resample(mono, orig_sr=rate, target_sr=target_sr, res_type="soxr_hq"))


def read_audio(path: str | Path) -> tuple[np.ndarray, int]:
    """Decode an audio file to a mono float32 waveform at its native rate.

    Raises:
        FileNotFoundError: the file does not exist.
        ValueError: the file cannot be decoded or holds no samples.
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"{path}: audio file not found")
    try:
        data, sr = sf.read(str(path), dtype="float32", always_2d=True)
    except Exception as exc:  # soundfile raises its own error types
        raise ValueError(f"{path}: cannot decode audio: {exc}") from None
    if data.shape[0] == 0:
        raise ValueError(f"{path}: the audio file holds no samples")
    mono = data.mean(axis=1, dtype=np.float32) if data.shape[1] > 1 else data[:, 0]
    return np.ascontiguousarray(mono), int(sr)
