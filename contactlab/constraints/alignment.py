"""Alignment error between an estimated and a true frame (8.1.1.2, tables 8.1-8.5).

"This was compared to an assumed true P by computing the singular value
decomposition of P_hat^T P = U Sigma V.  If the two projection matrices were
equivalent, the singular values would all be one.  Since the singular values
are the direction cosines of the misalignment, any deviation from one can be
mapped to a positive angular error.  We assumed a log-normal distribution for
the deviation of the minimum singular value from 1."

The "equivalent mean angular error" of the tables is ``arccos(1 - exp(mu))``
(checked against table 8.1: mu = -10.9 gives 0.35 deg, -5.09 gives 6.3 deg).
The tables' "std of log-normal sigma sqrt(n)" does not say which n; we report
sigma and, when a sample size is given, sigma * sqrt(sample size).
"""

from __future__ import annotations

import math

import numpy as np

from contactlab.errors import UsageError

#: deviations at or below this are rounding: the frame was exact (the tables' NA)
EXACT = 1e-12

__all__ = ["direction_cosines", "alignment_deviation", "angular_error_deg",
           "joint_projection", "lognormal_summary", "equivalent_angle_deg"]


def direction_cosines(P_hat, P) -> np.ndarray:
    """Singular values of ``P_hat^T P`` (descending): the cosines of the principal
    angles between the column spaces.  Works on stacks (..., r, c)."""
    P_hat = np.asarray(P_hat, dtype=np.float64)
    P = np.asarray(P, dtype=np.float64)
    if P_hat.shape[-2] != P.shape[-2]:
        raise UsageError(f"frames live in different spaces: {P_hat.shape} vs {P.shape}")
    if P_hat.shape[-1] == 0 or P.shape[-1] == 0:
        return np.ones(P_hat.shape[:-2] + (0,))
    s = np.linalg.svd(np.swapaxes(P_hat, -1, -2) @ P, compute_uv=False)
    return np.clip(s, 0.0, 1.0)


def alignment_deviation(P_hat, P) -> np.ndarray:
    """``1 - min singular value`` of ``P_hat^T P`` (0 = same subspace; 0 when empty)."""
    s = direction_cosines(P_hat, P)
    if s.shape[-1] == 0:
        return np.zeros(s.shape[:-1])
    return 1.0 - s.min(axis=-1)


def angular_error_deg(P_hat, P) -> np.ndarray:
    """Largest principal angle (deg) between the column spaces of P_hat and P."""
    s = direction_cosines(P_hat, P)
    if s.shape[-1] == 0:
        return np.zeros(s.shape[:-1])
    return np.degrees(np.arccos(s.min(axis=-1)))


def joint_projection(normals, free=None) -> np.ndarray:
    """The joint (2k x k) projection ``[[N, 0], [0, T]]`` of 8.21 from unit normals
    (k, m); ``free`` defaults to an orthonormal complement of the normals."""
    N = np.asarray(normals, dtype=np.float64)
    k, m = N.shape
    if free is None:
        q, _ = np.linalg.qr(np.concatenate([N, np.eye(k)], axis=1))
        free = q[:, m:k] if m else np.eye(k)
    T = np.asarray(free, dtype=np.float64)
    P = np.zeros((2 * k, k))
    P[:k, :m] = N
    P[k:, m:] = T
    return P


def equivalent_angle_deg(mu: float) -> float:
    """The angle whose ``1 - cos`` is ``exp(mu)``: the tables' equivalent mean error."""
    return math.degrees(math.acos(max(-1.0, 1.0 - math.exp(mu))))


def lognormal_summary(deviations, *, sample_size: int | None = None) -> dict:
    """Log-normal fit of the deviations ``1 - min singular value`` (tables 8.1-8.5).

    Returns ``mu`` and ``sigma`` (mean and std of ``log deviation``),
    ``sigma_sqrt_n`` (``sigma * sqrt(sample_size)``, None without a size),
    ``angle_deg`` (``arccos(1 - exp(mu))``) and ``count``.  Zero deviations
    (a frame with nothing to estimate: the thesis's NA) give ``mu = None``,
    ``angle_deg = 0``.
    """
    d = np.asarray(deviations, dtype=np.float64).reshape(-1)
    d = d[np.isfinite(d)]
    out = {"count": int(d.size), "mu": None, "sigma": None, "sigma_sqrt_n": None,
           "angle_deg": None, "zero": int((d <= EXACT).sum())}
    if d.size == 0:
        return out
    pos = d[d > EXACT]
    if pos.size < d.size / 2:             # mostly exact: nothing to estimate (NA)
        out["angle_deg"] = 0.0
        return out
    logs = np.log(pos)
    mu = float(logs.mean())
    sigma = float(logs.std(ddof=1)) if logs.size > 1 else 0.0
    out.update(mu=mu, sigma=sigma, angle_deg=equivalent_angle_deg(mu),
               sigma_sqrt_n=None if sample_size is None else sigma * math.sqrt(sample_size))
    return out
