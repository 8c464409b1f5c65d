"""``momu generate``: the user's song — decoded, checked and warned about before any model is loaded.

:func:`read_song` decodes wav, flac, ogg, opus and mp3 with libsndfile and anything else (m4a, aac ...)
with ffmpeg (within time limits, :mod:`momu.render.ffmpeg`), reading only what is used: at most
:data:`MAX_SONG_SECONDS`, or ``--seconds``. What it refuses (one line, exit status 2):

* a file that is not decodable audio (neither libsndfile nor ffmpeg decodes it), or holds no samples;
* NaN or infinite samples;
* a song longer than :data:`MAX_SONG_SECONDS` without ``--seconds``; a ``--seconds`` outside
  [:data:`MIN_SECONDS`, :data:`MAX_SONG_SECONDS`]; a song shorter than :data:`MIN_SECONDS`;
* a corrupt or truncated file: fewer samples decode than the file declares (an mp3's header
  says its length) — unless ``--seconds`` uses only the part that decodes.

What it mends, with a warning: a float file whose samples go beyond full scale (±1) is scaled down
to peak at ±1 (its loudness relative to other songs is lost, its shape is kept; clipping would
distort it and ffmpeg's AAC encoder can spin forever on samples around ±1e6).

:func:`song_warnings` logs the soft problems: very short, silent, an unusual sample rate.
"""

from __future__ import annotations

import contextlib
import logging
import os
import sys
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from momu.cli.generate_errors import GenerateInputError

__all__ = [
    "Song",
    "read_song",
    "song_warnings",
    "check_seconds",
    "MAX_SONG_SECONDS",
    "MIN_SECONDS",
]

log = logging.getLogger(__name__)

MAX_SONG_SECONDS = 600.0
"""Longest song or motion (10 minutes); ``--seconds`` uses the beginning of a longer one."""
MIN_SECONDS = 0.5
"""Shortest song, motion or ``--seconds`` (a few motion frames, a few spectrogram frames)."""
SHORT_SONG_SECONDS = 2.0
"""Songs shorter than this get a warning (the model's beats need a few bars)."""
SILENCE_RMS = 1e-4
"""A song whose RMS is below this (full scale 1) is called silent."""
USUAL_RATES = (8000, 96000)
"""Sample rates outside this range (Hz) get a warning: far from the 16 kHz music the models train on."""
SHORT_DECODE_S = 0.5
"""A decode this much shorter (s) than the file declares (and 1 % of it) is a corrupt or truncated file."""
_BLOCK_S = 0.5
"""Decoding reads blocks this long: a corrupt frame loses at most one block before it is noticed."""


@dataclass(frozen=True)
class Song:
    """A decoded song at its own rate, samples in [-1, 1].

    Attributes:
        audio: ``(S,)`` float32 mono mixdown (what the models hear).
        sample_rate: the file's rate (Hz).
        channels: channels in the file.
        duration: seconds of ``audio`` (after any ``--seconds`` cut).
        file_duration: seconds in the file (as far as it was read: at most the limit plus a little).
        path: the file.
        track: ``(S, channels)`` float32, the song as it sounds (the mp4's sound track); ``None``:
            ``audio``.
    """

    audio: np.ndarray
    sample_rate: int
    channels: int
    duration: float
    file_duration: float
    path: Path
    track: np.ndarray | None = None


def check_seconds(seconds: float | None, option: str = "--seconds") -> float | None:
    """``seconds`` checked: finite, in [:data:`MIN_SECONDS`, :data:`MAX_SONG_SECONDS`] (``None`` passes)."""
    if seconds is None:
        return None
    if not np.isfinite(seconds):
        raise GenerateInputError(f"{option} must be a finite number of seconds, got {seconds}")
    if seconds < MIN_SECONDS:
        raise GenerateInputError(f"{option} {seconds:g} is shorter than the {MIN_SECONDS:g} s minimum")
    if seconds > MAX_SONG_SECONDS:
        raise GenerateInputError(
            f"{option} {seconds:g} is longer than the {MAX_SONG_SECONDS:g} s (10-minute) limit"
        )
    return float(seconds)


@contextlib.contextmanager
def _c_stderr_silenced() -> Iterator[None]:
    """Silence what C libraries print on file descriptor 2 (libmpg123's resync notes) in the block."""
    fd = 2
    with contextlib.suppress(AttributeError, OSError, ValueError):
        sys.stderr.flush()
    try:
        saved = os.dup(fd)
    except OSError:  # no file descriptor 2: nothing to silence
        yield
        return
    try:
        with open(os.devnull, "wb") as null:
            os.dup2(null.fileno(), fd)
            yield
    finally:
        os.dup2(saved, fd)
        os.close(saved)


@dataclass(frozen=True)
class _Decoded:
    audio: np.ndarray  # (S, C) float32
    sample_rate: int
    declared: int | None  # frames the file says it holds (libsndfile), None when unknown
    error: str | None  # why decoding stopped early


def _decode_soundfile(path: Path, seconds: float | None) -> _Decoded | None:
    """libsndfile, block by block up to the limit; ``None`` when it cannot open the file."""
    import soundfile as sf

    try:
        f = sf.SoundFile(os.fsencode(path))
    except Exception:  # LibsndfileError / RuntimeError / TypeError: not a format libsndfile knows
        return None
    with f:
        sr, declared = int(f.samplerate), int(f.frames)
        if sr <= 0:
            return None
        if seconds is None and declared / sr > MAX_SONG_SECONDS:
            raise GenerateInputError(_too_long(path, declared / sr))
        want = max(0, min(declared, int(round((seconds or MAX_SONG_SECONDS) * sr))))
        audio = np.empty((want, max(1, f.channels)), dtype=np.float32)
        got, error = 0, None
        while got < want:
            n = min(int(_BLOCK_S * sr), want - got)
            try:
                block = f.read(n, dtype="float32", always_2d=True, out=audio[got : got + n])
            except Exception as exc:  # a corrupt frame libmpg123 cannot resync past
                error = str(exc).strip().splitlines()[-1] if str(exc).strip() else type(exc).__name__
                break
            if block.shape[0] == 0:
                break
            got += block.shape[0]
    return _Decoded(audio[:got], sr, declared, error)


def _decode_ffmpeg(path: Path, seconds: float | None) -> _Decoded:
    """Any format ffmpeg decodes, as float WAV, at most the limit (+1 s to tell a longer song)."""
    import io

    import soundfile as sf

    from momu.render.ffmpeg import CPU_BASE_S, CPU_PER_AUDIO_S, WALL_BASE_S, FfmpegError, run_ffmpeg

    limit = seconds if seconds is not None else MAX_SONG_SECONDS + 1.0
    args = ["-v", "error", "-i", str(path), "-t", f"{limit:.3f}", "-f", "wav", "-c:a", "pcm_f32le", "-"]
    cpu = CPU_BASE_S + CPU_PER_AUDIO_S * limit
    try:
        out, messages = run_ffmpeg(
            args, what=f"decoding {path}", cpu_seconds=cpu, wall_seconds=WALL_BASE_S + 2 * cpu
        )
        audio, sr = sf.read(io.BytesIO(out), dtype="float32", always_2d=True)
    except FfmpegError as exc:
        reason = str(exc).strip().splitlines()[-1] if str(exc).strip() else "no output"
        raise GenerateInputError(
            f"--music {path}: cannot read audio: not a decodable audio file ({reason})"
        ) from None
    except (RuntimeError, ValueError, TypeError):  # no WAV on ffmpeg's output
        raise GenerateInputError(
            f"--music {path}: cannot read audio: not a decodable audio file (no audio stream)"
        ) from None
    if messages:
        log.warning("--music %s: ffmpeg reported errors decoding it: %s", path, messages.splitlines()[0])
    return _Decoded(audio, int(sr), None, None)


def _too_long(path: Path, seconds: float) -> str:
    return (
        f"--music {path}: {seconds:.0f} s is longer than the {MAX_SONG_SECONDS:.0f} s (10-minute) limit; "
        "pass --seconds to use its beginning"
    )


def _check_complete(path: Path, got: _Decoded, seconds: float | None) -> None:
    """Refuse a decode that ends well before what the file declares (corrupt or truncated)."""
    if got.declared is None:
        return
    sr = got.sample_rate
    want = min(got.declared, int(round((seconds or MAX_SONG_SECONDS) * sr)))
    missing = want - got.audio.shape[0]
    if missing <= max(SHORT_DECODE_S * sr, 0.01 * want):
        return
    have = got.audio.shape[0] / sr
    why = f"decoding stopped: {got.error}" if got.error else "the stream ends early"
    hint = (
        f", or pass --seconds {np.floor(have * 10) / 10:g} to use the part that decodes"
        if have >= MIN_SECONDS
        else ""
    )
    raise GenerateInputError(
        f"--music {path}: only {have:.1f} s of the {got.declared / sr:.1f} s the file declares could be "
        f"decoded ({why}); the file is corrupt or truncated: repair or re-encode it{hint}"
    )


def read_song(path: Path, seconds: float | None = None) -> Song:
    """Decode and check a song (module docstring); ``seconds``: use only its beginning.

    Raises:
        GenerateInputError: see the module docstring.
    """
    seconds = check_seconds(seconds)
    if not path.exists():
        raise GenerateInputError(f"--music {path}: file not found")
    if not path.is_file():
        raise GenerateInputError(f"--music {path}: not a file")
    if path.stat().st_size == 0:
        raise GenerateInputError(f"--music {path}: empty file (0 bytes), not audio")
    with _c_stderr_silenced():
        got = _decode_soundfile(path, seconds)
    if got is None:
        got = _decode_ffmpeg(path, seconds)
    _check_complete(path, got, seconds)
    if got.audio.size == 0:
        raise GenerateInputError(f"--music {path}: the file holds no audio samples")
    audio, sr = got.audio, got.sample_rate
    bad = int(np.count_nonzero(~np.isfinite(audio)))
    if bad:
        raise GenerateInputError(f"--music {path}: {bad} audio samples are NaN or infinite")
    file_duration = (got.declared if got.declared else audio.shape[0]) / sr
    if seconds is None and audio.shape[0] / sr > MAX_SONG_SECONDS:
        raise GenerateInputError(_too_long(path, audio.shape[0] / sr))
    if seconds is not None:
        audio = audio[: int(round(seconds * sr))]
    if audio.shape[0] / sr < MIN_SECONDS:
        raise GenerateInputError(
            f"--music {path}: too short: only {audio.shape[0] / sr:.2f} s of audio; "
            f"momu needs at least {MIN_SECONDS:g} s"
        )
    peak = max(float(audio.max()), -float(audio.min()))
    if peak > 1.0:
        log.warning(
            "--music %s: samples reach ±%.3g, beyond full scale (±1); scaled down by %.3g to fit",
            path,
            peak,
            peak,
        )
        audio = (audio.astype(np.float64) / peak).astype(np.float32)
    mono = audio.mean(axis=1, dtype=np.float32) if audio.shape[1] > 1 else audio[:, 0].copy()
    return Song(mono, sr, int(audio.shape[1]), mono.shape[0] / sr, file_duration, path, audio)


def song_warnings(song: Song) -> list[str]:
    """Warnings (also logged) for a song that is very short, silent, or at an unusual sample rate."""
    out = []
    if song.duration < SHORT_SONG_SECONDS:
        out.append(
            f"{song.path}: only {song.duration:.2f} s long; dances under {SHORT_SONG_SECONDS:g} s show little"
        )
    rms = float(np.sqrt(np.mean(np.square(song.audio.astype(np.float64))))) if song.audio.size else 0.0
    if rms < SILENCE_RMS:
        out.append(f"{song.path}: the audio is silent (RMS {rms:.1e}); the dance will not follow any beat")
    if not USUAL_RATES[0] <= song.sample_rate <= USUAL_RATES[1]:
        out.append(
            f"{song.path}: sample rate {song.sample_rate} Hz is far outside the models' 16 kHz training "
            f"music (usual range {USUAL_RATES[0]}-{USUAL_RATES[1]} Hz); it is resampled"
        )
    for line in out:
        log.warning("%s", line)
    return out
