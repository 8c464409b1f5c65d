"""Non-negative least squares of the mel inversion: ``librosa.util.nnls``, bit for bit, faster.

``librosa.util.nnls(A, B)`` (librosa 0.11) solves ``min ‖A X − B‖², X ≥ 0`` with SciPy's L-BFGS-B
over all of ``X`` at once, passing one ``(0, None)`` bound per variable. For a 4-s MoMu mel
(``X``: 513 × 251 = 128 763 variables) SciPy then spends about 0.45 s converting those bounds in
Python loops (``old_bound_to_new`` and the per-variable ``nbd`` loop of ``_minimize_lbfgsb``)
against about 0.05 s of optimisation, and a Griffin-Lim vocoding takes 0.6 s instead of 0.15 s
(``benchmarks/bench_mel_inversion.py``).

:func:`nnls` runs the same algorithm — the same start (the clipped pseudo-inverse), the same
objective and gradient, the same L-BFGS-B routine with the same memory (``m = A.shape[1]``),
tolerances, iteration and evaluation limits, the same column blocks — and builds the bound arrays
with NumPy. It drives SciPy's L-BFGS-B routine ``scipy.optimize._lbfgsb.setulb`` the way
``_minimize_lbfgsb`` does. That routine is private, so :func:`nnls` falls back to
``librosa.util.nnls`` where it is missing or its signature changed, and a test checks that both
give identical arrays on the installed SciPy.
"""

from __future__ import annotations

import functools
import warnings
from typing import Any

import librosa
import numpy as np

__all__ = ["nnls"]

# librosa.util.nnls's settings: fmin_l_bfgs_b's defaults with m = A.shape[1]
_FACTR, _PGTOL, _MAXFUN, _MAXITER, _MAXLS = 1e7, 1e-5, 15000, 15000, 20
# the task codes of SciPy's setulb (scipy/optimize/_lbfgsb_py.py)
_TASK_FG, _TASK_NEW_X, _TASK_STOP, _STOP_MAXFUN, _STOP_MAXITER = 3, 1, 5, 502, 504


@functools.cache
def _setulb() -> Any:
    """SciPy's private L-BFGS-B step, or ``None`` where this SciPy has none."""
    try:
        from scipy.optimize import _lbfgsb
    except ImportError:
        return None
    return getattr(_lbfgsb, "setulb", None)


def _objective(
    x: np.ndarray, shape: tuple[int, ...], a: np.ndarray, b: np.ndarray
) -> tuple[float, np.ndarray]:
    """``(½‖A X − B‖² / |B|, gradient)``, the objective librosa minimises."""
    diff = np.einsum("mf,...ft->...mt", a, x.reshape(shape), optimize=True) - b
    value = (1 / b.size) * 0.5 * np.sum(diff**2)
    grad = (1 / b.size) * np.einsum("mf,...mt->...ft", a, diff, optimize=True)
    return float(np.asarray(value).item()), grad.flatten()


def _lbfgsb_nonnegative(setulb: Any, a: np.ndarray, b: np.ndarray, x_init: np.ndarray) -> np.ndarray:
    """L-BFGS-B for ``X ≥ 0`` from ``x_init``, as ``scipy.optimize.fmin_l_bfgs_b`` runs it."""
    shape, n, m = x_init.shape, x_init.size, a.shape[1]
    x = np.clip(x_init.ravel(), np.zeros(n), np.full(n, np.inf))  # float64, as SciPy clips x0
    factr = _FACTR * np.finfo(float).eps / np.finfo(float).eps  # fmin_l_bfgs_b's ftol round trip
    nbd = np.ones(n, np.int32)  # a lower bound (0) on every variable, no upper bound
    low_bnd, upper_bnd = np.zeros(n, np.float64), np.zeros(n, np.float64)
    f: Any = np.array(0.0, dtype=np.float64)
    g = np.zeros(n, dtype=np.float64)
    task = np.zeros(2, dtype=np.int32)
    work = (  # wa, iwa, task, lsave, isave, dsave: setulb's workspace and state, as SciPy sizes them
        np.zeros(2 * m * n + 5 * n + 11 * m * m + 8 * m, np.float64),
        np.zeros(3 * n, dtype=np.int32),
        task,
        np.zeros(4, dtype=np.int32),
        np.zeros(44, dtype=np.int32),
        np.zeros(29, np.float64),
    )
    ln_task = np.zeros(2, dtype=np.int32)
    evaluated_at, cached, evaluations, iterations = x.copy(), _objective(x, shape, a, b), 1, 0
    while True:
        g = g.astype(np.float64)
        setulb(m, x, low_bnd, upper_bnd, nbd, f, g, factr, _PGTOL, *work, _MAXLS, ln_task)
        if task[0] == _TASK_FG:
            if not np.array_equal(x, evaluated_at):  # SciPy's ScalarFunction memoises the last point
                evaluated_at, cached = x.copy(), _objective(x, shape, a, b)
                evaluations += 1
            f, g = cached[0], np.atleast_1d(cached[1])
        elif task[0] == _TASK_NEW_X:
            iterations += 1
            if iterations >= _MAXITER:
                task[0], task[1] = _TASK_STOP, _STOP_MAXITER
            elif evaluations > _MAXFUN:
                task[0], task[1] = _TASK_STOP, _STOP_MAXFUN
        else:
            return x.reshape(shape)


def _pinv_start(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """librosa's start: the pseudo-inverse solution clipped at 0."""
    x = np.einsum("fm,...mt->...ft", np.linalg.pinv(a), b, optimize=True)
    np.clip(x, 0, None, out=x)
    return x


def _fast(setulb: Any, a: np.ndarray, b: np.ndarray, n_columns: int) -> np.ndarray:
    """librosa.util.nnls's column blocks, each solved by :func:`_lbfgsb_nonnegative`."""
    if b.shape[-1] <= n_columns:
        return _lbfgsb_nonnegative(setulb, a, b, _pinv_start(a, b)).astype(a.dtype)
    x = _pinv_start(a, b)
    for start in range(0, x.shape[-1], n_columns):
        stop = min(start + n_columns, b.shape[-1])
        x[..., start:stop] = _lbfgsb_nonnegative(setulb, a, b[..., start:stop], x[..., start:stop])
    return x


def nnls(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """``librosa.util.nnls(a, b)`` for a 2-D ``b`` (``(m, N)``): the same array, without SciPy's
    per-variable bound handling. ``a``: ``(m, d)`` basis; returns ``(d, N)``, non-negative."""
    if b.ndim != 2:
        raise ValueError(f"nnls: b must be (m, N), got shape {b.shape}")
    setulb = _setulb()
    if setulb is not None:
        try:
            return _fast(setulb, a, b, max(int(librosa.util.MAX_MEM_BLOCK // (b.shape[0] * a.itemsize)), 1))
        except TypeError as err:  # a SciPy whose private routine takes other arguments
            reason = f"scipy.optimize._lbfgsb.setulb failed ({err})"
    else:
        reason = "this SciPy has no scipy.optimize._lbfgsb.setulb"
    warnings.warn(f"{reason}; using librosa.util.nnls (same result, slower)", RuntimeWarning, stacklevel=2)
    return np.asarray(librosa.util.nnls(a, b))
