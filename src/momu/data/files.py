"""Dataset file readers with clear errors: every per-file problem is a :class:`DataFileError`.

A ``DataFileError`` (a ``ValueError``) starts its message with the offending file, so
``momu data check`` can list each bad file with its reason; a file that does not exist raises
:class:`MissingDataFileError`, which is also a ``FileNotFoundError``. ``.npy`` files are checked
from their header before anything is allocated; audio is decoded with libsndfile
(:data:`momu.data.common.AUDIO_SUFFIXES`). :mod:`momu.data.common` re-exports every name here.
"""

from __future__ import annotations

import errno
import os
from collections.abc import Collection
from pathlib import Path
from typing import Any

import numpy as np

from momu.data.safe_pickle import UnsafePickleError, safe_load
from momu.io import read_json

__all__ = [
    "DataFileError",
    "MissingDataFileError",
    "printable",
    "read_lines",
    "read_json_file",
    "absent_reason",
    "npy_header",
    "read_npy_header",
    "npy_nbytes",
    "load_npy",
    "read_pickle",
    "read_pickle_dict",
    "audio_info",
    "load_audio",
]


def printable(text: object) -> str:
    """``text`` with any undecodable file-name bytes shown as ``\\xNN`` (safe to print or write as JSON)."""
    return str(text).encode("utf-8", "surrogateescape").decode("utf-8", "backslashreplace")


class DataFileError(ValueError):
    """A dataset file that cannot be used; ``str(err)`` is ``"<path>: <reason>"``.

    Attributes:
        path: the offending file (or folder).
        reason: what is wrong with it.
    """

    def __init__(self, path: str | Path, reason: str) -> None:
        self.path = Path(path)
        self.reason = reason
        super().__init__(f"{path}: {reason}")

    def __reduce__(self) -> tuple[Any, ...]:  # keep (path, reason) through multiprocessing
        return (type(self), (self.path, self.reason))


class MissingDataFileError(DataFileError, FileNotFoundError):
    """A file the layout requires does not exist."""


def read_lines(path: str | Path) -> list[str]:
    """The non-empty lines of a text file (split files, ignore lists, descriptions), stripped."""
    path = Path(path)
    if not path.is_file():
        raise _missing(path)
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise DataFileError(path, f"cannot read as UTF-8 text ({exc})") from None
    lines = (line.strip() for line in text.splitlines())
    return [line for line in lines if line]


def read_json_file(path: str | Path) -> Any:
    """Parse a JSON file; a missing or unreadable file raises :class:`DataFileError`."""
    path = Path(path)
    if not path.is_file():
        raise _missing(path)
    try:
        return read_json(path)
    except (OSError, ValueError) as exc:
        reason = str(exc)
        prefix = f"{path}: "
        raise DataFileError(path, reason[len(prefix) :] if reason.startswith(prefix) else reason) from None


def absent_reason(path: str | Path, what: str = "file") -> str:
    """Why ``path`` cannot be opened as a ``what``: not found, a folder, a broken link, a link loop."""
    path = Path(path)
    try:
        os.stat(path)
    except OSError as exc:
        if exc.errno == errno.ELOOP:
            return "symbolic link loop"
        if path.is_symlink():
            return f"broken symbolic link (points to {os.readlink(path)})"
        if exc.errno == errno.EACCES:
            return "permission denied"
        return f"{what} not found"
    if path.is_dir():
        return f"is a folder, expected a {what}"
    return f"{what} not found"


def _missing(path: Path, what: str = "file") -> MissingDataFileError:
    return MissingDataFileError(path, absent_reason(path, what))


def read_npy_header(fh: Any, path: str | Path) -> tuple[tuple[int, ...], bool, np.dtype[Any]]:
    """``(shape, fortran_order, dtype)`` of the ``.npy`` stream ``fh`` (left at its data); nothing is
    allocated. Raises :class:`DataFileError` naming ``path``: no NUMPY magic, a corrupt header, an
    object dtype (pickled Python objects)."""
    magic = fh.read(6)
    if magic != b"\x93NUMPY":
        raise DataFileError(path, "not a .npy file (no NUMPY header)" if magic else "empty file (0 bytes)")
    try:
        version = (fh.read(1) or b"\x00")[0], (fh.read(1) or b"\x00")[0]
        if version == (1, 0):
            shape, fortran, dtype = np.lib.format.read_array_header_1_0(fh)
        elif version in ((2, 0), (3, 0)):
            shape, fortran, dtype = np.lib.format.read_array_header_2_0(fh)
        else:
            raise ValueError(f"version {version}")
    except (ValueError, EOFError, OSError, SyntaxError) as exc:
        raise DataFileError(path, f"not a valid .npy file (corrupt header: {exc})") from None
    if dtype.hasobject:
        raise DataFileError(path, "holds pickled Python objects; refusing to load (expected a numeric array)")
    return tuple(int(n) for n in shape), bool(fortran), dtype


def npy_nbytes(shape: tuple[int, ...], dtype: np.dtype[Any]) -> int:
    """Bytes of data a ``.npy`` header declares (Python integers: no overflow)."""
    count = 1
    for n in shape:
        count *= int(n)
    return count * int(dtype.itemsize)


def npy_header(path: str | Path) -> tuple[tuple[int, ...], np.dtype[Any], int]:
    """``(shape, dtype, data offset)`` from a ``.npy`` header, checked against the file's size.

    Nothing is allocated: a header declaring more data than the file holds (truncated or crafted)
    is refused before ``np.load`` would allocate it.

    Raises:
        DataFileError: not a ``.npy`` file, a corrupt header, an object dtype, or a size mismatch.
    """
    path = Path(path)
    size = path.stat().st_size
    with open(path, "rb") as fh:
        shape, _, dtype = read_npy_header(fh, path)
        offset = fh.tell()
    expected = npy_nbytes(shape, dtype)
    if expected != size - offset:
        raise DataFileError(
            path,
            f"not a valid .npy file (truncated or corrupt: the header declares {expected} bytes of data, "
            f"the file holds {size - offset})",
        )
    return tuple(int(n) for n in shape), dtype, offset


def load_npy(path: str | Path, max_bytes: int | None = None) -> np.ndarray:
    """Load a numeric ``.npy`` array without admitting pickled objects; errors name the file.

    The header is checked first (:func:`npy_header`), so a corrupt or truncated file is "not a
    valid .npy file" and nothing larger than the file is ever allocated; ``max_bytes`` refuses a
    larger array too.
    """
    path = Path(path)
    if not path.is_file():
        raise _missing(path)
    shape, dtype, _ = npy_header(path)
    if max_bytes is not None and npy_nbytes(shape, dtype) > max_bytes:
        raise DataFileError(
            path,
            f"holds a {shape} {dtype} array of {npy_nbytes(shape, dtype)} bytes, more than the "
            f"{max_bytes}-byte limit",
        )
    if not np.issubdtype(dtype, np.number):
        raise DataFileError(path, f"expected a numeric array, got dtype {dtype}")
    try:
        array = np.load(path, allow_pickle=False)
    except (ValueError, OSError, EOFError) as exc:
        raise DataFileError(path, f"not a valid .npy file ({exc})") from None
    return array


def read_pickle(path: str | Path, max_bytes: int, records: Collection[tuple[str, str]] = ()) -> Any:
    """A pickle read with :mod:`momu.data.safe_pickle` (``records``: foreign classes admitted as
    plain state, e.g. SMPL's chumpy arrays), never ``pickle.load``.

    Raises:
        MissingDataFileError: no such file.
        DataFileError: a forbidden global, a memory bomb or an unreadable pickle.
    """
    path = Path(path)
    if not path.is_file():
        raise _missing(path)
    try:
        return safe_load(path, max_bytes=max_bytes, records=records)
    except UnsafePickleError as exc:
        reason = str(exc)
        raise DataFileError(
            path, reason.split(": ", 1)[1] if reason.startswith(str(path)) else reason
        ) from None


def read_pickle_dict(
    path: str | Path, max_bytes: int, records: Collection[tuple[str, str]] = ()
) -> dict[str, Any]:
    """:func:`read_pickle` of a file that must hold a dict (else :class:`DataFileError`)."""
    data = read_pickle(path, max_bytes, records)
    if not isinstance(data, dict):
        raise DataFileError(path, f"expected a pickled dict, got {type(data).__name__}")
    return data


def audio_info(path: str | Path) -> tuple[int, int]:
    """``(sample_rate, num_frames)`` of an audio file without decoding it."""
    import soundfile as sf

    path = Path(path)
    if not path.is_file():
        raise _missing(path, "audio file")
    if path.stat().st_size == 0:
        raise DataFileError(path, "empty audio file (0 bytes)")
    try:
        info = sf.info(os.fsencode(path))  # bytes: names that are not UTF-8 open too
    except Exception as exc:  # libsndfile raises its own error types (LibsndfileError, RuntimeError)
        raise DataFileError(path, f"cannot decode audio ({_sf_reason(exc)})") from None
    return int(info.samplerate), int(info.frames)


def _sf_reason(exc: BaseException) -> str:
    text = str(exc).strip().splitlines()[-1] if str(exc).strip() else type(exc).__name__
    return text.replace("Error opening", "error opening")


def load_audio(
    path: str | Path,
    *,
    sample_rate: int | None = None,
    offset: float = 0.0,
    duration: float | None = None,
) -> tuple[np.ndarray, int]:
    """Decode a mono float32 waveform in [-1, 1] (channels averaged), optionally resampled.

    Only ``[offset, offset + duration)`` seconds are decoded (soundfile seeks, also in MP3s).
    When the file ends before ``offset + duration`` the available part is returned; callers
    compare lengths with :func:`check_length_match`.

    Args:
        path: wav / flac / ogg / mp3 file (anything libsndfile decodes).
        sample_rate: target rate in Hz (soxr HQ resampling); ``None`` keeps the file's rate.
        offset: start, seconds from the beginning of the file (>= 0).
        duration: seconds to read (``None``: to the end).

    Returns:
        ``(audio (S,), sample_rate)``.

    Raises:
        MissingDataFileError: no such file.
        DataFileError: undecodable or empty file, ``offset`` past the end, non-finite samples.
    """
    import soundfile as sf

    path = Path(path)
    if not path.is_file():
        raise _missing(path, "audio file")
    if offset < 0:
        raise DataFileError(path, f"negative audio offset {offset} s")
    if path.stat().st_size == 0:
        raise DataFileError(path, "empty audio file (0 bytes)")
    try:
        with sf.SoundFile(os.fsencode(path)) as f:
            sr = int(f.samplerate)
            total = int(f.frames)
            if total <= 0:
                raise DataFileError(path, "empty audio (0 samples)")
            start = int(round(offset * sr))
            if start >= total:
                raise DataFileError(
                    path, f"audio is {total / sr:.2f} s long; cannot start reading at {offset:.2f} s"
                )
            count = total - start if duration is None else min(total - start, int(round(duration * sr)))
            if start:
                f.seek(start)
            data = f.read(count, dtype="float32", always_2d=True)
    except DataFileError:
        raise
    except Exception as exc:  # LibsndfileError / RuntimeError / ValueError from the decoder
        raise DataFileError(path, f"cannot decode audio ({_sf_reason(exc)})") from None
    if data.shape[0] == 0:
        raise DataFileError(path, "empty audio (no samples could be decoded)")
    audio = data.mean(axis=1, dtype=np.float32)
    if not np.all(np.isfinite(audio)):
        raise DataFileError(path, f"{int(np.count_nonzero(~np.isfinite(audio)))} non-finite audio samples")
    if sample_rate is not None and int(sample_rate) != sr:
        if sample_rate <= 0:
            raise ValueError(f"sample_rate must be positive, got {sample_rate}")
        from momu.features.audio import resample

        audio = resample(audio, sr, int(sample_rate))
        sr = int(sample_rate)
    return np.ascontiguousarray(audio, dtype=np.float32), sr


# --------------------------------------------------------------------------------- keypoints
