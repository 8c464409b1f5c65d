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

__all__ = ["prepare_audio", "read_audio", "warm_librosa_kernels"]


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


def warm_librosa_kernels() -> None:
    """Compile (or load from numba's cache) the librosa kernels the metrics use, in this process.

    librosa caches its numba kernels on disk (``cache=True``), and numba writes a ``@guvectorize``
    kernel as two files with no lock between them: processes that fill a cold cache at the same time
    can load a mismatched pair and die with a segmentation fault (numba/numba#10128, seen as
    librosa/librosa#1998 in ``beat_track``). Calling this once before starting worker processes fills
    the cache from one process, so the workers only read it.
    """
    sr, hop = 22050, 512
    y = np.random.default_rng(0).standard_normal(sr).astype(np.float32) * 0.1
    envelope = librosa.onset.onset_strength(y=y, sr=sr, hop_length=hop)
    librosa.onset.onset_detect(onset_envelope=envelope, sr=sr, hop_length=hop, backtrack=True)
    librosa.beat.beat_track(onset_envelope=envelope, sr=sr, hop_length=hop)
    librosa.util.peak_pick(envelope, pre_max=3, post_max=3, pre_avg=3, post_avg=3, delta=0.2, wait=1)
