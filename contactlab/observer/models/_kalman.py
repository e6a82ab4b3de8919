"""Batched square-root Kalman instances for the linear feature models (A.32-A.42).

The state of ``U`` instances of a ``C``-channel model is held as arrays with
axes ``(U, C, ...)`` and advanced by the estimators' compiled kernel
(:func:`contactlab.estimators.kalman.kalman_step`, the stateless step behind
:class:`~contactlab.estimators.SquareRootKalman` and
:class:`~contactlab.estimators.OrthogonalKalman`) with ``B = U * C`` scalar
filters, so instances can be added and dropped without rebuilding objects.
"""

from __future__ import annotations

import numpy as np

from contactlab.estimators.kalman import MODE_PLAIN, STRUCTURES, kalman_step

MODES = STRUCTURES
__all__ = ["MODES", "MODE_PLAIN", "prior_state", "repeat_state", "run_kalman", "as_channel_prior"]


def prior_state(n_units: int, theta_mean: np.ndarray, theta_sqrt: np.ndarray,
                noise_var: np.ndarray, structure_sqrt: np.ndarray) -> dict:
    """State of ``n_units`` instances at the prior: (U, C, ...) arrays."""
    C, q = theta_mean.shape

    def tile(a):
        return np.array(np.broadcast_to(a, (n_units,) + a.shape), dtype=np.float64, order="C")

    lv = np.sqrt(noise_var).reshape(C, 1, 1)
    return {"theta": tile(theta_mean), "S": tile(theta_sqrt), "Lv": tile(lv), "Ve": tile(lv),
            "vcount": np.zeros((n_units, C)), "Ls": tile(structure_sqrt)}


def repeat_state(template: dict, n_units: int) -> dict:
    """``n_units`` copies of a one-instance state (:func:`prior_state` with one unit)."""
    if n_units == 1:
        return {k: v.copy() for k, v in template.items()}
    return {k: np.repeat(v, n_units, axis=0) for k, v in template.items()}


def run_kalman(state: dict, psi: np.ndarray, y: np.ndarray, *, mode: int,
               estimate_noise: bool = False, noise_prior_count: float = 8.0):
    """Advance every instance: ``psi`` (N, U, C, q), or (N, C, q) shared by the U
    instances; ``y`` (N, U, C), or (N, C) shared.

    Returns ``(loglik, stat)``: (N, U) per-sample log-likelihoods (A.39, summed
    over the independent channels) and (N, U, 2) detector statistics,
    ``sum_c alpha_c^2`` (6.11 with a diagonal innovation covariance, m = C) and
    ``sum_c alpha_c / sqrt(C)`` (the normalised innovation, N(0, 1) under the model).
    """
    U = len(state["theta"])
    N, C, q = y.shape[0], y.shape[-1], psi.shape[-1]
    B = U * C
    if N == 0 or U == 0:
        return np.zeros((N, U)), np.zeros((N, U, 2))
    psi4 = np.empty((N, U, C, q))
    psi4[...] = psi if psi.ndim == 4 else psi[:, None]
    y3 = np.empty((N, U, C))
    y3[...] = y if y.ndim == 3 else y[:, None]
    # (U, C, ...) state arrays as (B, ...) views: the kernel updates them in place
    res = kalman_step(psi4.reshape(N, B, 1, q), y3.reshape(N, B, 1),
                      theta=state["theta"].reshape(B, q), theta_sqrt=state["S"].reshape(B, q, q),
                      noise_sqrt=state["Lv"].reshape(B, 1, 1), noise_est=state["Ve"].reshape(B, 1, 1),
                      noise_count=state["vcount"].reshape(B),
                      structure_sqrt=state["Ls"].reshape(B, q, q), structure=mode,
                      estimate_noise=bool(estimate_noise),
                      noise_prior_count=float(noise_prior_count))
    stat = np.empty((N, U, 2))
    if C == 1:
        loglik = res.loglik
        np.multiply(res.change_stat, -2.0, out=stat[..., 0])
        stat[..., 1] = res.alpha.reshape(N, U)
    else:
        loglik = res.loglik.reshape(N, U, C).sum(axis=2)
        stat[..., 0] = (-2.0 * res.change_stat).reshape(N, U, C).sum(axis=2)
        stat[..., 1] = res.alpha.reshape(N, U, C).sum(axis=2) * (1.0 / np.sqrt(C))
    return loglik, stat


def as_channel_prior(theta_mean, theta_sqrt, noise_var, q: int, name: str):
    """Check/broadcast a prior to ``(C, q)``, ``(C, q, q)``, ``(C,)`` (C may be None: shared)."""
    m = np.asarray(theta_mean, dtype=np.float64)
    s = np.asarray(theta_sqrt, dtype=np.float64)
    v = np.asarray(noise_var, dtype=np.float64)
    if m.ndim == 1:
        m = m[None]
    if s.ndim == 1:
        s = np.diag(s)
    if s.ndim == 2:
        s = s[None]
    v = v.reshape(-1)
    C = max(m.shape[0], s.shape[0], v.shape[0])
    try:
        m = np.broadcast_to(m, (C, q)).copy()
        s = np.broadcast_to(s, (C, q, q)).copy()
        v = np.broadcast_to(v, (C,)).copy()
    except ValueError:
        raise ValueError(f"{name}: prior shapes disagree (theta_mean {np.shape(theta_mean)}, "
                         f"theta_sqrt {np.shape(theta_sqrt)}, noise_var {np.shape(noise_var)}; "
                         f"q = {q})") from None
    if np.any(np.triu(s, 1) != 0):
        raise ValueError(f"{name}: theta_sqrt must be lower-triangular (cholesky of the covariance)")
    if not (np.all(np.isfinite(m)) and np.all(np.isfinite(s)) and np.all(v > 0)):
        raise ValueError(f"{name}: prior must be finite with noise_var > 0")
    return m, s, v
