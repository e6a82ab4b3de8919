"""One planar contact, type A or B (8.1.3.3): the two-step iteration (8.64-8.67).

The unknowns are the constant tangent vectors ``U_1 = J_1 = [n_dot; 0; 0]``
and ``U_2 = J_2 = [p_dot; 1; 0]`` (8.41-8.42, 8.47-8.48). Each sweep solves the
eigenvalue problem ``I_11 n_dot = eta n_dot`` of (8.64) for ``U_1`` given
``U_2``, then the linear equation of (8.65) for ``U_2`` given ``U_1``. The
start is ``p_dot = 0``. The geometry follows from (8.66) (type B:
``n_dot = X n``, ``p_dot = X^T p``) and (8.67) (type A: ``n_dot = X^T n``,
``p_dot = X^T p``).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from contactlab.planar.geometry import X, curvature_tangents
from contactlab.planar.information import PlanarInformation
from contactlab.planar.steps import affine_step, aligned, unit_step


@dataclass
class SingleFit:
    """Result of the iteration in the estimator's (scaled) units."""

    kind: str
    normal: np.ndarray
    point: np.ndarray
    U1: np.ndarray
    U2: np.ndarray
    iterations: int
    converged: bool
    criterion: float
    history: list


def information(kind: str) -> PlanarInformation:
    """Empty information for a single contact of ``kind`` (U = tangents)."""
    return PlanarInformation(lambda x: curvature_tangents(kind, x))


def fit_single(info: PlanarInformation, kind: str, *, tol: float = 1e-10,
               max_iter: int = 100) -> SingleFit:
    """Iterate (8.64)/(8.65) until ``U_1, U_2`` change by less than ``tol``."""
    U2 = np.array([0.0, 0.0, 1.0, 0.0])
    U1 = None
    history = []
    converged = False
    it = 0
    for it in range(1, max_iter + 1):
        (U1_new,), _ = unit_step(info.given_u2(U2), free_a=False)
        U1_new = aligned(U1_new, U1)
        U2_new = affine_step(info.given_u1(U1_new))
        delta = (np.inf if U1 is None else
                 max(np.abs(U1_new - U1).max(), np.abs(U2_new - U2).max() / (1 + np.abs(U2).max())))
        U1, U2 = U1_new, U2_new
        history.append(info.criterion(U1, U2))
        if delta < tol:
            converged = True
            break
    ndot, pdot = U1[:2], U2[:2]
    normal = X.T @ ndot if kind == "B" else X @ ndot       # (8.66) / (8.67)
    point = X @ pdot
    return SingleFit(kind, normal, point, U1, U2, it, converged, history[-1], history)
