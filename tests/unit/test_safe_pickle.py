"""The restricted unpickler: containers and numpy arrays load; anything that could run code is refused."""

from __future__ import annotations

import collections
import copyreg
import os
import pickle
import pickletools
import subprocess
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp
from tests.fixtures.layouts import evil_pickle_bytes

from momu.data.safe_pickle import ALLOWED_GLOBALS, UnsafePickleError, safe_load, safe_loads


def _aist_like() -> dict:
    rng = np.random.default_rng(0)
    return {
        "smpl_poses": rng.normal(size=(5, 72)).astype(np.float32),
        "smpl_trans": np.asfortranarray(rng.normal(size=(5, 3))),
        "smpl_scaling": np.array([93.5]),
        "smpl_loss": np.float64(0.25),
        "frames": np.int64(5),
        "mask": np.array([True, False, True]),
        "empty": np.zeros((0, 17, 3), np.float32),
        "scalar_array": np.array(3.5),
        "nested": [(1, 2.5, "a", None, True), {"k": b"bytes"}],
        "sets": ({1, 2}, frozenset({"x"})),
        "ordered": collections.OrderedDict(b=1, a=2),
        "complex": 1 + 2j,
    }


@pytest.mark.parametrize("protocol", range(pickle.HIGHEST_PROTOCOL + 1))
def test_plain_containers_and_numpy_round_trip_at_every_protocol(protocol: int) -> None:
    data = _aist_like()
    out = safe_loads(pickle.dumps(data, protocol=protocol))
    assert out.keys() == data.keys()
    for key in ("smpl_poses", "smpl_trans", "smpl_scaling", "mask", "empty", "scalar_array"):
        np.testing.assert_array_equal(out[key], data[key])
        assert out[key].dtype == data[key].dtype and out[key].shape == data[key].shape
    assert out["smpl_trans"].flags.f_contiguous
    assert out["smpl_loss"] == 0.25 and isinstance(out["smpl_loss"], np.float64)
    assert out["frames"] == 5 and isinstance(out["frames"], np.int64)
    assert out["nested"] == data["nested"] and out["sets"] == data["sets"]
    assert list(out["ordered"]) == ["b", "a"] and out["complex"] == 1 + 2j


def test_crafted_pickle_cannot_run_code(tmp_path: Path) -> None:
    marker = tmp_path / "PWNED"
    payload = evil_pickle_bytes(marker)
    with pytest.raises(UnsafePickleError, match=r"refusing to load global '(posix|nt|os)\.system'"):
        safe_loads(payload)
    assert not marker.exists()
    # The same bytes do run code through plain pickle — the test's payload is real.
    pickle.loads(payload)
    assert marker.exists()


class _Reduce:
    def __init__(self, func: object, args: tuple) -> None:
        self.func, self.args = func, args

    def __reduce__(self) -> tuple:
        return (self.func, self.args)


@pytest.mark.parametrize(
    "func, args",
    [
        (eval, ("1 + 1",)),
        (exec, ("x = 1",)),
        (getattr, ("abc", "upper")),
        (subprocess.Popen, (["true"],)),
        (os.remove, ("/nonexistent",)),
        (np.load, ("/nonexistent.npy",)),
        (__import__, ("os",)),
    ],
)
def test_every_callable_outside_the_allow_list_is_refused(func: object, args: tuple) -> None:
    with pytest.raises(UnsafePickleError, match="refusing to load global"):
        safe_loads(pickle.dumps(_Reduce(func, args), protocol=2))


def test_class_instances_are_refused_even_harmless_ones() -> None:
    with pytest.raises(UnsafePickleError, match="refusing to load global"):
        safe_loads(pickle.dumps(_Reduce(dict, ()), protocol=4))
    with pytest.raises(UnsafePickleError, match=r"copy_?reg\._reconstructor"):
        safe_loads(pickle.dumps(_Reduce(copyreg._reconstructor, (object, object, None)), protocol=2))


def test_codecs_encode_is_narrowed_to_latin1_strings() -> None:
    # Python 3 writes bytes as _codecs.encode(str, 'latin1') at protocol 2: that must load ...
    assert b"_codecs" in pickle.dumps(b"\x00\xff", protocol=2)
    assert safe_loads(pickle.dumps(b"\x00\xff", protocol=2)) == b"\x00\xff"
    # ... but _codecs.encode with another codec is refused.
    crafted = pickle.dumps(_Reduce(__import__("_codecs").encode, ("abc", "rot13")), protocol=2)
    with pytest.raises(UnsafePickleError, match="latin-1"):
        safe_loads(crafted)


def test_allow_list_is_only_containers_and_numpy() -> None:
    modules = {module for module, _ in ALLOWED_GLOBALS}
    assert modules <= {
        "collections",
        "builtins",
        "__builtin__",
        "_codecs",
        "numpy",
        "numpy.core.multiarray",
        "numpy._core.multiarray",
        "numpy.core.numeric",
        "numpy._core.numeric",
    }
    assert ("builtins", "eval") not in ALLOWED_GLOBALS and ("builtins", "getattr") not in ALLOWED_GLOBALS


def test_persistent_ids_are_refused() -> None:
    # PERSID opcode: b"P" + id + newline, then STOP.
    with pytest.raises(UnsafePickleError, match="persistent"):
        safe_loads(b"Pabc\n.")


def test_truncated_and_garbage_input_name_the_source(tmp_path: Path) -> None:
    data = pickle.dumps(_aist_like(), protocol=2)
    path = tmp_path / "seq.pkl"
    path.write_bytes(data[: len(data) // 2])
    with pytest.raises(UnsafePickleError, match=rf"{path}: not a readable pickle"):
        safe_load(path)
    path.write_bytes(b"")
    with pytest.raises(UnsafePickleError, match="not a readable pickle"):
        safe_load(path)
    with pytest.raises(FileNotFoundError, match="missing.pkl"):
        safe_load(tmp_path / "missing.pkl")


def test_numpy_1_pickles_referencing_numpy_core_load_without_warnings(
    recwarn: pytest.WarningsRecorder,
) -> None:
    data = pickle.dumps(np.arange(4, dtype=np.int16), protocol=2)
    old = data.replace(b"numpy._core.multiarray", b"numpy.core.multiarray")
    assert b"numpy.core.multiarray" in old
    pickletools.dis(old, out=open(os.devnull, "w"))  # still a valid pickle stream
    np.testing.assert_array_equal(safe_loads(old), np.arange(4, dtype=np.int16))
    assert not [w for w in recwarn if "numpy.core" in str(w.message)]


# ------------------------------------------------------------------------------------ properties
_scalars = st.one_of(
    st.none(),
    st.booleans(),
    st.integers(-(2**70), 2**70),
    st.floats(allow_nan=False),
    st.text(max_size=8),
    st.binary(max_size=8),
)
_arrays = hnp.arrays(
    dtype=st.sampled_from([np.float32, np.float64, np.int16, np.int64, np.bool_, np.complex64]),
    shape=hnp.array_shapes(min_dims=0, max_dims=3, max_side=4),
)
_trees = st.recursive(
    st.one_of(_scalars, _arrays),
    lambda kids: st.one_of(
        st.lists(kids, max_size=3),
        st.tuples(kids, kids),
        st.dictionaries(st.text(max_size=4), kids, max_size=3),
    ),
    max_leaves=8,
)


def _same(a: object, b: object) -> bool:
    if isinstance(a, np.ndarray):
        return isinstance(b, np.ndarray) and a.dtype == b.dtype and np.array_equal(a, b, equal_nan=True)
    if isinstance(a, (list, tuple)):
        return type(a) is type(b) and len(a) == len(b) and all(_same(x, y) for x, y in zip(a, b))
    if isinstance(a, dict):
        return isinstance(b, dict) and a.keys() == b.keys() and all(_same(a[k], b[k]) for k in a)
    return a == b and type(a) is type(b)


@settings(deadline=None)
@given(tree=_trees, protocol=st.integers(0, pickle.HIGHEST_PROTOCOL))
def test_any_tree_of_containers_and_arrays_round_trips(tree: object, protocol: int) -> None:
    assert _same(tree, safe_loads(pickle.dumps(tree, protocol=protocol)))


def test_admitted_records_load_as_plain_state_without_running_the_class() -> None:
    """``records`` admit named foreign classes as :class:`PickledObject` (SMPL's chumpy/scipy objects):
    the class is neither imported nor run, and anything else is still refused."""
    import scipy.sparse

    from momu.data.safe_pickle import PickledObject

    matrix = scipy.sparse.csc_matrix(np.eye(3)[:2])
    raw = pickle.dumps({"m": matrix}, protocol=2)
    name = (type(matrix).__module__, "csc_matrix")
    with pytest.raises(UnsafePickleError, match="refusing to load global 'scipy.sparse"):
        safe_loads(raw)
    out = safe_loads(raw, records={name})["m"]
    assert isinstance(out, PickledObject) and (out.module, out.name) == name and out.args == ()
    np.testing.assert_array_equal(out.state["indptr"], matrix.indptr)
    assert tuple(out.state["_shape"]) == (2, 3)
    evil = raw.replace(b"numpy", b"nompy", 1)  # the arrays inside are still checked
    with pytest.raises(UnsafePickleError):
        safe_loads(evil, records={name})


# ---------------------------------------------------------------- issue 34: bypasses of the memory guard


class _Built:
    """A pickle of ``func(*args)`` whose BUILD gives it ``state``; ``kwargs`` through NEWOBJ_EX."""

    def __init__(self, func: object, args: tuple, state: object = None, kwargs: dict | None = None) -> None:
        self.func, self.args, self.state, self.kwargs = func, args, state, kwargs

    def __reduce_ex__(self, protocol: int) -> tuple:
        if self.kwargs is not None:
            return (copyreg.__newobj_ex__, (self.func, self.args, self.kwargs))
        return (self.func, self.args) if self.state is None else (self.func, self.args, self.state)


_core = getattr(np, "_core", None) or np.core


@pytest.mark.parametrize("kind", [bytes, bytearray])
def test_bytes_of_a_size_by_keyword_is_refused(kind: type) -> None:
    payload = pickle.dumps(_Built(kind, (), kwargs={"source": 2 * 10**9}), protocol=4)
    assert b"__newobj_ex__" not in payload and len(payload) < 60  # NEWOBJ_EX: 36-ish bytes of pickle
    with pytest.raises(UnsafePickleError, match=rf"refusing {kind.__name__}\(int 2000000000\)"):
        safe_loads(payload)
    # what a real pickle of these types holds still loads
    assert safe_loads(pickle.dumps(kind(b"\x00ab"), protocol=2)) == kind(b"\x00ab")


def test_a_numpy_scalar_without_its_bytes_is_refused() -> None:
    payload = pickle.dumps(_Built(_core.multiarray.scalar, (np.dtype("V200000000"),)), protocol=4)
    assert len(payload) < 120  # ~66 bytes would make a 200 MB zero-filled item
    with pytest.raises(UnsafePickleError, match="a numpy scalar of 200000000 bytes"):
        safe_loads(payload)
    with pytest.raises(UnsafePickleError, match="limit"):  # and the declared size counts
        safe_loads(pickle.dumps(np.bytes_(b"x" * 5000)), max_bytes=1000)
    assert safe_loads(pickle.dumps(np.float32(2.5))) == np.float32(2.5)


def _array_of(dtype: object, raw: bytes, shape: tuple = (1,)) -> _Built:
    return _Built(_core.multiarray._reconstruct, (np.ndarray, (0,), b"b"), (1, shape, dtype, False, raw))


CRAFTED_DTYPES = {
    "float64 declaring 10^6-byte items": _Built(
        np.dtype, ("f8", False, True), (3, "<", None, None, None, 10**6, -1, 0)
    ),
    "a field past the end of its item": _Built(
        np.dtype, ("V8", False, True), (3, "|", None, ("a",), {"a": (np.dtype("f8"), 4096)}, 8, 1, 16)
    ),
    "a sub-array larger than its item": _Built(
        np.dtype, ("V8", False, True), (3, "|", (np.dtype("f8"), (1000,)), None, None, 8, 8, 0)
    ),
    "fields on a number type": _Built(
        np.dtype, ("f8", False, True), (3, "<", None, ("a",), {"a": (np.dtype("f8"), 0)}, 8, 8, 16)
    ),
    "a state of another version": _Built(
        np.dtype, ("f8", False, True), (99, "<", None, None, None, -1, -1, 0)
    ),
}


@pytest.mark.parametrize("name", list(CRAFTED_DTYPES))
def test_crafted_dtype_states_are_refused(name: str) -> None:
    dtype = CRAFTED_DTYPES[name]
    with pytest.raises(UnsafePickleError, match="refusing"):
        safe_loads(pickle.dumps(_array_of(dtype, b"\0" * 8), protocol=4))


def test_what_numpys_own_pickles_hold_still_loads() -> None:
    aligned = np.dtype([("a", "u1"), ("b", "<f8")], align=True)
    arrays = [
        np.zeros(3, dtype=[("a", "<f8"), ("b", "S3"), ("c", ">i4", (2,))]),
        np.zeros(2, dtype=aligned),
        np.zeros(2, dtype=np.dtype({"names": ["x"], "formats": ["<f4"], "titles": ["the x"]})),
        np.array(["ab", "c"], dtype="U3"),
        np.array([b"ab"], dtype="S4"),
        np.zeros(2, dtype="V5"),
    ]
    arrays[0]["a"] = [1.0, 2.0, 3.0]
    for protocol in (2, 4, 5):
        for x in arrays:
            y = safe_loads(pickle.dumps(x, protocol=protocol))
            assert y.dtype == x.dtype and y.dtype.itemsize == x.dtype.itemsize
            np.testing.assert_array_equal(y, x)
        assert safe_loads(pickle.dumps(np.zeros(1, aligned), protocol=protocol)).dtype.isalignedstruct


def test_setting_the_state_of_other_objects_is_refused() -> None:
    payload = pickle.dumps(_Built(_core.multiarray.scalar, (np.dtype("f8"), b"\0" * 8), {"x": 1}), protocol=4)
    with pytest.raises(UnsafePickleError, match="refusing setting the state of a float64"):
        safe_loads(payload)
