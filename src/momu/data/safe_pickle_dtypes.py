"""numpy dtypes from a pickle, rebuilt through numpy's public constructor instead of ``__setstate__``.

A pickled dtype is ``numpy.dtype(typestr, align, copy)`` followed by a BUILD whose state sets its
byte order, item size, alignment, flags, fields and sub-array. ``dtype.__setstate__`` trusts that
state: an item size larger than the type's, a field whose offset lies past the item, or the
"holds Python objects" flag on a plain number type gives arrays that read and write outside their
memory, or crash the process. And with ``copy=False`` the dtype is numpy's shared built-in one, so a
BUILD would change ``float64`` for the whole process.

:func:`rebuild_dtype` never calls ``__setstate__``: it checks the state against what numpy's own
pickles hold — plain numbers (``b i u f c``) with their own size, byte strings (``S``), unicode (``U``,
4 bytes a character), raw bytes (``V``), structured dtypes whose fields all lie inside the item,
sub-arrays whose size is their base's times their shape — and builds a new dtype from the checked
description with the public constructor (which computes alignment and flags itself). Anything else
raises :class:`DtypeStateError`.
"""

from __future__ import annotations

from typing import Any

import numpy as np

__all__ = ["DtypeStateError", "rebuild_dtype", "DTYPE_KINDS"]

DTYPE_KINDS = frozenset("biufcSUV")
"""The dtype kinds a pickle may hold: booleans, integers, floats, complex, bytes, unicode, raw/structured."""
_ALIGNED_STRUCT = 0x80  # NPY_ALIGNED_STRUCT: the struct was made with align=True


class DtypeStateError(ValueError):
    """A pickled dtype state numpy's own pickles never hold (the reason says what)."""


def _int(value: Any, what: str) -> int:
    if not isinstance(value, (int, np.integer)) or isinstance(value, (bool, np.bool_)):
        raise DtypeStateError(f"a dtype {what} of type {type(value).__name__}")
    return int(value)


def _subarray(sub: Any, elsize: int) -> np.dtype[Any]:
    if not (isinstance(sub, tuple) and len(sub) == 2 and isinstance(sub[0], np.dtype)):
        raise DtypeStateError(f"a dtype sub-array {type(sub).__name__}")
    base, shape = sub
    shape = (shape,) if isinstance(shape, (int, np.integer)) else shape
    if not isinstance(shape, tuple) or not shape:
        raise DtypeStateError(f"a dtype sub-array shape {shape!r}")
    dims = [_int(n, "sub-array dimension") for n in shape]
    if any(n < 0 for n in dims):
        raise DtypeStateError(f"a dtype sub-array shape {shape!r}")
    new = np.dtype((base, tuple(dims)))
    if elsize not in (-1, new.itemsize):
        raise DtypeStateError(f"a sub-array dtype of {new.itemsize} bytes declaring {elsize}")
    return new


def _structured(names: Any, fields: Any, elsize: int, flags: int) -> np.dtype[Any]:
    if not isinstance(names, tuple) or not all(isinstance(n, str) for n in names) or not names:
        raise DtypeStateError("structured dtype names that are not a tuple of strings")
    if not isinstance(fields, dict) or not set(names) <= set(fields):
        raise DtypeStateError("structured dtype fields that do not match its names")
    if elsize < 0:
        raise DtypeStateError(f"a structured dtype of {elsize} bytes")
    formats, offsets, titles = [], [], []
    for name in names:
        entry = fields[name]
        if not isinstance(entry, tuple) or len(entry) not in (2, 3) or not isinstance(entry[0], np.dtype):
            raise DtypeStateError(f"structured dtype field {name!r}: {type(entry).__name__}")
        offset = _int(entry[1], "field offset")
        title = entry[2] if len(entry) == 3 else None
        if title is not None and not isinstance(title, str):
            raise DtypeStateError(f"structured dtype field {name!r}: a title of type {type(title).__name__}")
        if offset < 0 or offset + entry[0].itemsize > elsize:
            raise DtypeStateError(
                f"structured dtype field {name!r} at bytes {offset}..{offset + entry[0].itemsize} of a "
                f"{elsize}-byte item"
            )
        formats.append(entry[0])
        offsets.append(offset)
        titles.append(title)
    spec: Any = {"names": list(names), "formats": formats, "offsets": offsets, "itemsize": elsize}
    if any(t is not None for t in titles):
        spec["titles"] = titles
    try:
        return np.dtype(spec, align=bool(flags & _ALIGNED_STRUCT))
    except (ValueError, TypeError):
        return np.dtype(spec)


def _flexible(base: np.dtype[Any], endian: str, elsize: int) -> np.dtype[Any]:
    size = base.itemsize if elsize == -1 else elsize
    if size < 0 or (base.kind == "U" and size % 4):
        raise DtypeStateError(f"a {base.kind} dtype of {size} bytes")
    new = np.dtype(f"{base.kind}{size // 4 if base.kind == 'U' else size}")
    return new.newbyteorder("<" if endian == "<" else ">") if base.kind == "U" and endian in "<>" else new


def rebuild_dtype(base: Any, state: Any) -> np.dtype[Any]:
    """A new dtype equal to ``base`` with pickled ``state`` applied, built without ``__setstate__``.

    Raises:
        DtypeStateError: ``base`` is not a dtype of :data:`DTYPE_KINDS`, or ``state`` is not what
            numpy's pickles hold (module docstring).
    """
    if not isinstance(base, np.dtype) or base.kind not in DTYPE_KINDS or base.hasobject:
        raise DtypeStateError(f"a dtype of kind {getattr(base, 'kind', type(base).__name__)!r}")
    if not isinstance(state, tuple) or len(state) not in (8, 9) or state[0] not in (3, 4):
        raise DtypeStateError(
            f"a dtype state {type(state).__name__} of length {len(state) if isinstance(state, tuple) else 0}"
        )
    _, endian, sub, names, fields, elsize, alignment, flags = state[:8]
    if endian not in ("<", ">", "|", "="):
        raise DtypeStateError(f"a dtype byte order {endian!r}")
    elsize, flags = _int(elsize, "item size"), _int(flags, "flags")
    _int(alignment, "alignment")  # recomputed by the constructor
    if sub is not None:
        if names is not None or fields is not None:
            raise DtypeStateError("a dtype that is both a sub-array and structured")
        return _subarray(sub, elsize)
    if names is not None or fields is not None:
        if base.kind != "V":
            raise DtypeStateError(f"fields on a dtype of kind {base.kind!r}")
        return _structured(names, fields, elsize, flags)
    if base.kind in "SUV":
        return _flexible(base, endian, elsize)
    if elsize not in (-1, base.itemsize):
        raise DtypeStateError(f"a {base} dtype declaring {elsize}-byte items")
    if endian in "<>":
        return base.newbyteorder("<" if endian == "<" else ">")
    return np.dtype(base.str)
