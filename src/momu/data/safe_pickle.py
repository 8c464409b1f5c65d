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

A caller that expects instances of a few named foreign classes (the official SMPL model pickles
hold ``chumpy.ch.Ch`` arrays and a ``scipy.sparse`` matrix) may admit those classes as *records*
(``records={("chumpy.ch", "Ch")}``): the pickle then builds a :class:`PickledObject` holding the
class's name, its constructor arguments and the state the pickle gives it. The foreign class is
never imported and none of its code runs; the caller reads the (plain, checked) state itself.

Memory bombs are refused before anything is allocated. A few bytes of pickle can otherwise ask
for gigabytes: ``bytes(N)`` / ``bytearray(N)`` (N zero bytes from nothing, also as ``bytes(source=N)``),
numpy's ``scalar(dtype)`` (a zero-filled item of any declared size), the ``numpy.ndarray(shape)``
constructor (uninitialised memory that would be read as keypoints), an array whose declared shape
does not match the data the file holds, or object-dtype arrays (whose elements are more pickled
objects). The unpickler (the pure-Python one, so it can see each opcode) refuses

* ``bytes``/``bytearray`` given anything but the bytes, text or list of values they copy (whatever
  the call form: positional, keyword, ``NEWOBJ``), and the ``ndarray`` constructor at all;
* a numpy scalar without exactly its item's bytes in the file;
* object dtypes anywhere (a dtype, an array, a scalar);
* a pickled dtype state numpy's own pickles never hold (:mod:`momu.data.safe_pickle_dtypes`: dtypes
  are rebuilt through numpy's public constructor, never ``__setstate__``, so a crafted item size,
  field offset or flag cannot make arrays read outside their memory);
* an array whose data is not exactly ``prod(shape) × itemsize`` bytes held in the file;
* a BUILD (``__setstate__``) on anything but an array, a dtype, an admitted record or an ``OrderedDict``;
* a file, or a total of declared array (and scalar) data, larger than ``max_bytes``
  (:data:`DEFAULT_MAX_BYTES`; ``aistpp``'s ``max_pickle_mb`` option sets it).

momu never writes pickles; this module only reads them.
"""

from __future__ import annotations

import collections
import io
import pickle
import struct
from collections.abc import Callable, Collection
from pathlib import Path
from typing import IO, Any, NoReturn

import numpy as np

from momu.data.safe_pickle_dtypes import DtypeStateError, rebuild_dtype

__all__ = [
    "UnsafePickleError",
    "PickledObject",
    "RestrictedUnpickler",
    "safe_load",
    "safe_loads",
    "ALLOWED_GLOBALS",
    "DEFAULT_MAX_BYTES",
]

DEFAULT_MAX_BYTES = 1 << 30
"""Largest pickle file, and largest total of array data declared in one, that is read (1 GiB)."""


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


class _Refused(UnsafePickleError):
    pass


_COPIED_SOURCES = (bytes, bytearray, memoryview, str, list, tuple, np.ndarray)
"""What ``bytes(...)`` / ``bytearray(...)`` may be given in a pickle: values it copies (proportional
to the file), never a size."""


def _size_free(kind: type, refuse: Callable[[str], NoReturn]) -> type:
    """A stand-in for ``bytes`` / ``bytearray`` whose every call form refuses a size argument."""

    class _Checked:
        def __new__(cls, *args: Any, **kwargs: Any) -> Any:
            source = args[0] if args else kwargs.get("source")
            if source is not None and not isinstance(source, _COPIED_SOURCES):
                refuse(
                    f"{kind.__name__}({type(source).__name__} {source!r:.40}): only bytes, text or a list of "
                    "values are admitted, not a size that builds zero bytes from nothing"
                )
            return kind(*args, **kwargs)

    _Checked.__name__ = _Checked.__qualname__ = kind.__name__
    return _Checked


class PickledObject:
    """An instance of an admitted record class (see the module docstring), never constructed for real.

    Attributes:
        module: the class's module as the pickle names it (``"chumpy.ch"``).
        name: the class's name (``"Ch"``).
        args: the arguments the pickle passed to the class (usually ``()``).
        state: what the pickle's BUILD gave the instance (usually its ``__dict__``), or ``None``.
    """

    __slots__ = ("module", "name", "args", "state")

    def __init__(self, module: str, name: str, args: tuple[Any, ...] = ()) -> None:
        self.module = module
        self.name = name
        self.args = args
        self.state: Any = None

    def __setstate__(self, state: Any) -> None:
        self.state = state

    def __repr__(self) -> str:
        return f"PickledObject({self.module}.{self.name})"


def _record_class(module: str, name: str) -> type:
    """What ``find_class`` returns for an admitted record: calling it, or its ``__new__`` (the
    NEWOBJ opcode), gives a :class:`PickledObject` instead of an instance of the real class."""

    class _Record:
        def __new__(cls, *args: Any, **kwargs: Any) -> Any:
            return PickledObject(module, name, args)

    _Record.__name__ = _Record.__qualname__ = name
    return _Record


def _nbytes(shape: Any, dtype: np.dtype[Any], source: str) -> int:
    if isinstance(shape, (int, np.integer)):
        shape = (shape,)
    if not isinstance(shape, (tuple, list)) or not all(
        isinstance(n, (int, np.integer)) and not isinstance(n, bool) and n >= 0 for n in shape
    ):
        raise UnsafePickleError(f"{source}: an array shape must be non-negative integers, got {shape!r}")
    count = 1
    for n in shape:
        count *= int(n)
    return count * int(dtype.itemsize)


class RestrictedUnpickler(pickle._Unpickler):
    """An unpickler that resolves only :data:`ALLOWED_GLOBALS` and refuses memory bombs (module docstring).

    Args:
        file: a binary file object positioned at the pickle.
        source: a name for error messages (the file path).
        max_bytes: the most array data (bytes, summed over the file) that may be declared.
        records: ``(module, name)`` classes whose instances load as :class:`PickledObject`.
    """

    dispatch: dict[int, Any] = dict(pickle._Unpickler.dispatch)  # type: ignore[attr-defined,misc]
    stack: list[Any]  # the pure-Python unpickler's stack (untyped in the stubs)
    memo: dict[int, Any]  # and its memo

    def __init__(
        self,
        file: IO[bytes],
        *,
        source: str = "<pickle>",
        max_bytes: int = DEFAULT_MAX_BYTES,
        records: Collection[tuple[str, str]] = (),
    ) -> None:
        # latin-1 lets Python 2 pickles of numpy arrays (their raw data is a py2 str) load.
        super().__init__(file, encoding="latin1")
        self._source = source
        self._budget = int(max_bytes)
        self._max_bytes = int(max_bytes)
        self._allowed = _build_allowed()
        core = _numpy_core()
        self._allowed[("numpy", "ndarray")] = np.ndarray
        for module in ("builtins", "__builtin__"):
            self._allowed[(module, "bytes")] = _size_free(bytes, self._refuse)
            self._allowed[(module, "bytearray")] = _size_free(bytearray, self._refuse)
        for package in ("numpy.core", "numpy._core"):
            self._allowed[(f"{package}.multiarray", "_reconstruct")] = self._reconstruct
            self._allowed[(f"{package}.numeric", "_frombuffer")] = self._frombuffer
            self._allowed[(f"{package}.multiarray", "scalar")] = self._scalar
        self._np_scalar = core.multiarray.scalar
        self._np_reconstruct = core.multiarray._reconstruct
        self._np_frombuffer = core.numeric._frombuffer
        self._records = {(m, n): _record_class(m, n) for m, n in records}

    # ------------------------------------------------------------------ globals
    def find_class(self, module: str, name: str) -> Any:
        try:
            return self._allowed.get((module, name)) or self._records[(module, name)]
        except KeyError:
            raise UnsafePickleError(
                f"{self._source}: refusing to load global '{module}.{name}': only plain containers and "
                "numpy arrays are admitted (the file may be corrupt or crafted to run code)"
            ) from None

    def persistent_load(self, pid: Any) -> Any:
        raise UnsafePickleError(f"{self._source}: persistent ids are not admitted ({pid!r})")

    # ------------------------------------------------------------------ size checks
    def _refuse(self, why: str) -> NoReturn:
        raise _Refused(f"{self._source}: refusing {why} (the file may be corrupt or crafted)")

    def _spend(self, nbytes: int) -> None:
        if nbytes > self._budget:
            self._refuse(
                f"an array of {nbytes} bytes: the file declares more than the {self._max_bytes}-byte limit "
                "of array data (max_bytes / aistpp max_pickle_mb)"
            )
        self._budget -= nbytes

    def _dtype(self, dtype: Any) -> np.dtype[Any]:
        if not isinstance(dtype, np.dtype):
            self._refuse(f"an array dtype of type {type(dtype).__name__}")
        if dtype.hasobject:
            self._refuse("an object-dtype array (its elements would be more pickled objects)")
        return dtype

    def _check_call(self, func: Any) -> None:
        if func is np.ndarray:
            self._refuse("the numpy.ndarray(shape) constructor: it returns uninitialised memory")

    def _checked(self, value: Any) -> Any:
        if isinstance(value, np.dtype) and value.hasobject:
            self._refuse("an object dtype")
        return value

    def _reconstruct(self, subtype: Any, shape: Any, dtype: Any) -> Any:
        """numpy's array reconstructor, admitted only as numpy's own pickles call it: an empty ndarray."""
        if subtype is not np.ndarray:
            self._refuse(f"an array of type {getattr(subtype, '__name__', subtype)!r}")
        if _nbytes(shape, np.dtype(np.uint8), self._source) != 0:
            self._refuse(f"_reconstruct of shape {shape!r}: numpy pickles start from an empty array")
        return self._np_reconstruct(subtype, shape, dtype)

    def _scalar(self, dtype: Any, obj: Any = None) -> Any:
        """numpy's scalar reconstructor, only with exactly its item's bytes (no zero-filled items)."""
        dtype = self._dtype(dtype)
        if isinstance(obj, str):  # Python 2 pickles: the raw bytes as a latin-1 str
            obj = obj.encode("latin-1")
        if not isinstance(obj, bytes) or len(obj) != dtype.itemsize:
            held = len(obj) if isinstance(obj, bytes) else type(obj).__name__
            self._refuse(f"a numpy scalar of {dtype.itemsize} bytes given {held}")
        self._spend(dtype.itemsize)
        return self._np_scalar(dtype, obj)

    def _frombuffer(self, buf: Any, dtype: Any, shape: Any, order: Any) -> Any:
        dtype = self._dtype(dtype)
        nbytes = _nbytes(shape, dtype, self._source)
        held = memoryview(buf).nbytes if isinstance(buf, (bytes, bytearray, memoryview)) else -1
        if held != nbytes:
            self._refuse(f"an array declaring {nbytes} bytes of data but holding {held}")
        self._spend(nbytes)
        return self._np_frombuffer(buf, dtype, shape, order)

    def _check_array_state(self, state: Any) -> None:
        """``ndarray.__setstate__((version,) shape, dtype, is_fortran, rawdata)`` before it runs."""
        if not isinstance(state, tuple) or len(state) not in (4, 5):
            self._refuse(f"an array state of type {type(state).__name__}")
        shape, dtype, _, raw = state[-4:]
        dtype = self._dtype(dtype)
        nbytes = _nbytes(shape, dtype, self._source)
        if not isinstance(raw, (bytes, bytearray, str)):
            self._refuse(f"array data of type {type(raw).__name__}")
        if len(raw) != nbytes:
            self._refuse(f"an array declaring {nbytes} bytes of data but holding {len(raw)}")
        self._spend(nbytes)

    # ------------------------------------------------------------------ opcodes that construct
    def load_reduce(self) -> None:
        self._check_call(self.stack[-2])
        pickle._Unpickler.load_reduce(self)  # type: ignore[attr-defined]
        self._checked(self.stack[-1])

    def load_newobj(self) -> None:
        self._check_call(self.stack[-2])
        pickle._Unpickler.load_newobj(self)  # type: ignore[attr-defined]
        self._checked(self.stack[-1])

    def load_newobj_ex(self) -> None:
        self._check_call(self.stack[-3])
        pickle._Unpickler.load_newobj_ex(self)  # type: ignore[attr-defined]
        self._checked(self.stack[-1])

    def _instantiate(self, klass: Any, args: list[Any]) -> None:
        self._check_call(klass)
        pickle._Unpickler._instantiate(self, klass, args)  # type: ignore[attr-defined]
        self._checked(self.stack[-1])

    def load_build(self) -> None:
        state, inst = self.stack[-1], self.stack[-2]
        if isinstance(inst, np.dtype):
            self._build_dtype(inst, state)
            return
        if isinstance(inst, np.ndarray):
            self._check_array_state(state)
        elif not isinstance(inst, (PickledObject, collections.OrderedDict)):
            self._refuse(f"setting the state of a {type(inst).__name__} (only arrays and dtypes have one)")
        pickle._Unpickler.load_build(self)  # type: ignore[attr-defined]
        self._checked(inst)

    def _build_dtype(self, inst: np.dtype[Any], state: Any) -> None:
        """BUILD of a dtype: a new dtype from the checked state replaces ``inst`` on the stack and in
        the memo (:func:`~momu.data.safe_pickle_dtypes.rebuild_dtype`); ``inst`` itself — possibly
        numpy's shared built-in dtype — is never changed."""
        try:
            new = rebuild_dtype(inst, state)
        except DtypeStateError as exc:
            self._refuse(str(exc))
        self.stack.pop()
        self.stack[-1] = new
        for key, value in self.memo.items():
            if value is inst:
                self.memo[key] = new

    dispatch[pickle.REDUCE[0]] = load_reduce
    dispatch[pickle.NEWOBJ[0]] = load_newobj
    dispatch[pickle.NEWOBJ_EX[0]] = load_newobj_ex
    dispatch[pickle.BUILD[0]] = load_build


def safe_loads(
    data: bytes,
    *,
    source: str = "<bytes>",
    max_bytes: int = DEFAULT_MAX_BYTES,
    records: Collection[tuple[str, str]] = (),
) -> Any:
    """Unpickle ``data`` with :class:`RestrictedUnpickler` (``records``: see the module docstring).

    Raises:
        UnsafePickleError: a forbidden global, a memory bomb, or a truncated / malformed stream
            (the message names ``source``).
    """
    if len(data) > max_bytes:
        raise UnsafePickleError(f"{source}: {len(data)} bytes, more than the {max_bytes}-byte limit")
    try:
        unpickler = RestrictedUnpickler(io.BytesIO(data), source=source, max_bytes=max_bytes, records=records)
        return unpickler.load()
    except UnsafePickleError:
        raise
    except MemoryError:
        raise UnsafePickleError(f"{source}: not a readable pickle (out of memory while reading it)") from None
    except RecursionError:
        raise UnsafePickleError(f"{source}: not a readable pickle (nested too deeply)") from None
    except (
        pickle.UnpicklingError,
        EOFError,
        ValueError,
        TypeError,
        AttributeError,
        IndexError,
        KeyError,
        struct.error,
        OverflowError,
    ) as exc:
        raise UnsafePickleError(f"{source}: not a readable pickle ({type(exc).__name__}: {exc})") from None


def safe_load(
    path: str | Path, *, max_bytes: int = DEFAULT_MAX_BYTES, records: Collection[tuple[str, str]] = ()
) -> Any:
    """Read a pickle file through :class:`RestrictedUnpickler` (``records``: see the module docstring).

    Raises:
        FileNotFoundError: ``path`` does not exist.
        UnsafePickleError: the file names a forbidden global, declares more than ``max_bytes``,
            or is not a readable pickle; the message names the file.
    """
    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"{path}: file not found")
    size = path.stat().st_size
    if size > max_bytes:
        raise UnsafePickleError(f"{path}: {size} bytes, more than the {max_bytes}-byte limit (max_bytes)")
    return safe_loads(path.read_bytes(), source=str(path), max_bytes=max_bytes, records=records)
