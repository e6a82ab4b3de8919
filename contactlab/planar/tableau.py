"""The tangent-space tableau (8.50-8.56): compare two-contact models up to equivalence.

For two contacts the tangent field ``J(x) = Y_1(x) x Y_2(x)`` is linear in a
fixed feature vector of the configuration, ``J(x) = J_T f(x)``; ``J_T`` is the
tangent-space tableau. Two descriptions of the geometry are equivalent (same
configuration-space curve, 4.2.4) exactly when their tableaux are
proportional, so estimates are compared through normalised tableaux.

Features (8.51, 8.54, 8.56): BB ``(cos t, sin t, 1)``; AA
``(cos 2t, sin 2t, r1, r2, 1)``; AB ``(cos 2t, sin 2t, r1 c, r2 c, r1 s,
r2 s, c, s, 1)``. :func:`tableau` fits ``J_T`` from ``J(x)`` at a fixed design
of configurations (exact up to rounding; the fit residual is checked), and
:func:`tableau_bb` is the closed form (8.50).
"""

from __future__ import annotations

import numpy as np

from contactlab.planar.geometry import Contact, cotangent

FEATURES = {
    "BB": ("cos", "sin", "1"),
    "AA": ("cos2", "sin2", "r1", "r2", "1"),
    "AB": ("cos2", "sin2", "r1 cos", "r2 cos", "r1 sin", "r2 sin", "cos", "sin", "1"),
}


def pair_kind(c1: Contact, c2: Contact) -> str:
    """'AA', 'BB' or 'AB' (the A contact must come first for 'AB')."""
    kind = c1.kind + c2.kind
    if kind == "BA":
        raise ValueError("order a mixed pair as (A contact, B contact)")
    return kind


def features(kind: str, x) -> np.ndarray:
    """The feature vectors ``f(x)`` of (8.51), (8.54), (8.56); ``(N, m)``."""
    x = np.atleast_2d(np.asarray(x, float))
    r1, r2, t = x[:, 0], x[:, 1], x[:, 2]
    c, s, one = np.cos(t), np.sin(t), np.ones(len(x))
    if kind == "BB":
        cols = (c, s, one)
    elif kind == "AA":
        cols = (np.cos(2 * t), np.sin(2 * t), r1, r2, one)
    elif kind == "AB":
        cols = (np.cos(2 * t), np.sin(2 * t), r1 * c, r2 * c, r1 * s, r2 * s, c, s, one)
    else:
        raise ValueError(f"no tableau for kind {kind!r}")
    return np.column_stack(cols)


def _design(n: int = 64) -> np.ndarray:
    rng = np.random.default_rng(20240501)
    return np.column_stack([rng.normal(0, 3, n), rng.normal(0, 3, n), rng.uniform(-np.pi, np.pi, n)])


def tableau(c1: Contact, c2: Contact) -> np.ndarray:
    """``J_T`` with ``Y_1(x) x Y_2(x) = J_T f(x)`` (8.50-8.56); ``(3, m)``."""
    kind = pair_kind(c1, c2)
    x = _design()
    J = np.cross(cotangent(c1, x), cotangent(c2, x))
    F = features(kind, x)
    T, *_ = np.linalg.lstsq(F, J, rcond=None)
    err = np.abs(F @ T - J).max()
    if err > 1e-8 * max(1.0, np.abs(J).max()):
        raise ArithmeticError(f"{kind} tangent field is not linear in the tableau features ({err:.3g})")
    return T.T


def tableau_bb(n, a, m, b) -> np.ndarray:
    """The closed form (8.50) for two type B contacts ``Y_n = [n; a]``, ``Y_m = [m; b]``."""
    n1, n2 = n
    m1, m2 = m
    a1, a2 = a
    b1, b2 = b
    return np.array([[n2 * b1 - m2 * a1, m2 * a2 - n2 * b2, 0.0],
                     [m1 * a1 - n1 * b1, n1 * b2 - m1 * a2, 0.0],
                     [0.0, 0.0, n1 * m2 - n2 * m1]])


def distance(T1: np.ndarray, T2: np.ndarray) -> float:
    """Sign- and scale-free distance of two tableaux: ``sqrt(2 (1 - |cos angle|))``."""
    a, b = np.ravel(T1), np.ravel(T2)
    cos = abs(a @ b) / (np.linalg.norm(a) * np.linalg.norm(b))
    return float(np.sqrt(max(0.0, 2.0 * (1.0 - min(cos, 1.0)))))


def equivalent(T1: np.ndarray, T2: np.ndarray, *, tol: float = 1e-6) -> bool:
    """True when the two tableaux are proportional (equivalent mechanisms)."""
    return distance(T1, T2) < tol


def equivalent_bb(c1: Contact, c2: Contact, *, normal) -> tuple[Contact, Contact]:
    """An equivalent BB pair whose first normal is ``normal`` (solves 8.52).

    ``J_T(3,3) = n x m`` fixes the second normal ``m`` (the root with
    ``n . m`` of the original's sign); (8.52) then gives ``a`` and ``b``.
    """
    T = tableau(c1, c2)
    n = np.asarray(normal, float) / np.linalg.norm(normal)
    z5 = T[2, 2]
    dot0 = c1.n @ c2.n
    cos = np.sqrt(max(0.0, 1 - z5 ** 2)) * (1 if dot0 >= 0 else -1)
    # m with n1 m2 - n2 m1 = z5 and n . m = cos
    m = cos * n + z5 * np.array([-n[1], n[0]])
    n1, n2 = n
    m1, m2 = m
    A = np.array([[-m2, 0, n2, 0], [0, m2, 0, -n2], [m1, 0, -n1, 0], [0, -m1, 0, n1]])
    rhs = np.array([T[0, 0], T[0, 1], T[1, 0], T[1, 1]])
    a1, a2, b1, b2 = np.linalg.solve(A, rhs)
    y1, y2 = np.r_[n, a1, a2], np.r_[m, b1, b2]
    return (Contact.from_cotangent_vector("B", y1, distance=0.0),
            Contact.from_cotangent_vector("B", y2, distance=0.0))
