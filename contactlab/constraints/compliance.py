"""A compliant contact: the penetration that follows the pressing force.

The constraint form of 8.1.1 takes every contact as rigid: along each normal ``n_j``
the position stays at ``d_j``.  A real contact gives way: the fingertip's pad, the
surface, the wrist's mount sink by the force over their stiffness, so along each normal

    n_j . x_t = d_j - c (n_j . f_t)                                   (compliance c, m/N)

with ``f_t`` the measured force (the pressing force along ``n_j`` plus friction across
it, which ``n_j .`` removes).  When the pressing force drifts together with the motion
(a hand pressing harder as it slides), the positions lie on a tilted surface and the
rigid fit tilts by up to ``atan(c * change of force / stroke)``: on 2000 N/m with
0.2-2 N and a few millimetres of stroke, one or two degrees, common to every block of
the contact, so no spread between blocks shows it (:mod:`.dispersion`).

This module estimates ``c`` with the frame (beyond the thesis, which models no
compliance in the constraint form; its stiffness form 8.12-8.20 is the rigid limit of a
spring, not a constraint that gives way).  Around a fitted frame ``[N, T]`` (normals,
free directions), each normal's position is linear in the small tilts ``a_jl`` of
``n_j`` toward each free direction ``t_l``, its offset and ``c``:

    n_j . x_t  =  sum_l a_jl (t_l . x_t)  +  d_j  -  c (n_j . f_t)  +  e_jt

one least-squares problem over every sample and normal (``m (k - m) + m + 1``
unknowns).  ``c`` is identified when the force along the normals varies other than in
step with the motion; when it does not vary, ``c`` is undetermined and harmless (the
correction is then a constant offset).  The positions corrected to the rigid surface,
``x_t + c f_t``, are fitted again by the constraint form as written, and the frame's
standard error gains the share of ``c``'s uncertainty, ``Sigma_ac Sigma_cc^-1 Sigma_ca``
(the tilts' marginal covariance less their covariance with ``c`` known).  The
coefficients' covariance is the sandwich with the residuals' long-run covariance
(:func:`.frames.long_run_covariance`, as the constraint fit's own "hac" standard error).
"""

from __future__ import annotations

import copy
import dataclasses
import math

import numpy as np

from contactlab.constraints.frames import long_run_covariance

__all__ = ["Compliance", "fit_compliance", "CompliantConstraint", "TURN_LEVEL",
           "TURN_MIN_SAMPLES", "TURN_MAX_DEG"]

#: the rates' test level: a frame is turned on to a block when its tilt rates are
#: significant at this level.  A false turn costs little (the frame moves by its rate's
#: noise and its sd grows by as much), a missed creep leaves the error uncovered; on the
#: synthetic contacts creeping 2 deg a run (seeds 1-5), 5 % covered more blocks than 1 %
#: on every row (edges of seed 4: 88 against 79 %) and the same on rigid contacts
TURN_LEVEL = 0.05

#: the fewest samples a turn is followed from (0.4 s at 250 Hz): a rate fitted over a
#: shorter stretch, extrapolated to its block, turned a real snap-fit's frame by 73 deg
TURN_MIN_SAMPLES = 100

#: the largest turn followed (deg): the regression's small-rotation form holds to a few
#: degrees; a larger fitted turn is a misfit of the creep's straight line, not a creep (on
#: a real snap fit's blocks the fitted turns reached tens of degrees)
TURN_MAX_DEG = 5.0


@dataclasses.dataclass(frozen=True)
class Compliance:
    """The compliance ``c`` (m/N) along a frame's normals, its standard error, and the
    covariance (rad^2, normal-major ``m (k - m)``) its uncertainty adds to the frame's
    tilts."""

    c: float
    sd: float
    tilt_cov: np.ndarray
    rate: np.ndarray | None = None        # (m (k-m),) tilt per unit of centred time, rad
    rate_cov: np.ndarray | None = None    # its covariance, rad^2

    def turning(self, level: float = TURN_LEVEL) -> bool:
        """Whether the frame turns: the rates' Wald statistic beyond chi^2's upper
        ``level`` quantile."""
        from scipy.stats import chi2

        if self.rate is None or self.rate.size == 0:
            return False
        try:
            w = float(self.rate @ np.linalg.solve(self.rate_cov, self.rate))
        except np.linalg.LinAlgError:
            return False
        return w > chi2.isf(level, self.rate.size)

    @property
    def tilt_sd_deg(self) -> float:
        """The largest standard error (deg) ``c``'s uncertainty adds to a tilt."""
        return _largest_sd_deg(self.tilt_cov)


def _largest_sd_deg(cov: np.ndarray) -> float:
    """The largest standard deviation (deg) of a covariance of small rotations (rad^2)."""
    if cov.size == 0:
        return 0.0
    return float(np.degrees(np.sqrt(max(0.0, np.linalg.eigvalsh(cov).max()))))


def fit_compliance(position, force, normals, free, *, force_sd=0.0) -> Compliance | None:
    """``c`` of the module notes about the frame ``normals`` (k, m), ``free`` (k, k-m)
    from ``position`` (n, k, m) and ``force`` (n, k, N); None without a normal, with
    too few samples or a singular problem.  ``force_sd`` (N, scalar or per axis): the
    force's white noise, removed from the force column's sum of squares (the
    errors-in-variables correction: the noise would otherwise shrink ``c`` toward 0 by
    the share of the force's own variation it makes up)."""
    x = np.asarray(position, dtype=np.float64)
    f = np.asarray(force, dtype=np.float64)
    N = np.asarray(normals, dtype=np.float64)
    T = np.asarray(free, dtype=np.float64)
    n, k = x.shape
    m = N.shape[1]
    if m == 0 or not np.all(np.isfinite(N)) or not np.all(np.isfinite(T)):
        return None
    q = k - m
    p = 2 * (m * q + m) + 1
    if n * m <= p + 2:
        return None
    xc = x - x.mean(axis=0)
    u = xc @ T                                    # (n, q) free coordinates
    y = xc @ N                                    # (n, m) position along each normal
    g = (f - f.mean(axis=0)) @ N                  # (n, m) force along each normal
    tau = np.linspace(-1.0, 1.0, n)[:, None]      # time, centred
    # rows normal-major: [tilts of normal j (q) | offsets (m) | their rates | c]; the
    # rates (a frame turning at a constant rate) keep a drift out of c
    h = m * q + m
    X = np.zeros((n, m, p))
    for j in range(m):
        X[:, j, j * q:(j + 1) * q] = u
        X[:, j, m * q + j] = 1.0
        X[:, j, h + j * q:h + (j + 1) * q] = tau * u
        X[:, j, h + m * q + j] = tau[:, 0]
        X[:, j, -1] = -g[:, j]
    A = X.reshape(n * m, p)
    b = y.reshape(n * m)
    # scale the columns so the normal equations are well conditioned
    s = np.sqrt(np.sum(A * A, axis=0))
    if np.any(s <= 0):
        return None
    As = A / s
    G = As.T @ As
    fsd2 = float(np.mean(np.square(np.broadcast_to(np.asarray(force_sd, np.float64), (k,)))))
    G[-1, -1] = max(G[-1, -1] - n * m * fsd2 / s[-1] ** 2, 0.5 * G[-1, -1])
    w = np.linalg.eigvalsh(G)
    if not np.all(np.isfinite(w)) or w.min() <= 1e-12 * w.max():
        return None
    beta = np.linalg.solve(G, As.T @ b) / s
    e = (b - A @ beta).reshape(n, m)
    # the sandwich with the scores' long-run covariance: slow disturbances make
    # neighbouring samples alike
    omega, _ = long_run_covariance(np.einsum("tjp,tj->tp", X / s, e))
    Ginv = np.linalg.inv(G)
    cov = Ginv @ (n * omega) @ Ginv / np.outer(s, s)
    t = slice(0, m * q)
    cac = cov[t, -1]
    extra = np.outer(cac, cac) / cov[-1, -1] if cov[-1, -1] > 0 else np.zeros((m * q, m * q))
    r = slice(h, h + m * q)
    return Compliance(c=float(beta[-1]), sd=float(math.sqrt(max(cov[-1, -1], 0.0))),
                      tilt_cov=extra, rate=beta[r].copy(), rate_cov=cov[r, r].copy())


class CompliantConstraint:
    """A constraint-form estimator (:class:`~contactlab.constraints.cartesian.
    CartesianConstraint`) on positions corrected for the contact's compliance (module
    notes): fit, estimate ``c`` about the fitted frame, fit ``x + c f`` again with the
    degree the rigid fit decided; the frame's standard error widened by ``c``'s share.
    The degree stays the one 8.2's test decides on the data as measured (its
    ``log_likelihoods_`` are that test's): estimated on a 0.1-s block decided alone,
    the compliance cost the synthetic suite's blocks 2 points of degrees right (0.46 ->
    0.44 at 0.1 mm / 20 mN, 0.97 -> 0.95 at 0.01 mm / 10 mN, seed 1).  A fit without a
    determined plane or edge (free space, a corner, an undetermined frame), or whose
    corrected refit is undetermined, is the rigid fit.

    The returned fit's ``parameters`` carry ``compliance_m_per_n`` and
    ``compliance_sd_m_per_n`` (and ``turn_deg`` when :meth:`estimate` turned the frame;
    then ``normals_`` and ``free_`` are the turned frame's, the other attributes the
    samples' average frame's).
    """

    def __init__(self, estimator, *, passes: int = 2):
        self.estimator = estimator
        self.passes = int(passes)

    def get_params(self) -> dict:
        return {**self.estimator.get_params(), "compliance": True}

    def _force_sd(self, k: int) -> np.ndarray:
        sd = np.asarray(getattr(self.estimator, "force_sd", 0.0), dtype=np.float64)
        return np.broadcast_to(sd, (k,)) if sd.size in (1, k) else np.zeros(k)

    def __getattr__(self, name):
        # the wrapped estimator's settings (noise levels, degree, ...) read through
        if name == "estimator":
            raise AttributeError(name)
        return getattr(self.estimator, name)

    def estimate(self, position, force, velocity=None, *, at: float | None = None):
        """Fit (n, k) ``position``, ``force`` (and ``velocity``).  ``at`` in [0, 1]: the
        frame wanted at that share of the samples' time (a block's middle in a
        segment's samples so far); when the frame turns measurably (:meth:`Compliance.
        turning`, over at least :data:`TURN_MIN_SAMPLES` samples, by at most
        :data:`TURN_MAX_DEG`), the fitted frame (the samples' average) is turned on to it
        at the rate found, and its standard error gains the rate's."""
        est = self.estimator
        rigid = est.estimate(position, force, velocity)
        x = np.asarray(position, dtype=np.float64)
        f = np.asarray(force, dtype=np.float64)
        k = x.shape[1]
        m = rigid.degree_
        if m is None or not rigid.determined_ or not 0 < m < k:
            return rigid
        fixed = copy.copy(est)
        fixed.degree = m
        fit, comp = rigid, None
        for _ in range(self.passes):
            c = fit_compliance(x, f, fit.normals_, fit.free_, force_sd=self._force_sd(k))
            if c is None:
                break
            refit = fixed.estimate(x + c.c * f, force, velocity)
            if refit.degree_ != m or not refit.determined_:
                break
            fit, comp = refit, c
        if comp is None or comp.tilt_cov.shape[0] != m * (k - m):
            return rigid
        var = fit.angle_sd_deg_ ** 2 + comp.tilt_sd_deg ** 2
        params = {**fit.parameters, "compliance_m_per_n": comp.c,
                  "compliance_sd_m_per_n": comp.sd}
        changes = {}
        tau = 2.0 * float(at) - 1.0 if at is not None else 0.0   # the regression's time
        tilt = -comp.rate.reshape(m, k - m) * tau     # regression coefficients are -tilts
        turn_deg = float(np.degrees(np.linalg.norm(tilt)))
        if at is not None and len(x) >= TURN_MIN_SAMPLES and comp.turning() \
                and turn_deg <= TURN_MAX_DEG:
            N = fit.normals_ + fit.free_ @ tilt.T
            N, _ = np.linalg.qr(N)
            N = N * np.sign(np.sum(N * fit.normals_, axis=0))
            full, _ = np.linalg.qr(np.concatenate([N, fit.free_], axis=1))
            free = full[:, m:] * np.sign(np.sum(full[:, m:] * fit.free_, axis=0))
            changes.update(normals_=N, free_=free)
            var += _largest_sd_deg(comp.rate_cov * tau * tau) ** 2
            params["turn_deg"] = turn_deg
        return dataclasses.replace(fit, angle_sd_deg_=float(np.sqrt(var)), parameters=params,
                                   log_likelihoods_=rigid.log_likelihoods_, **changes)
