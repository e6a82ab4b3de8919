"""Information matrices of the planar constraint estimator (eqs 8.57-8.60).

A planar contact model is a pair of constant 4-vectors ``(U_1, U_2)`` with
curvature matrices ``C_1(x), C_2(x)`` so that ``P C_k(x) U_k`` is a basis field
of one bundle; the third field is ``V(x) = U_1(x) x U_2(x)`` (8.49). For one
contact the ``U`` are the two tangents (measured against the wrench) and ``V``
the cotangent (measured against the velocity); for two contacts the ``U`` are
the two cotangents (measured against the velocity) and ``V`` the tangent
(measured against the wrench).

The residuals are ``V(x_i)^T u_i = U_1^T M_i U_2`` with
``M_i = -C_1(x_i)^T P^T [u_i]_x P C_2(x_i)``, ``U_1(x_i)^T v_i`` and
``U_2(x_i)^T v_i``. Their mean squares are quadratic forms in constant
matrices of the data: ``I_u`` (the 4x4x4x4 tensor ``mean M_i (x) M_i``, 8.57)
and ``I_v1``, ``I_v2`` (8.58-8.59). The iteration works on these small
matrices only, and :meth:`PlanarInformation.update` adds samples recursively.
"""

from __future__ import annotations

import numpy as np


def _skew(u: np.ndarray) -> np.ndarray:
    """Cross-product matrices ``[u]_x`` of ``(N, 3)`` vectors; ``(N, 3, 3)``."""
    S = np.zeros(u.shape[:-1] + (3, 3))
    S[..., 0, 1], S[..., 0, 2] = -u[..., 2], u[..., 1]
    S[..., 1, 0], S[..., 1, 2] = u[..., 2], -u[..., 0]
    S[..., 2, 0], S[..., 2, 1] = -u[..., 1], u[..., 0]
    return S


def bilinear(C1: np.ndarray, C2: np.ndarray, u: np.ndarray) -> np.ndarray:
    """``M_i`` with ``U_1^T M_i U_2 = (P C_1 U_1) x (P C_2 U_2) . u_i``; ``(N, 4, 4)``."""
    return -np.einsum("nka,nkl,nlb->nab", C1[:, :3, :], _skew(u), C2[:, :3, :])


def projected(C: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Rows ``C_i^T P^T v_i`` so that ``U(x_i)^T v_i = row_i . U``; ``(N, 4)``."""
    return np.einsum("nka,nk->na", C[:, :3, :], v)


class PlanarInformation:
    """Sufficient statistics (8.57-8.59) for one contact model, updated recursively.

    Parameters
    ----------
    curvature : callable ``x -> (C_1(x), C_2(x))``, each ``(N, 4, 4)``
    """

    def __init__(self, curvature):
        self.curvature = curvature
        self.n = 0
        self._Iu = np.zeros((4, 4, 4, 4))
        self._Iv1 = np.zeros((4, 4))
        self._Iv2 = np.zeros((4, 4))

    def update(self, x: np.ndarray, u: np.ndarray, v: np.ndarray) -> PlanarInformation:
        """Add samples: configurations ``x``, V-measurements ``u``, U-measurements ``v``."""
        x, u, v = (np.atleast_2d(np.asarray(a, float)) for a in (x, u, v))
        C1, C2 = self.curvature(x)
        M = bilinear(C1, C2, u)
        self._Iu += np.einsum("nab,ncd->abcd", M, M)
        g1, g2 = projected(C1, v), projected(C2, v)
        self._Iv1 += g1.T @ g1
        self._Iv2 += g2.T @ g2
        self.n += len(x)
        return self

    @property
    def Iu(self) -> np.ndarray:
        """(8.57) as the tensor ``I[a,b,c,d] = mean M_i[a,b] M_i[c,d]``."""
        return self._Iu / max(self.n, 1)

    @property
    def Iv1(self) -> np.ndarray:
        """(8.58)."""
        return self._Iv1 / max(self.n, 1)

    @property
    def Iv2(self) -> np.ndarray:
        """(8.59)."""
        return self._Iv2 / max(self.n, 1)

    def given_u2(self, U2: np.ndarray) -> np.ndarray:
        """``T_e(U_2)^T I_u T_e(U_2) + I_v1``: the form in ``U_1`` of (8.62, 8.64)."""
        return np.einsum("abcd,b,d->ac", self.Iu, U2, U2) + self.Iv1

    def given_u1(self, U1: np.ndarray) -> np.ndarray:
        """``T'_e(U_1)^T I_u T'_e(U_1) + I_v2``: the form in ``U_2`` of (8.63, 8.65)."""
        return np.einsum("abcd,a,c->bd", self.Iu, U1, U1) + self.Iv2

    def criterion(self, U1: np.ndarray, U2: np.ndarray) -> float:
        """The trace criterion (8.60), to be minimised."""
        return float(U1 @ self.given_u2(U2) @ U1 + U2 @ self.Iv2 @ U2)
