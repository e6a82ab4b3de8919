"""Planar polygon constraint estimation: the public entry point.

    from contactlab.planar import estimate_polygon
    est = estimate_polygon(configuration=x, wrench=w, kind="B")   # x: (N,3) [x,y,theta]
    est.status, est.contacts[0], est.parameters, est.standard_errors, est.iterations

``kind``: "A" (moving edge on a fixed vertex), "B" (moving vertex on a fixed
edge), "AA", "BB", "AB" (two contacts; the A contact first) or "line-line".
Velocities are the differences of successive configurations unless given
(``velocity=``, same shape); with differences, configurations and wrenches are
taken at the midpoints of the steps. ``noise`` holds the measurement standard
deviations used to make the data unit-free with a reciprocity-preserving
scaling (8.7-8.9); by default they are set from the data's RMS levels.

Degenerate data (fewer samples than parameters, no motion, no rotation where
the geometry needs it, singular information) give ``status="undetermined"``
with a ``reason`` and NaN parameters, never a silent wrong answer; malformed
input raises :class:`contactlab.errors.DataError`.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from contactlab.errors import DataError
from contactlab.planar import double, single
from contactlab.planar.geometry import Contact, X, angle_of, constraint, cotangent, tangents, unit
from contactlab.planar.steps import Undetermined
from contactlab.planar.tableau import tableau

KINDS = ("A", "B", "AA", "BB", "AB", "line-line")
N_PARAMS = {"A": 3, "B": 3, "AA": 5, "BB": 5, "AB": 6, "line-line": 1}
ROTATION_TOL = 1e-9      # rad: below this peak-to-peak the data hold no rotation


@dataclass(frozen=True)
class PolygonNoise:
    """Measurement standard deviations defining the unit-free scaling (8.7-8.9).

    Attributes
    ----------
    velocity : translational velocity (length per sample)
    force : force
    length : the length unit linking rotation to translation: angular-velocity
        noise is ``velocity / length`` and torque noise ``force * length``, so
        the scaling of every wrench-twist pair has the same product (8.9).
    """

    velocity: float
    force: float
    length: float

    def __post_init__(self):
        for name in ("velocity", "force", "length"):
            v = getattr(self, name)
            if not (np.isfinite(v) and v > 0):
                raise DataError(f"must be a positive number, not {v!r}", field=f"noise.{name}")

    @classmethod
    def from_data(cls, velocity: np.ndarray, wrench: np.ndarray) -> PolygonNoise:
        """RMS levels of the data: translational velocity, force, and
        ``length = rms(v) / rms(omega)`` (1 when there is no rotation)."""
        rv = float(np.sqrt(np.mean(velocity[:, :2] ** 2)))
        rw = float(np.sqrt(np.mean(velocity[:, 2] ** 2)))
        rf = float(np.sqrt(np.mean(wrench[:, :2] ** 2)))
        length = rv / rw if rw > 0 and rv > 0 else 1.0
        return cls(rv if rv > 0 else 1.0, rf if rf > 0 else 1.0, length)

    def scale(self, x, v, w):
        """Unit-free configuration, velocity and wrench."""
        ell = self.length
        xs = np.column_stack([x[:, :2] / ell, x[:, 2]])
        vs = np.column_stack([v[:, :2] / self.velocity, v[:, 2] * ell / self.velocity])
        ws = np.column_stack([w[:, :2] / self.force, w[:, 2] / (self.force * ell)])
        return xs, vs, ws


@dataclass
class PolygonEstimate:
    """A planar contact estimate.

    Attributes
    ----------
    contacts : estimated contacts (two contacts: one member of the family of
        equivalent mechanisms; compare with ``tableau``); empty for line-line
    parameters, standard_errors : named geometric parameters (angles in rad)
    covariance : covariance of ``parameter_names`` (Gauss-Newton, residual-scaled)
    tableau : tangent-space tableau of a two-contact estimate (8.50-8.56)
    residuals : per-sample residuals in noise units, columns ``residual_names``
    log_likelihood : (8.18) of the residuals, ``-n/2 (log det V + k)``
    iterations : sweeps of the iteration until the change fell below ``tol``
    """

    kind: str
    status: str
    reason: str = ""
    contacts: tuple = ()
    parameters: dict = field(default_factory=dict)
    standard_errors: dict = field(default_factory=dict)
    parameter_names: tuple = ()
    covariance: np.ndarray | None = None
    tableau: np.ndarray | None = None
    residuals: np.ndarray | None = None
    residual_names: tuple = ()
    log_likelihood: float = float("nan")
    criterion: float = float("nan")
    iterations: int = 0
    converged: bool = False
    n_samples: int = 0
    noise: PolygonNoise | None = None

    @property
    def determined(self) -> bool:
        return self.status == "ok"

    def to_dict(self) -> dict:
        """JSON-able summary (no per-sample arrays)."""
        def f(v):
            return None if v is None or not np.isfinite(v) else float(v)
        return {"kind": self.kind, "status": self.status, "reason": self.reason,
                "parameters": {k: f(v) for k, v in self.parameters.items()},
                "standard_errors": {k: f(v) for k, v in self.standard_errors.items()},
                "contacts": [{"kind": c.kind, "normal": list(c.normal), "distance": c.distance,
                              "point": list(c.point)} for c in self.contacts],
                "tableau": None if self.tableau is None else self.tableau.tolist(),
                "log_likelihood": f(self.log_likelihood), "iterations": self.iterations,
                "converged": self.converged, "n_samples": self.n_samples}


def _validate(name, a, n=None):
    try:
        a = np.asarray(a, dtype=float)
    except (TypeError, ValueError):
        raise DataError("must be numeric", field=name) from None
    if a.ndim != 2 or a.shape[1] != 3:
        raise DataError(f"must have shape (N, 3), not {a.shape}", field=name)
    if n is not None and len(a) != n:
        raise DataError(f"has {len(a)} rows, configuration has {n}", field=name)
    if not np.all(np.isfinite(a)):
        raise DataError("contains NaN or infinite values", field=name)
    return a


def estimate_polygon(*, configuration, wrench, kind: str = "B", noise: PolygonNoise | None = None,
                     velocity=None, tol: float = 1e-10, max_iter: int = 100) -> PolygonEstimate:
    """Estimate planar contact geometry from configurations ``[x, y, theta]`` and
    wrenches ``[fx, fy, tau]`` (each ``(N, 3)``); see the module docstring."""
    if kind not in KINDS:
        raise DataError(f"unknown polygon model {kind!r}; one of {', '.join(KINDS)}", field="kind")
    x = _validate("configuration", configuration)
    w = _validate("wrench", wrench, len(x))
    if velocity is None:
        v = np.diff(x, axis=0)
        x = 0.5 * (x[1:] + x[:-1])
        w = 0.5 * (w[1:] + w[:-1])
    else:
        v = _validate("velocity", velocity, len(x))
    und = PolygonEstimate(kind=kind, status="undetermined", n_samples=len(x))
    if len(x) < N_PARAMS[kind] + 1:
        und.reason = f"{len(x)} samples for {N_PARAMS[kind]} parameters"
        return und
    if not np.any(v) or (np.ptp(x, axis=0).max() == 0 and velocity is None):
        und.reason = "no motion: every sample is the same configuration"
        return und
    if kind != "line-line" and np.ptp(x[:, 2]) < ROTATION_TOL and np.abs(v[:, 2]).max() < ROTATION_TOL:
        und.reason = ("no rotation: the contact offset along the normal is not observable "
                      "(fit 'line-line' for pure sliding)")
        return und
    noise = noise or PolygonNoise.from_data(v, w)
    xs, vs, ws = noise.scale(x, v, w)
    try:
        if kind in ("A", "B"):
            return _finish_single(kind, xs, vs, ws, noise, tol, max_iter)
        if kind == "line-line":
            return _finish_line(x, xs, vs, ws, noise)
        return _finish_double(kind, xs, vs, ws, noise, tol, max_iter)
    except Undetermined as exc:
        und.reason = str(exc)
        und.noise = noise
        return und


# -- shared pieces -----------------------------------------------------------------
def _loglik(res: np.ndarray) -> float:
    """(8.18): ``-n/2 (log det V + k)``, ``V = mean nu nu^T`` (floored at 1e-300)."""
    n, k = res.shape
    V = res.T @ res / n
    sign, logdet = np.linalg.slogdet(V)
    if sign <= 0:
        logdet = k * np.log(1e-300)
    return float(-0.5 * n * (max(logdet, k * np.log(1e-300)) + k))


def _covariance(resfun, params: np.ndarray) -> np.ndarray:
    """Gauss-Newton covariance ``s^2 pinv(J^T J)`` with a central-difference Jacobian."""
    r0 = resfun(params).ravel()
    J = np.empty((r0.size, params.size))
    for j in range(params.size):
        h = 1e-6 * max(1.0, abs(params[j]))
        e = np.zeros(params.size)
        e[j] = h
        J[:, j] = (resfun(params + e).ravel() - resfun(params - e).ravel()) / (2 * h)
    dof = max(r0.size - params.size, 1)
    s2 = r0 @ r0 / dof
    return s2 * np.linalg.pinv(J.T @ J, rcond=1e-12)


def _oriented(c: Contact, xs, ws, lam_sign: float) -> Contact:
    """Flip ``(n, d)`` so the contact pushes (lambda >= 0 on average)."""
    if lam_sign < 0:
        return Contact(c.kind, tuple(-c.n), -c.distance, c.point)
    return c


def _with_distance(c: Contact, xs) -> tuple[Contact, np.ndarray]:
    c0 = Contact(c.kind, c.normal, 0.0, c.point)
    vals = constraint(c0, xs)
    return Contact(c.kind, c.normal, float(vals.mean()), c.point), vals


def _physical(c: Contact, ell: float) -> Contact:
    return Contact(c.kind, c.normal, c.distance * ell, tuple(c.p * ell))


# -- single contact ----------------------------------------------------------------
def _single_residuals(kind, xs, vs, ws, params):
    c = Contact(kind, tuple(unit(params[0])), 0.0, tuple(params[1:3]))
    nu_u = np.einsum("ni,ni->n", cotangent(c, xs), vs)
    nu_w = np.einsum("nki,ni->nk", tangents(c, xs), ws)
    return np.column_stack([nu_u, nu_w])


def _finish_single(kind, xs, vs, ws, noise, tol, max_iter):
    info = single.information(kind).update(xs, vs, ws)
    fit = single.fit_single(info, kind, tol=tol, max_iter=max_iter)
    c = Contact(kind, tuple(fit.normal / np.linalg.norm(fit.normal)), 0.0, tuple(fit.point))
    lam = np.einsum("ni,ni->n", cotangent(c, xs), ws)
    c = _oriented(c, xs, ws, lam.mean())
    c, vals = _with_distance(c, xs)
    params = np.r_[angle_of(c.n), c.p]
    res = _single_residuals(kind, xs, vs, ws, params)
    cov = _covariance(lambda p: _single_residuals(kind, xs, vs, ws, p), params)
    ell = noise.length
    T = np.diag([1.0, ell, ell])
    cov = T @ cov @ T
    # distance: mean of C_0 over the samples; its variance adds the parameters' spread
    g = np.empty(3)
    for j in range(3):
        e = np.zeros(3)
        e[j] = 1e-6
        cp = Contact(kind, tuple(unit(params[0] + e[0])), 0.0, tuple(params[1:] + e[1:]))
        cm = Contact(kind, tuple(unit(params[0] - e[0])), 0.0, tuple(params[1:] - e[1:]))
        g[j] = (constraint(cp, xs).mean() - constraint(cm, xs).mean()) / 2e-6
    g = g / np.array([1.0, ell, ell])
    var_d = (vals.var(ddof=1) / len(vals)) * ell ** 2 + g @ cov @ g * ell ** 2
    cphys = _physical(c, ell)
    names = ("normal_angle", "point_x", "point_y")
    pars = dict(zip(names, (params[0], cphys.p[0], cphys.p[1]), strict=True))
    pars["distance"] = cphys.distance
    se = dict(zip(names, np.sqrt(np.diag(cov)), strict=True))
    se["distance"] = float(np.sqrt(var_d))
    return PolygonEstimate(
        kind=kind, status="ok", contacts=(cphys,), parameters=pars, standard_errors=se,
        parameter_names=names, covariance=cov, residuals=res,
        residual_names=("cotangent.velocity", "tangent1.wrench", "tangent2.wrench"),
        log_likelihood=_loglik(res), criterion=fit.criterion, iterations=fit.iterations,
        converged=fit.converged, n_samples=len(xs), noise=noise)


# -- two contacts ------------------------------------------------------------------
def _double_contacts(kind, params):
    k1, k2 = double.PAIRS[kind]
    return (Contact(k1, tuple(unit(params[0])), 0.0, tuple(params[1:3])),
            Contact(k2, tuple(unit(params[3])), 0.0, tuple(params[4:6])))


def _double_residuals(kind, xs, vs, ws, params):
    c1, c2 = _double_contacts(kind, params)
    Y1, Y2 = cotangent(c1, xs), cotangent(c2, xs)
    return np.column_stack([np.einsum("ni,ni->n", Y1, vs), np.einsum("ni,ni->n", Y2, vs),
                            np.einsum("ni,ni->n", np.cross(Y1, Y2), ws)])


def _finish_double(kind, xs, vs, ws, noise, tol, max_iter):
    info = double.information(kind).update(xs, ws, vs)   # U = cotangents: v = velocity
    fit = double.fit_double(info, kind, tol=tol, max_iter=max_iter)
    k1, k2 = double.PAIRS[kind]
    cs = [Contact.from_cotangent_vector(k1, fit.Y1), Contact.from_cotangent_vector(k2, fit.Y2)]
    G = np.stack([cotangent(c, xs) for c in cs], 2)                  # (N, 3, 2)
    GtG = np.swapaxes(G, 1, 2) @ G
    lam = np.linalg.solve(GtG, (np.swapaxes(G, 1, 2) @ ws[..., None]))[..., 0]
    cs = [_oriented(c, xs, ws, lam[:, j].mean()) for j, c in enumerate(cs)]
    cs = [_with_distance(c, xs)[0] for c in cs]
    params = np.r_[angle_of(cs[0].n), cs[0].p, angle_of(cs[1].n), cs[1].p]
    res = _double_residuals(kind, xs, vs, ws, params)
    cov = _covariance(lambda p: _double_residuals(kind, xs, vs, ws, p), params)
    ell = noise.length
    T = np.diag([1.0, ell, ell, 1.0, ell, ell])
    cov = T @ cov @ T
    phys = tuple(_physical(c, ell) for c in cs)
    names = ("c1_normal_angle", "c1_point_x", "c1_point_y",
             "c2_normal_angle", "c2_point_x", "c2_point_y")
    vals = (params[0], phys[0].p[0], phys[0].p[1], params[3], phys[1].p[0], phys[1].p[1])
    pars = dict(zip(names, vals, strict=True))
    pars["c1_distance"], pars["c2_distance"] = phys[0].distance, phys[1].distance
    se = dict(zip(names, np.sqrt(np.clip(np.diag(cov), 0, None)), strict=True))
    return PolygonEstimate(
        kind=kind, status="ok", contacts=phys, parameters=pars, standard_errors=se,
        parameter_names=names, covariance=cov, tableau=tableau(*phys), residuals=res,
        residual_names=("cotangent1.velocity", "cotangent2.velocity", "tangent.wrench"),
        log_likelihood=_loglik(res), criterion=fit.criterion, iterations=fit.iterations,
        converged=fit.converged, n_samples=len(xs), noise=noise)


# -- line-line ---------------------------------------------------------------------
def _finish_line(x, xs, vs, ws, noise):
    fit = double.fit_line_line(vs, ws)
    n = fit.normal
    if (ws[:, :2] @ n).mean() < 0:
        n = -n
    t = X @ n
    res = np.column_stack([vs[:, :2] @ n, vs[:, 2], ws[:, :2] @ t])
    dist = x[:, :2] @ n
    theta0 = float(x[:, 2].mean())
    # normal angle: small-angle perturbation of the 2x2 eigenproblem, residual-scaled
    m = len(xs)
    s2 = float(np.mean(res[:, 0] ** 2) + np.mean(res[:, 2] ** 2))
    curv = float(np.mean((vs[:, :2] @ t) ** 2) + np.mean((ws[:, :2] @ n) ** 2))
    se_phi = float(np.sqrt(s2 / (m * curv))) if curv > 0 else float("inf")
    pars = {"normal_angle": angle_of(n), "distance": float(dist.mean()), "angle": theta0}
    se = {"normal_angle": se_phi, "distance": float(dist.std(ddof=1) / np.sqrt(m)),
          "angle": float(x[:, 2].std(ddof=1) / np.sqrt(m))}
    return PolygonEstimate(
        kind="line-line", status="ok", parameters=pars, standard_errors=se,
        parameter_names=("normal_angle", "distance", "angle"),
        covariance=np.diag([se[k] ** 2 for k in ("normal_angle", "distance", "angle")]),
        tableau=np.array([[t[0]], [t[1]], [0.0]]), residuals=res,
        residual_names=("normal.velocity", "angular.velocity", "tangent.force"),
        log_likelihood=_loglik(res), iterations=1, converged=True, n_samples=m, noise=noise)
