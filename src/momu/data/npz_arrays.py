"""Read single arrays from a ``.npz`` archive lazily, with bounded memory.

``np.load(path)[key]`` trusts the archive: a 2 MB zip of zeros can inflate to gigabytes, and reading
every member to find the one needed inflates them all. :func:`read_npz_array` opens only the member
asked for, reads its ``.npy`` header from the compressed stream, and refuses — before inflating any
data — a member whose declared (zip) or header-declared size is over ``max_bytes``, or whose header
disagrees with the size the zip declares; it then reads exactly the declared bytes (the zip reader
stops at the declared size and checks the CRC), so no more than ``max_bytes`` is ever allocated.
Errors are :class:`~momu.data.files.DataFileError` lines naming the file and the array.
"""

from __future__ import annotations

import zipfile
import zlib
from pathlib import Path
from typing import Any

import numpy as np

from momu.data.files import DataFileError, npy_nbytes, read_npy_header

__all__ = ["npz_keys", "read_npz_array", "NPY_HEADER_MAX"]

NPY_HEADER_MAX = 65_536
"""Largest ``.npy`` header accepted in a member (numpy's own reader stops at 10 000 bytes)."""


def _zip(path: Path) -> zipfile.ZipFile:
    try:
        return zipfile.ZipFile(path)
    except (zipfile.BadZipFile, OSError, ValueError, EOFError) as exc:
        raise DataFileError(path, f"not a plain .npz archive ({exc})") from None


def npz_keys(path: str | Path) -> list[str]:
    """The array names in a ``.npz`` archive (members ``<name>.npy``), without reading any data."""
    path = Path(path)
    with _zip(path) as zf:
        return [n[: -len(".npy")] for n in zf.namelist() if n.endswith(".npy")]


def read_npz_array(path: str | Path, key: str, max_bytes: int) -> np.ndarray:
    """The array ``key`` of a ``.npz`` archive, read alone and within ``max_bytes`` (module docstring).

    The result may be read-only (it is a view of the bytes read).

    Raises:
        DataFileError: no such array, a corrupt or truncated member, an object dtype, a complex or
            zero-size item, or more than ``max_bytes`` of data.
    """
    path = Path(path)
    where = f"array {key!r}"
    with _zip(path) as zf:
        try:
            info = zf.getinfo(f"{key}.npy")
        except KeyError:
            raise DataFileError(path, f"no {where}") from None
        if info.file_size > max_bytes + NPY_HEADER_MAX:
            raise DataFileError(
                path, f"{where} is {info.file_size} bytes uncompressed, more than the {max_bytes}-byte limit"
            )
        try:
            with zf.open(info) as fh:
                shape, fortran, dtype = read_npy_header(fh, f"{path} ({where})")
                nbytes = npy_nbytes(shape, dtype)
                if nbytes > max_bytes:
                    raise DataFileError(
                        path,
                        f"{where} declares {shape} {dtype}: {nbytes} bytes, "
                        f"more than the {max_bytes}-byte limit",
                    )
                if dtype.itemsize == 0:
                    raise DataFileError(path, f"{where} has items of 0 bytes (dtype {dtype})")
                if info.file_size - fh.tell() != nbytes:
                    raise DataFileError(
                        path,
                        f"{where} is truncated or corrupt: its header declares {nbytes} bytes of data, the "
                        f"archive holds {info.file_size - fh.tell()}",
                    )
                data = fh.read(nbytes)
                fh.read(1)  # reach the end: the zip reader checks the CRC
        except (zipfile.BadZipFile, zlib.error, EOFError, OSError, ValueError) as exc:
            if isinstance(exc, DataFileError):
                raise
            raise DataFileError(path, f"{where} is corrupt ({exc})") from None
    if len(data) != nbytes:
        raise DataFileError(path, f"{where} is truncated: {len(data)} of {nbytes} bytes")
    array: Any = np.frombuffer(data, dtype=dtype)
    return array.reshape(shape, order="F" if fortran else "C")
