"""SMPL-24 joint positions from a user's SMPL model file and AIST++'s SMPL parameters.

momu does not ship the SMPL body model (its licence does not allow redistribution); a user who
has it passes the file:

* the official pickle (``SMPL_MALE.pkl`` / ``SMPL_NEUTRAL.pkl`` of SMPL 1.1,
  ``basicmodel_m_lbs_10_207_0_v1.0.0.pkl``, SMPLify's ``basicModel_neutral_lbs_10_207_0_v1.0.0.pkl``):
  a Python 2 pickle whose arrays are partly ``chumpy`` objects and whose ``J_regressor`` is a
  ``scipy.sparse`` matrix. It is read with :mod:`momu.data.safe_pickle`, admitting exactly those
  classes as records (:data:`PICKLE_RECORDS`): their pickled state is read as plain arrays and no
  chumpy/scipy code runs (chumpy need not be installed);
* the common ``.npz`` conversion (``np.savez`` of the same keys, e.g. smplx's ``SMPL_NEUTRAL.npz``),
  read with ``allow_pickle=False``.

Keys read: ``v_template`` ``(V, 3)``, ``J_regressor`` ``(J, V)`` (dense or sparse), ``kintree_table``
``(2, J)`` (row 0 the parent of each joint id in row 1; the root's parent is -1 or 2³²−1) and, only
when ``betas`` are given, ``shapedirs`` ``(V, 3, B)``. Other keys (``weights``, ``posedirs``, ``f``)
are not needed for joints and are ignored.

Joints (SMPL, Loper et al. 2015, Eq. 10; smplx's ``lbs``): the rest joints are
``J = J_regressor · (v_template + shapedirs · β)`` (β = 0 by default, as AIST++'s fits); pose blend
shapes do not move the joints. Forward kinematics composes the axis-angle rotations (``scipy``'s
``Rotation.from_rotvec``) down the tree: ``G_root = [R_root | J_root]``,
``G_j = G_parent(j) · [R_j | J_j − J_parent(j)]``; the posed joint ``j`` is ``G_j``'s translation,
plus the global translation. AIST++ (``aistplusplus_api``, ``demos/extract_motion_feats.py``) puts
its motion "in generic SMPL model scale" by passing ``transl = smpl_trans / smpl_scaling`` and no
scaling, which :func:`aistpp_joints` follows: metres of the SMPL template, Y up.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from momu.data.files import DataFileError, MissingDataFileError, absent_reason, read_pickle_dict
from momu.data.safe_pickle import PickledObject

__all__ = [
    "PICKLE_RECORDS",
    "SMPLModel",
    "load_smpl_model",
    "forward_kinematics",
    "aistpp_joints",
]

_SPARSE = ("csc_matrix", "csr_matrix")
PICKLE_RECORDS: frozenset[tuple[str, str]] = frozenset(
    {("chumpy.ch", "Ch")}
    | {(f"scipy.sparse.{mod}", cls) for mod in ("csc", "_csc", "csr", "_csr") for cls in _SPARSE}
)
"""The foreign classes an official SMPL pickle may hold, admitted as records (never run)."""

_MAX_BYTES = 512 << 20  # the SMPL pickles are ~40 MB (SMPL-H/X are larger but are not SMPL-24)


@dataclass(frozen=True)
class SMPLModel:
    """What joint positions need from an SMPL model file.

    Attributes:
        path: the file it was read from (for messages).
        v_template: ``(V, 3)`` template vertices (metres).
        j_regressor: ``(J, V)`` joint regressor.
        parents: ``J`` parent indices (-1 for the root, joint 0), every parent before its child.
        shapedirs: ``(V, 3, B)`` shape blend shapes, or ``None`` when the file has none.
    """

    path: Path
    v_template: np.ndarray
    j_regressor: np.ndarray
    parents: tuple[int, ...]
    shapedirs: np.ndarray | None = None

    @property
    def num_joints(self) -> int:
        return len(self.parents)

    def rest_joints(self, betas: Sequence[float] | np.ndarray | None = None) -> np.ndarray:
        """``(J, 3)`` rest joints ``J_regressor · (v_template + shapedirs · betas)`` (β = 0: the template)."""
        verts = self.v_template
        if betas is not None and np.any(np.asarray(betas) != 0):
            b = np.asarray(betas, dtype=np.float64).reshape(-1)
            if self.shapedirs is None:
                raise DataFileError(self.path, "betas given but the model has no 'shapedirs'")
            if b.size > self.shapedirs.shape[-1]:
                raise ValueError(
                    f"{b.size} betas given; {self.path} has {self.shapedirs.shape[-1]} shape components"
                )
            verts = verts + self.shapedirs[..., : b.size] @ b
        return self.j_regressor @ verts


# ------------------------------------------------------------------------------------------ reading
def _plain(value: Any, key: str, path: Path) -> Any:
    """A chumpy record's array, a sparse record's dense array; anything else as it is."""
    if not isinstance(value, PickledObject):
        return value
    state = value.state if isinstance(value.state, dict) else {}
    if value.name == "Ch":
        if "x" not in state:
            raise DataFileError(path, f"key {key!r}: a chumpy array without its values ('x')")
        return state["x"]
    # scipy.sparse csc/csr: data, indices, indptr, _shape (or shape in older scipy)
    shape = state.get("_shape", state.get("shape"))
    parts = [state.get(k) for k in ("data", "indices", "indptr")]
    if shape is None or any(not isinstance(p, np.ndarray) for p in parts):
        raise DataFileError(path, f"key {key!r}: a sparse matrix without data/indices/indptr/shape")
    import scipy.sparse

    kind = scipy.sparse.csc_matrix if value.name == "csc_matrix" else scipy.sparse.csr_matrix
    try:
        dims = tuple(int(n) for n in shape)
        if len(dims) != 2 or min(dims) < 0 or dims[0] * dims[1] * 8 > _MAX_BYTES:
            raise DataFileError(path, f"key {key!r}: a sparse matrix of shape {dims} (too large when dense)")
        return kind((parts[0], parts[1], parts[2]), shape=dims).toarray()
    except (ValueError, TypeError) as exc:
        raise DataFileError(path, f"key {key!r}: not a valid sparse matrix ({exc})") from None


def _read(path: Path) -> Mapping[str, Any]:
    if not path.is_file():
        raise MissingDataFileError(path, absent_reason(path))
    if path.suffix == ".npz":
        try:
            with np.load(path, allow_pickle=False) as npz:
                return {k: npz[k] for k in npz.files}
        except ValueError as exc:
            if "allow_pickle" in str(exc):
                raise DataFileError(
                    path, "holds a pickled object array (e.g. a sparse J_regressor): save dense arrays"
                ) from None
            raise DataFileError(path, f"not a readable .npz ({exc})") from None
        except OSError as exc:
            raise DataFileError(path, f"not a readable .npz ({exc})") from None
    return read_pickle_dict(path, _MAX_BYTES, PICKLE_RECORDS)


def _array(data: Mapping[str, Any], key: str, path: Path, ndim: int) -> np.ndarray:
    if key not in data:
        raise DataFileError(path, f"missing key {key!r} (has {', '.join(sorted(map(str, data)))})")
    value = np.asarray(_plain(data[key], key, path))
    if not np.issubdtype(value.dtype, np.number) or value.ndim != ndim:
        raise DataFileError(
            path, f"key {key!r}: expected a numeric {ndim}-d array, got {value.dtype} {value.shape}"
        )
    if not np.all(np.isfinite(value)):
        raise DataFileError(path, f"key {key!r}: non-finite values")
    return value


def _parents(table: np.ndarray, path: Path) -> tuple[int, ...]:
    """Parent indices from ``kintree_table`` (row 1 must list joints 0..J-1 in order)."""
    if table.shape[0] != 2 or not np.issubdtype(table.dtype, np.integer):
        raise DataFileError(
            path, f"key 'kintree_table': expected integer (2, J), got {table.dtype} {table.shape}"
        )
    joints = table.shape[1]
    if not np.array_equal(table[1], np.arange(joints)):
        raise DataFileError(path, "key 'kintree_table': row 1 must list the joints 0..J-1 in order")
    parents = []
    for j, p in enumerate(table[0].astype(np.int64)):
        if j == 0:
            if 0 <= p < joints:
                raise DataFileError(path, "key 'kintree_table': joint 0 (the root) has a parent")
            parents.append(-1)
        elif not 0 <= p < j:
            raise DataFileError(path, f"key 'kintree_table': joint {j}'s parent {p} is not a joint before it")
        else:
            parents.append(int(p))
    return tuple(parents)


def load_smpl_model(path: str | Path) -> SMPLModel:
    """Read an SMPL model file (``.pkl`` or ``.npz``; see the module docstring).

    Raises:
        DataFileError: missing file or key, wrong shapes, an unreadable or unsafe pickle; the
            message names the file and the key.
    """
    path = Path(path).expanduser()
    data = _read(path)
    v_template = _array(data, "v_template", path, 2).astype(np.float64)
    if v_template.shape[1] != 3:
        raise DataFileError(path, f"key 'v_template': expected (V, 3), got {v_template.shape}")
    parents = _parents(_array(data, "kintree_table", path, 2), path)
    regressor = _array(data, "J_regressor", path, 2).astype(np.float64)
    if regressor.shape != (len(parents), v_template.shape[0]):
        raise DataFileError(
            path,
            f"key 'J_regressor': expected ({len(parents)}, {v_template.shape[0]}) for {len(parents)} joints "
            f"and {v_template.shape[0]} vertices, got {regressor.shape}",
        )
    shapedirs = None
    if "shapedirs" in data:
        shapedirs = _array(data, "shapedirs", path, 3).astype(np.float64)
        if shapedirs.shape[:2] != v_template.shape:
            raise DataFileError(
                path, f"key 'shapedirs': expected ({v_template.shape[0]}, 3, B), got {shapedirs.shape}"
            )
    return SMPLModel(path, v_template, regressor, parents, shapedirs)


# ------------------------------------------------------------------------------------------ kinematics
def forward_kinematics(
    rest_joints: np.ndarray, parents: Sequence[int], poses: np.ndarray, trans: np.ndarray | None = None
) -> np.ndarray:
    """Posed joint positions ``(T, J, 3)`` (float64) of an SMPL-style kinematic tree.

    Args:
        rest_joints: ``(J, 3)`` rest joints.
        parents: ``J`` parent indices, -1 for the root, every parent before its child.
        poses: ``(T, 3J)`` or ``(T, J, 3)`` axis-angle rotations, each joint's relative to its parent
            (the root's global), as SMPL's ``global_orient`` + ``body_pose``.
        trans: ``(T, 3)`` global translation added to every joint (``None``: zero).
    """
    rest = np.asarray(rest_joints, dtype=np.float64)
    joints = rest.shape[0]
    aa = np.asarray(poses, dtype=np.float64)
    if aa.ndim == 2 and aa.shape[1] == 3 * joints:
        aa = aa.reshape(aa.shape[0], joints, 3)
    if aa.ndim != 3 or aa.shape[1:] != (joints, 3):
        raise ValueError(f"poses must be (T, {3 * joints}) or (T, {joints}, 3) axis-angle, got {aa.shape}")
    frames = aa.shape[0]
    from scipy.spatial.transform import Rotation  # here: scipy.spatial takes 0.6 s to import

    local = Rotation.from_rotvec(aa.reshape(-1, 3)).as_matrix().reshape(frames, joints, 3, 3)
    rot = np.empty_like(local)
    pos = np.empty((frames, joints, 3))
    rot[:, 0] = local[:, 0]
    pos[:, 0] = rest[0]
    for j in range(1, joints):
        p = parents[j]
        rot[:, j] = rot[:, p] @ local[:, j]
        pos[:, j] = pos[:, p] + rot[:, p] @ (rest[j] - rest[p])
    if trans is not None:
        t = np.asarray(trans, dtype=np.float64)
        if t.shape != (frames, 3):
            raise ValueError(f"trans must be ({frames}, 3), got {t.shape}")
        pos += t[:, None, :]
    return pos


def aistpp_joints(
    model: SMPLModel,
    smpl_poses: np.ndarray,
    smpl_trans: np.ndarray,
    smpl_scaling: float,
    betas: Sequence[float] | np.ndarray | None = None,
) -> np.ndarray:
    """AIST++ SMPL joints ``(T, J, 3)`` in SMPL model scale: FK of ``smpl_poses`` plus
    ``smpl_trans / smpl_scaling`` (as ``aistplusplus_api``'s feature extraction does)."""
    if not smpl_scaling > 0:
        raise ValueError(f"smpl_scaling must be > 0, got {smpl_scaling}")
    trans = np.asarray(smpl_trans, dtype=np.float64) / float(smpl_scaling)
    return forward_kinematics(model.rest_joints(betas), model.parents, smpl_poses, trans)
