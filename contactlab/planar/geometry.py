"""Planar polygon contact geometry (thesis 4.2, 8.1.2, eqs 8.30-8.48).

Configurations are ``x = (r_x, r_y, theta)`` (8.30), wrenches ``(f_x, f_y, tau)``.
The two contact types follow the thesis's own definitions (8.1.2 and 4.2):

* **type B**: a vertex of the moving polygon on an edge of the environment.
  The edge (unit normal ``n``, distance ``d``) is fixed in the world; the vertex
  ``p`` is in the moving frame. Constraint (8.33): ``n^T (R p + r) - d = 0``.
* **type A**: an edge of the moving polygon on a vertex of the environment.
  The edge (``n``, ``d``) is in the moving frame; the vertex ``p`` is in the world.
  Constraint (8.35): ``n^T R^T (p - r) - d = 0``.

Sign convention: ``C > 0`` is free space, so the contact wrench on the moving
body is ``lambda * dC/dx`` with ``lambda >= 0``: along ``+n`` for type B and
``-R n`` for type A (``n`` is the outward normal of the edge).

Every function is vectorised over the leading axis of ``x`` (shape ``(N, 3)``).
The 4x4 curvature matrices (8.39, 8.41-8.42, 8.45, 8.47-8.48) write each
cotangent / tangent field as ``P C(x) U`` with a constant 4-vector ``U`` and
``P`` keeping the first three components.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: the planar cross-product matrix X of (8.36)
X = np.array([[0.0, -1.0], [1.0, 0.0]])
KINDS_SINGLE = ("A", "B")


def rot(theta) -> np.ndarray:
    """Rotation matrices R(theta) (8.30), shape ``theta.shape + (2, 2)``."""
    theta = np.asarray(theta, dtype=float)
    c, s = np.cos(theta), np.sin(theta)
    return np.stack([np.stack([c, -s], -1), np.stack([s, c], -1)], -2)


def angle_of(v) -> float:
    """Angle of a 2-vector in (-pi, pi]."""
    return float(np.arctan2(v[1], v[0]))


def unit(angle: float) -> np.ndarray:
    """The unit 2-vector at ``angle``."""
    return np.array([np.cos(angle), np.sin(angle)])


@dataclass(frozen=True)
class Contact:
    """One point-on-line contact between planar polygons.

    kind : "A" (moving edge on a fixed vertex) or "B" (moving vertex on a fixed edge)
    normal : unit outward normal of the edge (world frame for B, moving frame for A)
    distance : the edge's distance from its frame's origin along ``normal``
    point : the vertex (moving frame for B, world frame for A)
    """

    kind: str
    normal: tuple[float, float]
    distance: float
    point: tuple[float, float]

    def __post_init__(self):
        if self.kind not in KINDS_SINGLE:
            raise ValueError(f"contact kind must be 'A' or 'B', not {self.kind!r}")
        n = np.asarray(self.normal, dtype=float)
        if n.shape != (2,) or not np.isclose(np.hypot(*n), 1.0, atol=1e-9):
            raise ValueError("contact normal must be a unit 2-vector")
        object.__setattr__(self, "normal", (float(n[0]), float(n[1])))
        object.__setattr__(self, "point", tuple(float(v) for v in self.point))
        object.__setattr__(self, "distance", float(self.distance))

    @property
    def n(self) -> np.ndarray:
        return np.asarray(self.normal)

    @property
    def p(self) -> np.ndarray:
        return np.asarray(self.point)

    @classmethod
    def touching(cls, kind: str, *, normal, point, at=(0.0, 0.0, 0.0)) -> Contact:
        """The contact whose constraint holds at configuration ``at``."""
        n = np.asarray(normal, float) / np.hypot(*normal)
        c = cls(kind, tuple(n), 0.0, tuple(point))
        return cls(kind, tuple(n), float(constraint(c, np.asarray(at, float)[None])[0]),
                   tuple(point))

    def cotangent_vector(self) -> np.ndarray:
        """The constant 4-vector ``Y = [n; a]`` of (8.39) / (8.45).

        Type B: ``Y_B = [n; a]`` with ``a = (n^T X p, n^T p)`` (8.38).
        Type A: ``Y_A = [-n; a]`` with ``a = (n^T X^T p, n^T p)``. (The thesis says
        type A uses "the previous definitions of a1 and a2", but expanding (8.44)
        against the matrix of (8.45) requires ``a1 = n^T X^T p = -n^T X p``.)
        """
        n, p = self.n, self.p
        if self.kind == "B":
            return np.array([n[0], n[1], n @ X @ p, n @ p])
        return np.array([-n[0], -n[1], n @ X.T @ p, n @ p])

    @classmethod
    def from_cotangent_vector(cls, kind: str, y, *, distance: float = 0.0) -> Contact:
        """Inverse of :meth:`cotangent_vector` (the normal part is renormalised)."""
        y = np.asarray(y, float)
        s = np.hypot(y[0], y[1])
        y = y / s
        if kind == "B":
            n = y[:2]
            p = y[2] * (X.T @ n) + y[3] * n
        else:
            n = -y[:2]
            p = y[2] * (X @ n) + y[3] * n
        return cls(kind, tuple(n), distance, tuple(p))


def constraint(contact: Contact, x) -> np.ndarray:
    """Constraint value C(x) (8.33 type B, 8.35 type A); shape ``(N,)``."""
    x = np.atleast_2d(np.asarray(x, float))
    R = rot(x[:, 2])
    n, p, r = contact.n, contact.p, x[:, :2]
    if contact.kind == "B":
        return (R @ p) @ n + r @ n - contact.distance
    return np.einsum("i,nji,nj->n", n, R, p - r) - contact.distance


def cotangent(contact: Contact, x) -> np.ndarray:
    """dC/dx: the constraint wrench direction (8.36 type B, 8.43 type A); ``(N, 3)``."""
    x = np.atleast_2d(np.asarray(x, float))
    R = rot(x[:, 2])
    n, p, r = contact.n, contact.p, x[:, :2]
    out = np.empty((len(x), 3))
    if contact.kind == "B":
        out[:, :2] = n
        out[:, 2] = (R @ p) @ (X.T @ n)            # n^T X R p
    else:
        out[:, :2] = -(R @ n)
        out[:, 2] = np.einsum("nij,j,ni->n", R, X @ n, p - r)   # n^T X^T R^T (p - r) = (R X n)^T (p - r)
    return out


def hessian(contact: Contact, x) -> np.ndarray:
    """Second derivative of C(x); ``(N, 3, 3)`` (used by the simulator's solver)."""
    x = np.atleast_2d(np.asarray(x, float))
    R = rot(x[:, 2])
    n, p, r = contact.n, contact.p, x[:, :2]
    H = np.zeros((len(x), 3, 3))
    if contact.kind == "B":
        H[:, 2, 2] = -(R @ p) @ n
    else:
        Rn = R @ n
        H[:, 2, 2] = -np.einsum("ni,ni->n", Rn, p - r)
        H[:, :2, 2] = -(Rn @ X.T)                    # -X R n
        H[:, 2, :2] = H[:, :2, 2]
    return H


def tangents(contact: Contact, x) -> np.ndarray:
    """The two tangent fields J_1, J_2 (8.40 type B, 8.46 type A); ``(N, 2, 3)``."""
    x = np.atleast_2d(np.asarray(x, float))
    R = rot(x[:, 2])
    n, p, r = contact.n, contact.p, x[:, :2]
    J = np.zeros((len(x), 2, 3))
    if contact.kind == "B":
        J[:, 0, :2] = X @ n
        J[:, 1, :2] = R @ (X.T @ p)
    else:
        J[:, 0, :2] = R @ (X.T @ n)
        J[:, 1, :2] = -(p - r) @ X.T
    J[:, 1, 2] = 1.0
    return J


# -- curvature matrices ------------------------------------------------------------
def curvature_cotangent(kind: str, x) -> np.ndarray:
    """C_Y(x) with cotangent = P C_Y(x) Y; (8.39) type B, (8.45) type A; ``(N, 4, 4)``."""
    x = np.atleast_2d(np.asarray(x, float))
    R = rot(x[:, 2])
    C = np.zeros((len(x), 4, 4))
    if kind == "B":
        C[:, 0, 0] = C[:, 1, 1] = 1.0
        C[:, 2:, 2:] = R
    else:
        C[:, :2, :2] = R
        C[:, 2:, 2:] = R
        C[:, 2, :2] = np.einsum("ni,ij,njk->nk", x[:, :2], X, R)   # r^T X R
    return C


def curvature_tangents(kind: str, x) -> tuple[np.ndarray, np.ndarray]:
    """(C_J1(x), C_J2(x)): (8.41-8.42) type B, (8.47-8.48) type A; each ``(N, 4, 4)``.

    Constant vectors: type B ``J_1 = [X n; 0; 0]``, ``J_2 = [X^T p; 1; 0]``;
    type A ``J_1 = [X^T n; 0; 0]``, ``J_2 = [-X p; 1; 0]``.
    """
    x = np.atleast_2d(np.asarray(x, float))
    N = len(x)
    R = rot(x[:, 2])
    eye = np.broadcast_to(np.eye(4), (N, 4, 4)).copy()
    C1, C2 = eye.copy(), eye.copy()
    if kind == "B":
        C2[:, :2, :2] = R
    else:
        C1[:, :2, :2] = R
        C2[:, :2, 2] = x[:, :2] @ X.T                              # [X r, 0]
    return C1, C2


def tangent_vectors(contact: Contact) -> tuple[np.ndarray, np.ndarray]:
    """The constant 4-vectors (J_1, J_2) of :func:`curvature_tangents`."""
    n, p = contact.n, contact.p
    if contact.kind == "B":
        return np.r_[X @ n, 0, 0], np.r_[X.T @ p, 1, 0]
    return np.r_[X.T @ n, 0, 0], np.r_[-(X @ p), 1, 0]


def cross3(a, b) -> np.ndarray:
    """Row-wise cross product of ``(N, 3)`` arrays."""
    return np.cross(a, b)
