"""The two step types of the planar estimator's iteration (8.62-8.65).

Each step minimises a quadratic form ``U^T Q U`` over one constant 4-vector ``U``
under its normalisation (8.61): the normal part unit (``U^T Ibar U = 1``) or
the third component one (``U^T I U = 1``), plus the fixed zeros ``D U = 0`` of
the single-contact forms.
"""

from __future__ import annotations

import numpy as np

#: smallest eigenvalue ratio of a block we still call determined
RCOND = 1e-12


class Undetermined(Exception):
    """The data do not determine the parameters (reason in the message)."""


def _check(Q: np.ndarray, what: str) -> None:
    w = np.linalg.eigvalsh(Q)
    if not np.all(np.isfinite(w)) or w[-1] <= 0 or w[0] <= RCOND * w[-1]:
        raise Undetermined(f"{what} is singular (eigenvalues {w[0]:.3g} .. {w[-1]:.3g})")


def unit_step(Q: np.ndarray, *, free_a: bool, count: int = 1) -> tuple[list[np.ndarray], np.ndarray]:
    """Minimise ``U^T Q U`` with ``|U[:2]| = 1``: the smallest ``count`` solutions.

    ``free_a=False``: ``U = [z; 0; 0]`` (a tangent ``J_1``, 8.64): the eigenvalue
    problem ``Q_11 z = eta z``.
    ``free_a=True``: ``U = [n; a]`` (a cotangent, 8.62 with ``C = Ibar``): the
    generalised problem ``Q U = eta Ibar U``, whose finite eigenvectors are
    ``n`` from the Schur complement ``Q_nn - Q_na Q_aa^-1 Q_an`` and
    ``a = -Q_aa^-1 Q_an n``. Returns the vectors and their eigenvalues.
    """
    if free_a:
        Qaa = Q[2:, 2:]
        _check(Qaa, "the information on the contact offsets (a)")
        K = np.linalg.solve(Qaa, Q[2:, :2])
        S = Q[:2, :2] - Q[:2, 2:] @ K
        S = 0.5 * (S + S.T)
        w, V = np.linalg.eigh(S)
        out = [np.r_[V[:, j], -K @ V[:, j]] for j in range(count)]
    else:
        w, V = np.linalg.eigh(Q[:2, :2])
        out = [np.r_[V[:, j], 0.0, 0.0] for j in range(count)]
    return out, w[:count]


def affine_step(Q: np.ndarray) -> np.ndarray:
    """Minimise ``U^T Q U`` over ``U = [z; 1; 0]`` (a tangent ``J_2``, 8.65)."""
    _check(Q[:2, :2], "the information on the contact point")
    z = np.linalg.solve(Q[:2, :2], -Q[:2, 2])
    return np.r_[z, 1.0, 0.0]


def aligned(U: np.ndarray, ref: np.ndarray | None) -> np.ndarray:
    """``U`` with the sign of its normal part matching ``ref`` (eigenvectors have no sign)."""
    if ref is not None and U[:2] @ ref[:2] < 0:
        return -U
    return U
