"""Two planar contacts: AA, BB, AB and line-line (8.1.3.1, 8.1.3.4).

The unknowns are the two constant cotangent vectors ``U_k = Y_k = [+-n_k; a_k]``
(8.39, 8.45) with ``|n_k| = 1``; the tangent is ``V(x) = Y_1(x) x Y_2(x)``
(8.49). Procedures (8.1.3.4):

* same type (AA, BB): the two equations (8.62)/(8.63) are redundant, so both
  vectors are the two finite generalised eigenvectors of one equation,
  ``(T_e(U_2)^T I_u T_e(U_2) + I_v1) U = eta Ibar U``, iterated with ``U_2``
  taken from the previous pair until the pair's span stops moving. The start
  uses ``I_v1`` alone. Only the span is identified: every basis of it is an
  equivalent mechanism (compare estimates with :mod:`contactlab.planar.tableau`).
* different types (AB): alternate (8.62) and (8.63), each time taking the
  eigenvector of the smallest eigenvalue; the start is the smallest
  eigenvector of ``I_v1`` and of ``I_v2``.
* line-line (two contacts along one line, or an edge flush on an edge): the
  configuration-space constraint is a straight line, ``theta = theta_0`` and
  ``n^T r = d``; the cotangents are ``[n; 0]`` and ``[0; 0; 1]``. The normal is
  the eigenvector of the smallest eigenvalue of
  ``sum v v^T + X^T (sum f f^T) X`` (translational velocity across the line,
  force along it); the contact locations along the line are undetermined.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from contactlab.planar.geometry import X, curvature_cotangent
from contactlab.planar.information import PlanarInformation
from contactlab.planar.steps import Undetermined, aligned, unit_step

PAIRS = {"AA": ("A", "A"), "BB": ("B", "B"), "AB": ("A", "B")}


@dataclass
class DoubleFit:
    """Result in the estimator's (scaled) units."""

    kind: str
    Y1: np.ndarray
    Y2: np.ndarray
    iterations: int
    converged: bool
    criterion: float
    history: list


def information(kind: str) -> PlanarInformation:
    """Empty information for a two-contact ``kind`` (U = cotangents)."""
    k1, k2 = PAIRS[kind]
    return PlanarInformation(lambda x: (curvature_cotangent(k1, x), curvature_cotangent(k2, x)))


def _span_projector(Y1: np.ndarray, Y2: np.ndarray) -> np.ndarray:
    Q, _ = np.linalg.qr(np.column_stack([Y1, Y2]))
    return Q @ Q.T


def fit_double(info: PlanarInformation, kind: str, *, tol: float = 1e-10,
               max_iter: int = 100) -> DoubleFit:
    """The coupled generalised-eigenvalue iteration (8.62-8.63) for AA, BB or AB."""
    same = kind in ("AA", "BB")
    history = []
    converged = False
    it = 0
    if same:
        (Y1, Y2), _ = unit_step(info.Iv1, free_a=True, count=2)
        P = _span_projector(Y1, Y2)
        for it in range(1, max_iter + 1):
            (A, B), _ = unit_step(info.given_u2(Y2), free_a=True, count=2)
            # keep the labels: Y2 is the new vector whose normal is nearer the old Y2's
            if abs(A[:2] @ Y2[:2]) > abs(B[:2] @ Y2[:2]):
                A, B = B, A
            Y1, Y2 = aligned(A, Y1), aligned(B, Y2)
            P_new = _span_projector(Y1, Y2)
            delta = np.abs(P_new - P).max()
            P = P_new
            history.append(info.criterion(Y1, Y2))
            if delta < tol:
                converged = True
                break
    else:
        (Y1,), _ = unit_step(info.Iv1, free_a=True)
        (Y2,), _ = unit_step(info.Iv2, free_a=True)
        for it in range(1, max_iter + 1):
            (Y1n,), _ = unit_step(info.given_u2(Y2), free_a=True)
            Y1n = aligned(Y1n, Y1)
            (Y2n,), _ = unit_step(info.given_u1(Y1n), free_a=True)
            Y2n = aligned(Y2n, Y2)
            delta = max(np.abs(Y1n - Y1).max() / (1 + np.abs(Y1).max()),
                        np.abs(Y2n - Y2).max() / (1 + np.abs(Y2).max()))
            Y1, Y2 = Y1n, Y2n
            history.append(info.criterion(Y1, Y2))
            if delta < tol:
                converged = True
                break
    return DoubleFit(kind, Y1, Y2, it, converged, history[-1], history)


@dataclass
class LineFit:
    """Line-line result in scaled units: normal, and the eigenvalues used."""

    normal: np.ndarray
    eigenvalues: np.ndarray


def fit_line_line(velocity: np.ndarray, wrench: np.ndarray) -> LineFit:
    """Closed-form normal of a line-line contact (one eigenproblem, no iteration)."""
    v, f = velocity[:, :2], wrench[:, :2]
    Q = (v.T @ v + X.T @ (f.T @ f) @ X) / len(v)
    w, V = np.linalg.eigh(Q)
    if w[1] <= 0 or w[0] > (1 - 1e-12) * w[1]:
        raise Undetermined("line-line: no direction of motion or force singles out the line")
    return LineFit(V[:, 0], w)
