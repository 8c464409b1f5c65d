"""A restricted unpickler for the pickles real datasets ship (AIST++ annotations).

Python's :mod:`pickle` runs whatever callable a file names, so ``pickle.load`` on a downloaded
file is arbitrary code execution. AIST++ distributes its motions and keypoints as pickles of
plain dicts of numpy arrays, so momu reads them through :class:`RestrictedUnpickler`, which
resolves only a fixed allow-list of globals:

* numpy's array / dtype / scalar reconstructors (``numpy.core.multiarray._reconstruct``,
  ``numpy._core.multiarray._reconstruct``, ``numpy.ndarray``, ``numpy.dtype``,
  ``numpy.core.multiarray.scalar``, ``numpy.core.numeric._frombuffer`` and their
  ``numpy._core`` spellings for pickles written by numpy >= 2);
* plain containers that need a global in the pickle stream (``set``, ``frozenset``, ``bytes``,
  ``bytearray``, ``complex``, ``collections.OrderedDict``);
* ``_codecs.encode``, which Python 3 emits for ``bytes`` in protocol-2 pickles, narrowed to
  encoding a ``str`` as latin-1.

Every other global (``os.system``, ``builtins.eval``, ``subprocess.Popen``, ...) raises
:class:`UnsafePickleError` *before* anything is called, so a crafted file cannot run code.
Dicts, lists, tuples, strings, numbers, ``None`` and booleans need no global and load as usual.

momu never writes pickles; this module only reads them.
"""

from __future__ import annotations

import collections
import io
import pickle
from collections.abc import Callable
from pathlib import Path
from typing import IO, Any

import numpy as np

__all__ = ["UnsafePickleError", "RestrictedUnpickler", "safe_load", "safe_loads", "ALLOWED_GLOBALS"]


class UnsafePickleError(pickle.UnpicklingError):
    """A pickle names a global outside the allow-list (or is otherwise unreadable)."""


def _latin1_encode(obj: Any, encoding: str = "utf-8", errors: str = "strict") -> bytes:
    """The one use of ``_codecs.encode`` legitimate pickles make: ``str`` -> latin-1 ``bytes``."""
    if not isinstance(obj, str) or encoding.lower().replace("_", "-") not in ("latin1", "latin-1"):
        raise UnsafePickleError(
            f"_codecs.encode is only admitted for str -> latin-1 bytes, "
            f"got {type(obj).__name__} / {encoding!r}"
        )
    return obj.encode("latin-1", errors)


def _numpy_core() -> Any:
    """numpy's core package (``numpy._core`` on numpy >= 2, ``numpy.core`` before)."""
    return getattr(np, "_core", None) or np.core


def _build_allowed() -> dict[tuple[str, str], Callable[..., Any] | type]:
    core = _numpy_core()
    reconstruct = core.multiarray._reconstruct
    scalar = core.multiarray.scalar
    frombuffer = core.numeric._frombuffer
    allowed: dict[tuple[str, str], Callable[..., Any] | type] = {
        ("collections", "OrderedDict"): collections.OrderedDict,
        ("builtins", "set"): set,
        ("builtins", "frozenset"): frozenset,
        ("builtins", "bytearray"): bytearray,
        ("builtins", "complex"): complex,
        ("builtins", "bytes"): bytes,
        ("__builtin__", "bytes"): bytes,
        ("__builtin__", "set"): set,  # Python 2 pickles
        ("__builtin__", "frozenset"): frozenset,
        ("__builtin__", "bytearray"): bytearray,
        ("__builtin__", "complex"): complex,
        ("_codecs", "encode"): _latin1_encode,
        ("numpy", "ndarray"): np.ndarray,
        ("numpy", "dtype"): np.dtype,
    }
    for package in ("numpy.core", "numpy._core"):
        allowed[(f"{package}.multiarray", "_reconstruct")] = reconstruct
        allowed[(f"{package}.multiarray", "scalar")] = scalar
        allowed[(f"{package}.numeric", "_frombuffer")] = frombuffer
    return allowed


ALLOWED_GLOBALS: frozenset[tuple[str, str]] = frozenset(_build_allowed())
"""The ``(module, name)`` pairs a pickle may reference."""


class RestrictedUnpickler(pickle.Unpickler):
    """An unpickler that resolves only :data:`ALLOWED_GLOBALS` (see the module docstring).

    Args:
        file: a binary file object positioned at the pickle.
        source: a name for error messages (the file path).
    """

    def __init__(self, file: IO[bytes], *, source: str = "<pickle>") -> None:
        # latin-1 lets Python 2 pickles of numpy arrays (their raw data is a py2 str) load.
        super().__init__(file, encoding="latin1")
        self._source = source
        self._allowed = _build_allowed()

    def find_class(self, module: str, name: str) -> Any:
        try:
            return self._allowed[(module, name)]
        except KeyError:
            raise UnsafePickleError(
                f"{self._source}: refusing to load global '{module}.{name}': only plain containers and "
                "numpy arrays are admitted (the file may be corrupt or crafted to run code)"
            ) from None

    def persistent_load(self, pid: Any) -> Any:
        raise UnsafePickleError(f"{self._source}: persistent ids are not admitted ({pid!r})")


def safe_loads(data: bytes, *, source: str = "<bytes>") -> Any:
    """Unpickle ``data`` with :class:`RestrictedUnpickler`.

    Raises:
        UnsafePickleError: a forbidden global, or a truncated / malformed stream (the message
            names ``source``).
    """
    try:
        return RestrictedUnpickler(io.BytesIO(data), source=source).load()
    except UnsafePickleError:
        raise
    except (
        pickle.UnpicklingError,
        EOFError,
        ValueError,
        TypeError,
        AttributeError,
        IndexError,
        KeyError,
    ) as exc:
        raise UnsafePickleError(f"{source}: not a readable pickle ({type(exc).__name__}: {exc})") from None


def safe_load(path: str | Path) -> Any:
    """Read a pickle file through :class:`RestrictedUnpickler`.

    Raises:
        FileNotFoundError: ``path`` does not exist.
        UnsafePickleError: the file names a forbidden global or is not a readable pickle; the
            message names the file.
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"{path}: file not found")
    return safe_loads(path.read_bytes(), source=str(path))
