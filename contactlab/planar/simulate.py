"""The small planar simulator of 8.1.3.5.

A desired trajectory of ``n_points`` configurations: a translational random walk
with steps of unit length in uniformly random directions, and an angle drawn
uniformly within ``(-0.3, 0.3)`` rad (the thesis: "random motion bounded to
stay within a (-0.3, 0.3) radian range"). A constraint solver turns it into the
actual motion by minimising the stiffness energy ``(x - x_d)^T K (x - x_d) / 2``
subject to ``C_j(x) = 0`` for every contact (Newton's method on the KKT
conditions, vectorised over the trajectory; the start holds ``theta = theta_d``
and projects the position exactly, since the constraints are linear in ``r``
at fixed ``theta``). The recorded wrench is the constraint wrench
``K (x - x_d) = sum_j lambda_j dC_j/dx``, exactly in the cotangent space.

Choices where the thesis is silent (each stated in the report):

* Each desired point is pushed into the obstacles, along one fixed direction,
  until it is ``preload`` (default one step length) deep in every contact, so
  the contact forces are compressive and of steady size, as when a hand slides
  an object while pressing it on; the estimator itself does not care.
* The velocity at each point is the K-orthogonal projection of the desired
  central-difference step onto the tangent space there, so it is an exact
  tangent vector.
* ``K = Id`` in (length, length, rad) units: the thesis gives no stiffness.
* Noise (the thesis: "noise magnitude ... the product of the average variance
  with a signal-to-noise ratio"): we read ``ratio`` as the ratio of noise to
  signal standard deviations, and add it only on bases that complete the
  tangent / cotangent spaces. Single contacts: velocity noise along the edge
  normal ``[n; 0]`` (world), force noise along the edge ``[t; 0]``, no
  torque noise (the thesis's type B recipe, used for type A too). Two
  contacts: velocity noise along both edge normals, wrench noise along the
  tangent scaled component-wise by the force and torque signal levels.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from contactlab.planar.geometry import Contact, X, constraint, cotangent, hessian, rot

N_POINTS = 100
ROTATION_RANGE = 0.3
STEP = 1.0


@dataclass
class PlanarSim:
    """One simulated planar trajectory. Arrays are ``(N, 3)``; ``lam`` is ``(N, m)``."""

    contacts: tuple
    configuration: np.ndarray
    velocity: np.ndarray
    wrench: np.ndarray
    true_velocity: np.ndarray
    true_wrench: np.ndarray
    desired: np.ndarray
    lam: np.ndarray
    noise_sd: dict
    solver_iterations: int
    max_violation: float


def _gradients(contacts, x):
    return np.stack([cotangent(c, x) for c in contacts], 1)          # (N, m, 3)


def _values(contacts, x):
    return np.stack([constraint(c, x) for c in contacts], 1)          # (N, m)


def _reduced(contacts, desired, theta, K):
    """Energy and position minimising over ``r`` at fixed ``theta`` (closed form).

    At fixed ``theta`` the constraints are affine in ``r``: ``G r + h = 0``.
    ``theta`` has shape ``(N, k)``; returns ``E (N, k)`` and ``r (N, k, 2)``.
    """
    N, k = theta.shape
    xt = np.zeros((N * k, 3))
    xt[:, 2] = theta.ravel()
    G = _gradients(contacts, xt)[:, :, :2]                     # (Nk, m, 2)
    h = _values(contacts, xt)                                   # (Nk, m)
    rd = np.repeat(desired[:, :2], k, 0)
    Kinv = np.linalg.inv(K[:2, :2])
    A = G @ Kinv @ np.swapaxes(G, 1, 2)
    mu = np.linalg.solve(A, (np.einsum("nmi,ni->nm", G, rd) + h)[..., None])[..., 0]
    r = rd - np.einsum("ij,nmj,nm->ni", Kinv, G, mu)
    E = 0.5 * K[2, 2] * (theta.ravel() - np.repeat(desired[:, 2], k)) ** 2 \
        + 0.5 * np.einsum("nm,nm->n", mu, (A @ mu[..., None])[..., 0])
    return E.reshape(N, k), r.reshape(N, k, 2)


def solve_constrained(contacts, desired: np.ndarray, *, stiffness=(1.0, 1.0, 1.0),
                      tol: float = 1e-12, max_iter: int = 30) -> tuple[np.ndarray, np.ndarray, int]:
    """Minimise ``(x - x_d)^T K (x - x_d)`` s.t. every ``C_j(x) = 0``, per row of ``desired``.

    The position is eliminated in closed form at fixed ``theta``; the global
    minimum over ``theta`` is bracketed on a 2-degree grid, refined by golden
    section, then polished by Newton's method on the full KKT system. Returns
    ``(x, lambda, newton_iterations)`` with ``K (x - x_d) = sum_j lambda_j dC_j/dx``.
    Contacts whose position constraints are parallel (line-line) are not supported.
    """
    K = np.diag(np.asarray(stiffness, float))
    m = len(contacts)
    desired = np.asarray(desired, float)
    N = len(desired)
    grid = np.linspace(-np.pi, np.pi, 181)[None, :].repeat(N, 0)
    E, _ = _reduced(contacts, desired, grid, K)
    j = np.argmin(E, 1)
    lo, hi = grid[0, np.maximum(j - 1, 0)], grid[0, np.minimum(j + 1, 180)]
    g = (np.sqrt(5) - 1) / 2
    for _ in range(60):                                         # golden section, vectorised
        a, b = hi - g * (hi - lo), lo + g * (hi - lo)
        Eab, _ = _reduced(contacts, desired, np.column_stack([a, b]), K)
        left = Eab[:, 0] < Eab[:, 1]
        hi = np.where(left, b, hi)
        lo = np.where(left, lo, a)
    theta = 0.5 * (lo + hi)
    _, r = _reduced(contacts, desired, theta[:, None], K)
    x = np.column_stack([r[:, 0], theta])
    G = _gradients(contacts, x)
    GG = G @ np.swapaxes(G, 1, 2)
    lam = np.linalg.solve(GG, (G @ ((x - desired) @ K)[..., None]))[..., 0]
    it = 0
    for it in range(1, max_iter + 1):                           # Newton polish on the KKT system
        G = _gradients(contacts, x)
        H = sum(lam[:, j, None, None] * hessian(c_, x) for j, c_ in enumerate(contacts))
        F = np.concatenate([(x - desired) @ K - np.einsum("nj,nji->ni", lam, G),
                            _values(contacts, x)], 1)
        if np.abs(F).max() < tol:
            break
        Jm = np.zeros((N, 3 + m, 3 + m))
        Jm[:, :3, :3] = K - H
        Jm[:, :3, 3:] = -np.swapaxes(G, 1, 2)
        Jm[:, 3:, :3] = G
        step = np.linalg.solve(Jm, -F[..., None])[..., 0]
        x = x + step[:, :3]
        lam = lam + step[:, 3:]
    return x, lam, it


def tangent_basis(contacts, x) -> np.ndarray:
    """Orthonormal basis of the tangent space at each row of ``x``; ``(N, 3, 3 - m)``."""
    G = _gradients(contacts, x)
    _, _, Vt = np.linalg.svd(G)
    return np.swapaxes(Vt[:, len(contacts):, :], 1, 2)


def simulate_polygon(contacts, *, rng: np.random.Generator, n_points: int = N_POINTS,
                     rotation_range: float = ROTATION_RANGE, step: float = STEP,
                     stiffness=(1.0, 1.0, 1.0), noise_ratio: float = 0.0,
                     preload: float | None = None) -> PlanarSim:
    """Simulate ``n_points`` of quasi-static motion in contact; see the module doc."""
    contacts = tuple(contacts)
    K = np.diag(np.asarray(stiffness, float))
    ang = rng.uniform(0, 2 * np.pi, n_points)
    walk = np.cumsum(step * np.column_stack([np.cos(ang), np.sin(ang)]), 0)
    walk -= walk[0]
    theta = rng.uniform(-rotation_range, rotation_range, n_points)
    desired = np.column_stack([walk, theta])
    # push the desired path into the obstacles (C < 0) so every contact is compressive
    g0 = _gradients(contacts, desired)[:, :, :2]
    u = g0.sum(1).mean(0)
    u /= np.linalg.norm(u)
    gu = g0 @ u                                                   # (N, m)
    if np.any(gu <= 0):
        raise ValueError("no common direction pushes into every contact")
    depth = step if preload is None else preload
    s = np.max((_values(contacts, desired) + depth) / gu, axis=1)
    desired[:, :2] -= s[:, None] * u
    x, lam, iters = solve_constrained(contacts, desired, stiffness=stiffness)
    wrench = (x - desired) @ K
    # velocity: K-orthogonal projection of the desired central step onto the tangent space
    dxd = np.gradient(desired, axis=0)
    T = tangent_basis(contacts, x)
    TK = np.swapaxes(T, 1, 2) @ K
    coef = np.linalg.solve(TK @ T, (TK @ dxd[..., None]))
    velocity = (T @ coef)[..., 0]
    sd = _signal_sd(velocity, wrench)
    nv, nw = _noise(contacts, x, velocity, wrench, sd, noise_ratio, rng)
    return PlanarSim(contacts, x, velocity + nv, wrench + nw, velocity, wrench, desired, lam,
                     {k: noise_ratio * v for k, v in sd.items()}, iters,
                     float(np.abs(_values(contacts, x)).max()))


def _signal_sd(velocity, wrench) -> dict:
    """Square roots of the average variances (8.1.3.5) of the four signal groups."""
    return {"velocity": float(np.sqrt(velocity[:, :2].var(0).mean())),
            "angular_velocity": float(np.sqrt(velocity[:, 2].var())),
            "force": float(np.sqrt(wrench[:, :2].var(0).mean())),
            "torque": float(np.sqrt(wrench[:, 2].var()))}


def _world_normal(c: Contact, x) -> np.ndarray:
    return np.broadcast_to(c.n, (len(x), 2)) if c.kind == "B" else rot(x[:, 2]) @ c.n


def _noise(contacts, x, velocity, wrench, sd, ratio, rng):
    N = len(x)
    nv, nw = np.zeros((N, 3)), np.zeros((N, 3))
    if ratio == 0:
        return nv, nw
    for c in contacts:
        nv[:, :2] += (ratio * sd["velocity"] * rng.standard_normal(N))[:, None] * _world_normal(c, x)
    if len(contacts) == 1:
        t = _world_normal(contacts[0], x) @ X.T                   # along the edge
        nw[:, :2] = (ratio * sd["force"] * rng.standard_normal(N))[:, None] * t
    else:
        J = tangent_basis(contacts, x)[:, :, 0]
        Jn = J / np.array([sd["velocity"], sd["velocity"], sd["angular_velocity"]])
        Jn /= np.linalg.norm(Jn, axis=1, keepdims=True)
        scale = np.array([sd["force"], sd["force"], sd["torque"]])
        nw = (ratio * rng.standard_normal(N))[:, None] * Jn * scale
    return nv, nw
