"""Shape checking shared by the estimators (batch axis ``B`` leads after time)."""

from __future__ import annotations

import numpy as np


def as_f64(a, name: str) -> np.ndarray:
    """``a`` as a C-contiguous float64 array (what the numba kernels expect)."""
    try:
        out = np.asarray(a, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{name} must be a numeric array ({exc})") from None
    # ascontiguousarray would turn a 0-d scalar into shape (1,)
    return np.ascontiguousarray(out) if out.ndim else out


def scalar_regression(psi, y) -> tuple[np.ndarray, np.ndarray]:
    """Check a batch of scalar-measurement regressions.

    ``psi`` (N, B, p) and ``y`` (N, B); a single model may be given as
    ``psi`` (N, p) and ``y`` (N,), which is read as B = 1.
    """
    psi = as_f64(psi, "psi")
    y = as_f64(y, "y")
    if y.ndim == 1 and psi.ndim == 2:
        y = y[:, None]
        psi = psi[:, None, :]
    if psi.ndim != 3 or y.ndim != 2:
        raise ValueError(
            f"psi must be (N, B, p) and y (N, B); got psi {psi.shape} and y {y.shape}")
    if psi.shape[:2] != y.shape:
        raise ValueError(f"psi {psi.shape} and y {y.shape} disagree on (N, B)")
    if psi.shape[2] < 1:
        raise ValueError("psi must have at least one regressor (p >= 1)")
    return np.ascontiguousarray(psi), np.ascontiguousarray(y)


def vector_regression(psi, y) -> tuple[np.ndarray, np.ndarray]:
    """Check a batch of vector-measurement regressions.

    ``psi`` (N, B, m, p) and ``y`` (N, B, m).  Scalar measurements may be
    given as ``psi`` (N, B, p) and ``y`` (N, B) (read as m = 1).
    """
    psi = as_f64(psi, "psi")
    y = as_f64(y, "y")
    if y.ndim == 2 and psi.ndim == 3:
        y = y[:, :, None]
        psi = psi[:, :, None, :]
    if psi.ndim != 4 or y.ndim != 3:
        raise ValueError(
            "psi must be (N, B, m, p) with y (N, B, m), or psi (N, B, p) with y (N, B); "
            f"got psi {psi.shape} and y {y.shape}")
    if psi.shape[:3] != y.shape:
        raise ValueError(f"psi {psi.shape} and y {y.shape} disagree on (N, B, m)")
    if psi.shape[3] < 1:
        raise ValueError("psi must have at least one regressor (p >= 1)")
    return np.ascontiguousarray(psi), np.ascontiguousarray(y)


def sqrt_matrix(value, n: int, batch: int, name: str) -> np.ndarray:
    """A batch of lower-triangular square roots (batch, n, n) from a user value.

    Accepts a scalar (``value * I``), a vector of length n (a diagonal of
    standard deviations), an (n, n) lower-triangular factor, or a (batch, n, n)
    stack.  The strictly upper part must be zero: a full matrix is almost
    always a covariance passed by mistake.
    """
    a = as_f64(value, name)
    if a.ndim == 0:
        out = np.broadcast_to(np.eye(n) * float(a), (batch, n, n))
    elif a.ndim == 1:
        if a.shape[0] != n:
            raise ValueError(f"{name} as a vector must have length {n}; got {a.shape[0]}")
        out = np.broadcast_to(np.diag(a), (batch, n, n))
    elif a.ndim == 2:
        if a.shape != (n, n):
            raise ValueError(f"{name} must be ({n}, {n}); got {a.shape}")
        out = np.broadcast_to(a, (batch, n, n))
    elif a.ndim == 3:
        if a.shape != (batch, n, n):
            raise ValueError(f"{name} must be ({batch}, {n}, {n}); got {a.shape}")
        out = a
    else:
        raise ValueError(f"{name} must be a scalar, (n,), (n, n) or (B, n, n); got {a.shape}")
    out = np.array(out, dtype=np.float64, order="C")
    if np.any(np.triu(out, 1) != 0.0):
        raise ValueError(f"{name} must be a lower-triangular square root (e.g. "
                         "numpy.linalg.cholesky of the covariance), not a full matrix")
    if not np.all(np.isfinite(out)):
        raise ValueError(f"{name} must be finite")
    return out


def batch_vector(value, n: int, batch: int, name: str) -> np.ndarray:
    """A (batch, n) array from a scalar, an (n,) vector or a (batch, n) array."""
    a = as_f64(value, name)
    if a.ndim == 0:
        a = np.full(n, float(a))
    if a.ndim == 1:
        if a.shape[0] != n:
            raise ValueError(f"{name} must have length {n}; got {a.shape[0]}")
        a = np.broadcast_to(a, (batch, n))
    if a.shape != (batch, n):
        raise ValueError(f"{name} must be ({n},) or ({batch}, {n}); got {a.shape}")
    return np.array(a, dtype=np.float64, order="C")


def batch_mask(mask, batch: int) -> np.ndarray:
    """A boolean (batch,) mask: None means all, else indices or booleans."""
    if mask is None:
        return np.ones(batch, dtype=bool)
    m = np.asarray(mask)
    if m.dtype == bool:
        if m.shape != (batch,):
            raise ValueError(f"mask must have shape ({batch},); got {m.shape}")
        return m
    out = np.zeros(batch, dtype=bool)
    out[m.astype(np.intp)] = True
    return out
