"""Householder kernels shared by the square-root estimators (appendix A.2).

Every square-root step of appendix A has the same shape: a lower-triangular
factor ``L`` with some columns ``Z`` appended is post-multiplied by an
orthogonal matrix ``T`` so that the appended columns vanish::

    [L  Z] T = [L'  0]        =>    L' L'^T = L L^T + Z Z^T

This is A.10 (information update, ``Z = psi^T``), A.33 (Kalman pre-array,
after a column permutation, see :mod:`contactlab.estimators.kalman`), A.38
(running innovation variance, ``Z = sqrt(1/n) nu``) and A.41 (correlation
structure).  :func:`tri_append` does it with one Householder reflection per
row: row ``i`` of ``[L Z]`` has non-zeros only in column ``i`` of ``L`` and in
``Z`` (``L`` is lower-triangular and the rows above are already reduced), so
the reflection acts on the ``1 + k`` entries ``[L[i, i], Z[i, :]]`` and costs
``O(q k)`` per row, ``O(q^2 k)`` in all.

Conventions: ``L`` is lower-triangular with a non-negative diagonal (the
reflection is chosen so that the new diagonal entry is ``+norm``; the
Cholesky-like factor is then unique where it is non-singular).  The kernels
work in place on C-contiguous float64 arrays and allocate nothing.
"""

from __future__ import annotations

import math

import numba
import numpy as np

__all__ = ["tri_append", "tri_append_n", "forward_subst", "back_subst_t"]


@numba.njit(cache=True)
def tri_append(L, Z):
    """Triangularise ``[L Z]`` in place: ``[L Z] T = [L' 0]``.

    Parameters
    ----------
    L : (q, q) float64, lower-triangular; overwritten by ``L'`` with
        ``L' L'^T = L L^T + Z Z^T`` and a non-negative diagonal.
    Z : (q, k) float64; destroyed (set to zero).

    For each row ``i`` the Householder vector is ``v = x - ||x|| e_0`` with
    ``x = [L[i, i], Z[i, :]]``; when ``L[i, i] > 0`` its first entry is formed
    as ``-s / (L[i, i] + ||x||)`` (Parlett) to avoid cancellation, so the
    reflected diagonal is ``+||x||`` in both cases.
    """
    tri_append_n(L, Z, L.shape[0], Z.shape[1])


@numba.njit(cache=True)
def tri_append_n(L, Z, q, k):
    """:func:`tri_append` on the leading ``q x q`` block of ``L`` and ``q x k`` block of
    ``Z`` (scratch arrays larger than the factor: no views in compiled loops)."""
    for i in range(q):
        s = 0.0
        for j in range(k):
            s += Z[i, j] * Z[i, j]
        a = L[i, i]
        if s == 0.0:
            if a < 0.0:
                for r in range(i, q):
                    L[r, i] = -L[r, i]
            continue
        nrm = math.sqrt(a * a + s)
        if a <= 0.0:
            v0 = a - nrm
        else:
            v0 = -s / (a + nrm)
        beta = 2.0 / (v0 * v0 + s)
        for r in range(i + 1, q):
            w = L[r, i] * v0
            for j in range(k):
                w += Z[r, j] * Z[i, j]
            w *= beta
            L[r, i] -= w * v0
            for j in range(k):
                Z[r, j] -= w * Z[i, j]
        L[i, i] = nrm
        for j in range(k):
            Z[i, j] = 0.0


@numba.njit(cache=True)
def forward_subst(L, b, x, n):
    """Solve ``L[:n, :n] x[:n] = b[:n]`` (lower-triangular) into ``x``.

    A zero pivot gives NaN for that entry (and so for the entries after it):
    the direction carries no information yet.
    """
    for i in range(n):
        s = b[i]
        for j in range(i):
            s -= L[i, j] * x[j]
        d = L[i, i]
        if d != 0.0:
            x[i] = s / d
        else:
            x[i] = np.nan


@numba.njit(cache=True)
def back_subst_t(L, b, x, n):
    """Solve ``L[:n, :n]^T x[:n] = b[:n]`` (``L`` lower-triangular) into ``x``."""
    for i in range(n - 1, -1, -1):
        s = b[i]
        for j in range(i + 1, n):
            s -= L[j, i] * x[j]
        d = L[i, i]
        if d != 0.0:
            x[i] = s / d
        else:
            x[i] = np.nan
