"""Batched numerics of the Cartesian constraint form (8.21-8.28).

Everything here works on the joint information matrix ``I`` (8.19) of a batch
of blocks, shape (B, 2k, 2k), in normalised units: the first k coordinates are
motion (position or velocity), the last k force.  A frame is a (B, k, k)
orthogonal matrix ``R = [N, T]`` whose first ``m`` columns are the constraint
normals (cotangent basis) and the rest the free directions (tangent basis);
its joint projection (8.21) is

    P = [[N, 0], [0, T]]        (2k x k)

so the residual (8.10-8.11, 8.14) is ``nu = [N^T x~; T^T w~]``: motion along
the normals and force along the free directions, both zero for an ideal
frictionless rigid constraint.

Criteria, per block:

- log-det (8.22-8.24): ``f(R) = log det(P^T I P + floor Id)``; the
  log-likelihood is ``-n/2 (f + k)`` (8.18).  ``f`` depends only on
  ``span(N)`` (a rotation inside N or inside T leaves it unchanged), so the
  search runs over the m(k-m) Grassmann coordinates ``A`` that tilt the
  normals toward the free directions: ``R(A) = R cay(S(A))`` with
  ``S = [[0, -A^T], [A, 0]]`` and the Cayley transform
  ``cay(S) = (I - S/2)^{-1} (I + S/2)``.
- trace (8.25-8.26): ``tr(N^T Ixx N) + tr(T^T Iww T)``.  Because
  ``T T^T = Id - N N^T`` this equals ``tr(Iww) + tr(N^T (Ixx - Iww) N)``, so
  its minimiser is closed-form: N = the eigenvectors of the m smallest
  eigenvalues of ``Ixx - Iww`` (Ky Fan).  The thesis solves the coupled
  necessary conditions (8.27) by Newton's method instead
  (:func:`trace_newton`); both are provided and agree (tests).
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["embed", "innovation_cov", "logdet_value", "logdet_gradient", "cayley",
           "trace_closed_form", "ratio_start", "gram_schmidt_start", "newton_logdet", "logdet_hessian",
           "powell_logdet", "trace_newton", "trace_value", "logdet_scores", "long_run_covariance"]


def embed(R: np.ndarray, m: int) -> np.ndarray:
    """The joint projection P (B, 2k, k) of frames R (B, k, k) with m normals (8.21)."""
    B, k, _ = R.shape
    P = np.zeros((B, 2 * k, k))
    P[:, :k, :m] = R[:, :, :m]
    P[:, k:, m:] = R[:, :, m:]
    return P


def innovation_cov(I: np.ndarray, R: np.ndarray, m: int, floor: float = 0.0) -> np.ndarray:
    """``V = P^T I P + floor Id`` (8.20, 8.23), shape (B, k, k)."""
    P = embed(R, m)
    V = np.swapaxes(P, 1, 2) @ I @ P
    if floor:
        k = R.shape[-1]
        V = V + floor * np.eye(k)
    return V


def _slogdet(V: np.ndarray) -> np.ndarray:
    sign, ld = np.linalg.slogdet(V)
    return np.where(sign > 0, ld, -np.inf)


def logdet_value(I, R, m: int, floor: float = 0.0) -> np.ndarray:
    """``log det V`` (B,) (-inf where V is singular)."""
    return _slogdet(innovation_cov(I, R, m, floor))


def logdet_gradient(I, R, m: int, floor: float = 0.0):
    """``(f, g)``: ``f = log det V`` (B,) and its gradient in the Grassmann
    coordinates at ``A = 0``, ``g`` (B, k-m, m).

    ``df = 2 tr(V^{-1} P^T I dP)`` so ``df/dP = 2 I P V^{-1}``; only the N and
    T blocks of P vary; with ``dR = R S`` and ``M = R^T [G_N, G_T]``,
    ``dg/dA = M[m:, :m] - M[:m, m:]^T``.
    """
    B, k, _ = R.shape
    P = embed(R, m)
    IP = I @ P
    V = np.swapaxes(P, 1, 2) @ IP
    if floor:
        V = V + floor * np.eye(k)
    f = _slogdet(V)
    with np.errstate(all="ignore"):
        Vinv = np.linalg.inv(np.where(np.isfinite(f)[:, None, None], V, np.eye(k)))
    Gf = 2.0 * IP @ Vinv
    G = np.concatenate([Gf[:, :k, :m], Gf[:, k:, m:]], axis=2)
    M = np.swapaxes(R, 1, 2) @ G
    g = M[:, m:, :m] - np.swapaxes(M[:, :m, m:], 1, 2)
    return f, g


def cayley(A: np.ndarray, k: int, m: int) -> np.ndarray:
    """``cay(S(A))`` (B, k, k) for Grassmann coordinates A (B, k-m, m)."""
    B = A.shape[0]
    S = np.zeros((B, k, k))
    S[:, m:, :m] = A
    S[:, :m, m:] = -np.swapaxes(A, 1, 2)
    eye = np.eye(k)
    return np.linalg.solve(eye - S / 2.0, eye + S / 2.0)


def trace_value(I, R, m: int) -> np.ndarray:
    """The trace criterion (8.25) without the -1/2: ``tr(N^T Ixx N) + tr(T^T Iww T)``."""
    return np.trace(innovation_cov(I, R, m), axis1=1, axis2=2)


def trace_closed_form(I: np.ndarray, m: int) -> np.ndarray:
    """Minimiser of the trace criterion: eigenvectors of ``Ixx - Iww`` by ascending
    eigenvalue (the first m are the normals).  Shape (B, k, k)."""
    k = I.shape[-1] // 2
    D = I[:, :k, :k] - I[:, k:, k:]
    _, vec = np.linalg.eigh(D)
    return vec


def ratio_start(I: np.ndarray, m: int, floor: float = 0.0) -> np.ndarray:
    """A start for the log-det criterion that does not depend on the units' ratio.

    Normals: the m generalised eigenvectors of ``(Ixx + floor Id) n = lam (Iww + floor Id) n``
    with the smallest ``lam`` (the directions with the least motion for their force),
    orthonormalised; free directions: their orthogonal complement.  When Ixx and Iww
    are diagonal in one orthonormal basis (and the cross terms vanish) the log-det
    criterion is ``sum_normals log(Ixx_ii + floor) + sum_free log(Iww_ii + floor)``,
    so choosing each axis by the ratio ``Ixx_ii / Iww_ii`` is then its exact minimiser.
    The trace start (``Ixx - Iww``) compares motion with force in absolute units
    instead, and picks a free direction as a normal whenever the force along it
    (stick friction, say) is larger in force units than its motion in motion units.
    Shape (B, k, k).
    """
    k = I.shape[-1] // 2
    eye = np.eye(k)
    Ixx = I[:, :k, :k] + floor * eye
    Iww = I[:, k:, k:] + floor * eye
    # scale-safe: a singular Iww (no force at all) gets a tiny ridge
    ridge = 1e-12 * np.maximum(np.trace(Iww, axis1=1, axis2=2), 1e-300)[:, None, None]
    L = np.linalg.cholesky(Iww + ridge * eye)
    Linv = np.linalg.inv(L)
    C = Linv @ Ixx @ np.swapaxes(Linv, 1, 2)
    _, u = np.linalg.eigh(0.5 * (C + np.swapaxes(C, 1, 2)))
    v = np.swapaxes(Linv, 1, 2) @ u                     # generalised eigenvectors, ascending
    q, r = np.linalg.qr(np.concatenate([v[:, :, :m], v[:, :, m:]], axis=2))
    return q * np.where(np.diagonal(r, axis1=1, axis2=2) < 0, -1.0, 1.0)[:, None, :]


def gram_schmidt_start(I: np.ndarray, m: int) -> np.ndarray:
    """The thesis's initial rotation (8.28): per-block eigenvectors, Gram-Schmidt.

    Normals: the m eigenvectors of ``Ixx`` with the smallest eigenvalues; free
    directions: the k-m eigenvectors of ``Iww`` with the smallest eigenvalues.
    "The eigenvectors were sorted based on the magnitude of their associated
    eigenvalue from largest to smallest. Then the Gram-Schmidt
    orthonormalization procedure was applied ... Then the eigenvectors were
    returned to their original order."  Implemented as written.
    """
    k = I.shape[-1] // 2
    lx, vx = np.linalg.eigh(I[:, :k, :k])
    lw, vw = np.linalg.eigh(I[:, k:, k:])
    cols = np.concatenate([vx[:, :, :m], vw[:, :, :k - m]], axis=2)
    vals = np.concatenate([lx[:, :m], lw[:, :k - m]], axis=1)
    order = np.argsort(-np.abs(vals), axis=1, kind="stable")
    sorted_cols = np.take_along_axis(cols, order[:, None, :], axis=2)
    q, r = np.linalg.qr(sorted_cols)
    q = q * np.where(np.diagonal(r, axis1=1, axis2=2) < 0, -1.0, 1.0)[:, None, :]
    out = np.empty_like(q)
    np.put_along_axis(out, order[:, None, :], q, axis=2)
    return out


def _pd_newton_step(g: np.ndarray, H: np.ndarray, max_step: float) -> np.ndarray:
    """Newton step ``-H^{-1} g`` with H's eigenvalues replaced by their magnitudes
    (floored), clipped to norm ``max_step``.  g (B, d), H (B, d, d)."""
    w, U = np.linalg.eigh(H)
    scale = np.maximum(np.abs(w).max(axis=1, keepdims=True), 1e-12)
    w = np.maximum(np.abs(w), 1e-8 * scale)
    step = -np.einsum("bij,bj,bkj,bk->bi", U, 1.0 / w, U, g)
    norm = np.linalg.norm(step, axis=1, keepdims=True)
    return step * np.minimum(1.0, max_step / np.maximum(norm, 1e-300))


def logdet_hessian(I, R, m: int, floor: float = 0.0, h: float = 1e-5) -> np.ndarray:
    """Hessian (B, d, d) of ``log det V`` in the Grassmann coordinates at R, by
    central differences of the analytic gradient (exact to O(h^2) at a stationary
    point).  d = m (k - m)."""
    B, k, _ = R.shape
    d = m * (k - m)
    H = np.empty((B, d, d))
    for j in range(d):
        e = np.zeros((B, d))
        e[:, j] = h
        _, gp = logdet_gradient(I, R @ cayley(e.reshape(B, k - m, m), k, m), m, floor)
        _, gm = logdet_gradient(I, R @ cayley(-e.reshape(B, k - m, m), k, m), m, floor)
        H[:, :, j] = (gp - gm).reshape(B, d) / (2 * h)
    return 0.5 * (H + np.swapaxes(H, 1, 2))


def logdet_scores(y: np.ndarray, R: np.ndarray, m: int, floor: float = 0.0) -> np.ndarray:
    """Per-sample terms ``s_t`` (n, d) of the gradient of ``log det V`` in the Grassmann
    coordinates at the frame R (k, k): ``g = mean_t s_t`` (:func:`logdet_gradient`).

    With ``V = (1/n) sum nu_t nu_t^T + floor Id``, ``dV = (1/n) sum (dnu_t nu_t^T + ...)``
    so ``d log det V = (1/n) sum_t 2 nu_t^T V^{-1} dnu_t``.  Tilting normal j toward free
    direction i (``dN = T A``, ``dT = -N A^T``) changes ``nu_t = [N^T x_t; T^T w_t]`` by
    ``e_j (T^T x_t)_i`` in the motion block and ``-e_i (N^T w_t)_j`` in the force block:
    ``s_t[i, j] = 2 [(V^{-1} nu_t)_j (T^T x_t)_i - (V^{-1} nu_t)_{m+i} (N^T w_t)_j]``,
    flattened row-major as the coordinates of :func:`logdet_hessian`.
    """
    k = R.shape[0]
    x, w = y[:, :k], y[:, k:]
    N, T = R[:, :m], R[:, m:]
    nu = np.concatenate([x @ N, w @ T], axis=1)
    V = nu.T @ nu / len(y) + floor * np.eye(k)
    z = np.linalg.solve(V, nu.T).T                       # V^{-1} nu_t
    tx, nw = x @ T, w @ N                                  # (n, k-m), (n, m)
    s = 2.0 * (tx[:, :, None] * z[:, None, :m] - z[:, m:, None] * nw[:, None, :])
    return s.reshape(len(y), -1)


def long_run_covariance(s: np.ndarray) -> tuple[np.ndarray, int]:
    """Long-run covariance ``sum_l Cov(s_t, s_{t-l})`` (d, d) of a series (n, d) and the lag
    used: Bartlett weights (Newey and West 1987) with the bandwidth of Andrews (1991)'s
    AR(1) plug-in rule, ``1.1447 (alpha n)^{1/3}``, at most n - 1.  For white scores it
    is their covariance; slow disturbances (a compliant contact's penetration, friction
    along a smooth motion) make neighbouring samples' scores alike, and the sum of their
    autocovariances is what the variance of the mean score has."""
    n, d = s.shape
    s = s - s.mean(axis=0)
    g0 = s.T @ s / n
    if n < 3:
        return g0, 0
    a, b = s[1:], s[:-1]
    rho = np.clip(np.einsum("ni,ni->i", a, b) / np.maximum(np.einsum("ni,ni->i", b, b),
                                                            1e-300), -0.99, 0.99)
    sig2 = np.einsum("ni,ni->i", a - rho * b, a - rho * b) / (n - 1)
    num = np.sum(4 * rho ** 2 * sig2 ** 2 / ((1 - rho) ** 6 * (1 + rho) ** 2))
    den = np.sum(sig2 ** 2 / (1 - rho) ** 4)
    alpha = num / den if den > 0 else 0.0
    lag = int(min(n - 1, math.floor(1.1447 * (alpha * n) ** (1.0 / 3.0))))
    omega = g0.copy()
    for l in range(1, lag + 1):
        gl = s[l:].T @ s[:-l] / n
        omega += (1.0 - l / (lag + 1.0)) * (gl + gl.T)
    return 0.5 * (omega + omega.T), lag


def newton_logdet(I: np.ndarray, R0: np.ndarray, m: int, floor: float = 0.0, *,
                  tol: float = 1e-9, max_iter: int = 40, max_step: float = 0.5):
    """Minimise ``log det V`` over frames from starts R0, all blocks at once.

    Newton's method on the Grassmann coordinates (Hessian by differences of
    the analytic gradient, eigenvalues made positive, step at most
    ``max_step`` rad, halved until the criterion does not increase).
    Returns ``(R, f, iterations)``; blocks whose criterion is not finite are
    returned unchanged with their (non-finite) value.
    """
    R = np.array(R0, dtype=np.float64, copy=True)
    B, k, _ = R.shape
    d = m * (k - m)
    f, g = logdet_gradient(I, R, m, floor)
    iters = np.zeros(B, dtype=np.int64)
    if d == 0 or B == 0:
        return R, f, iters
    active = np.flatnonzero(np.isfinite(f) & (np.abs(g).reshape(B, d).max(axis=1) > tol))
    for _ in range(max_iter):
        if active.size == 0:
            break
        Ia, Ra, fa, ga = I[active], R[active], f[active], g[active].reshape(-1, d)
        H = logdet_hessian(Ia, Ra, m, floor)
        step = _pd_newton_step(ga, H, max_step)
        t = np.ones(active.size)
        accepted = np.zeros(active.size, dtype=bool)
        newR, newf, newg = Ra.copy(), fa.copy(), g[active].copy()
        todo = np.arange(active.size)
        for _half in range(30):
            Rt = Ra[todo] @ cayley((t[todo, None] * step[todo]).reshape(-1, k - m, m), k, m)
            ft, gt = logdet_gradient(Ia[todo], Rt, m, floor)
            ok = np.isfinite(ft) & (ft <= fa[todo] + 1e-12 * np.maximum(1.0, np.abs(fa[todo])))
            sel = todo[ok]
            newR[sel], newf[sel], newg[sel] = Rt[ok], ft[ok], gt[ok]
            accepted[sel] = True
            todo = todo[~ok]
            if todo.size == 0:
                break
            t[todo] *= 0.5
        R[active], f[active], g[active] = newR, newf, newg
        iters[active] += 1
        gnorm = np.abs(newg.reshape(-1, d)).max(axis=1)
        small = np.linalg.norm(t[:, None] * step, axis=1) < 1e-12
        done = (gnorm <= tol) | ~accepted | small
        active = active[~done]
    # re-orthonormalise (Cayley is exactly orthogonal up to rounding)
    q, r = np.linalg.qr(R)
    R = q * np.where(np.diagonal(r, axis1=1, axis2=2) < 0, -1.0, 1.0)[:, None, :]
    return R, f, iters


# -- per-block methods as the thesis describes them --------------------------------------------

def _euler_zyx(angles: np.ndarray) -> np.ndarray:
    a, b, c = angles
    ca, sa, cb, sb, cc, sc = math.cos(a), math.sin(a), math.cos(b), math.sin(b), \
        math.cos(c), math.sin(c)
    rz = np.array([[ca, -sa, 0.0], [sa, ca, 0.0], [0.0, 0.0, 1.0]])
    ry = np.array([[cb, 0.0, sb], [0.0, 1.0, 0.0], [-sb, 0.0, cb]])
    rx = np.array([[1.0, 0.0, 0.0], [0.0, cc, -sc], [0.0, sc, cc]])
    return rz @ ry @ rx


def _skew_expm(theta: np.ndarray, k: int) -> np.ndarray:
    from scipy.linalg import expm

    S = np.zeros((k, k))
    S[np.triu_indices(k, 1)] = theta
    return expm(S - S.T)


def powell_logdet(I1: np.ndarray, R_init: np.ndarray, m: int, floor: float = 0.0, *,
                  xtol: float = 1e-10, ftol: float = 1e-13):
    """The thesis's search (8.28): ``P = R_initial R~`` with R~ from three Euler
    angles (k = 3; k(k-1)/2 angles of a skew-matrix exponential otherwise),
    minimised by Powell's method (scipy.optimize).  One block: I1 (2k, 2k),
    R_init (k, k).  Returns ``(R, f, nfev, nit)``."""
    from scipy.optimize import minimize

    k = R_init.shape[0]
    rot = (lambda th: _euler_zyx(th)) if k == 3 else (lambda th: _skew_expm(th, k))
    I3 = I1[None]

    def fun(th):
        v = logdet_value(I3, (R_init @ rot(th))[None], m, floor)[0]
        return v if np.isfinite(v) else 1e300

    res = minimize(fun, np.zeros(k * (k - 1) // 2), method="Powell",
                   options={"xtol": xtol, "ftol": ftol, "maxfev": 20000})
    R = R_init @ rot(res.x)
    return R, float(res.fun), int(res.nfev), int(res.nit)


def trace_newton(I1: np.ndarray, m: int, *, tol: float = 1e-11, max_iter: int = 100,
                 regularizer: float = 1e-9):
    """Newton's method on the necessary conditions of the trace criterion (8.27).

    Unknowns: the frame ``Pbar = [p_1..p_k]`` and the symmetric multipliers
    ``sigma``; equations ``I_i p_i + Pbar sigma_i = 0`` (``I_i`` = ``Ixx`` for
    a normal, ``Iww`` for a free direction) and ``Pbar^T Pbar = Id``.  Start:
    per-block eigenvectors (not orthonormal), ``sigma`` from least squares.
    The Jacobian is singular at some starts; as in the thesis a regulariser
    (Levenberg-Marquardt damping, raised when a step does not reduce the
    residual) makes the steps well defined.  One block; returns
    ``(R, trace value, iterations, converged)``.
    """
    k = I1.shape[0] // 2
    Ixx, Iww = I1[:k, :k], I1[k:, k:]
    blocks = [Ixx if i < m else Iww for i in range(k)]
    _, vx = np.linalg.eigh(Ixx)
    _, vw = np.linalg.eigh(Iww)
    Pb = np.concatenate([vx[:, :m], vw[:, :k - m]], axis=1)
    G0 = np.stack([blocks[i] @ Pb[:, i] for i in range(k)], axis=1)
    sigma = -np.linalg.lstsq(Pb, G0, rcond=None)[0]
    sigma = 0.5 * (sigma + sigma.T)
    iu = np.triu_indices(k)
    npar = k * k + len(iu[0])
    x = np.concatenate([Pb.T.reshape(-1), sigma[iu]])
    scale = max(float(np.abs(I1).max()), 1e-300)

    def unpack(x):
        Pb = x[:k * k].reshape(k, k).T
        s = np.zeros((k, k))
        s[iu] = x[k * k:]
        s = s + s.T - np.diag(np.diag(s))
        return Pb, s

    def residual_and_jac(x):
        Pb, s = unpack(x)
        F = np.empty(npar)
        J = np.zeros((npar, npar))
        for i in range(k):
            F[i * k:(i + 1) * k] = blocks[i] @ Pb[:, i] + Pb @ s[:, i]
            for j in range(k):
                J[i * k:(i + 1) * k, j * k:(j + 1) * k] = s[j, i] * np.eye(k)
            J[i * k:(i + 1) * k, i * k:(i + 1) * k] += blocks[i]
        for c, (a, b) in enumerate(zip(*iu)):
            row = k * k + c
            F[row] = Pb[:, a] @ Pb[:, b] - (1.0 if a == b else 0.0)
            J[row, a * k:(a + 1) * k] += Pb[:, b]
            J[row, b * k:(b + 1) * k] += Pb[:, a]
            for i in range(k):      # d(Pbar sigma_i)/d sigma_ab
                if i == b:
                    J[i * k:(i + 1) * k, k * k + c] += Pb[:, a]
                if i == a and a != b:
                    J[i * k:(i + 1) * k, k * k + c] += Pb[:, b]
        F[:k * k] /= scale
        J[:k * k] /= scale
        return F, J

    lam = regularizer
    F, J = residual_and_jac(x)
    it, converged = 0, False
    for it in range(1, max_iter + 1):
        JTJ = J.T @ J
        step = np.linalg.solve(JTJ + lam * np.eye(npar), -J.T @ F)
        Fn, Jn = residual_and_jac(x + step)
        if Fn @ Fn < F @ F:
            x, F, J = x + step, Fn, Jn
            lam = max(lam / 10.0, regularizer)
        else:
            lam *= 10.0
        if np.linalg.norm(F) < tol:
            converged = True
            break
    Pb, _ = unpack(x)
    q, r = np.linalg.qr(Pb)
    R = q * np.where(np.diag(r) < 0, -1.0, 1.0)[None, :]
    return R, float(trace_value(I1[None], R[None], m)[0]), it, converged
