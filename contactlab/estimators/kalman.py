"""Square-root Kalman filter for constant parameters with a prior (A.2.2, A.18-A.39).

State and measurement (A.18): the parameters are constant (no process noise)
and ``y(n) = psi(n) theta + V_nu^{1/2} mu(n)`` with ``psi(n)`` an (m, p) matrix,
m >= 1.  The prior ``theta ~ N(theta0, S0 S0^T)`` comes from training.  A batch
of B independent filters runs together: ``psi`` (N, B, m, p), ``y`` (N, B, m);
scalar measurements may be given as ``psi`` (N, B, p), ``y`` (N, B).

One step (A.32-A.39), with ``S = V_theta^{1/2}(n|n-1)`` and ``Lv = V_nu^{1/2}``:

* pre-array (A.32) ``A = [[psi S, Lv], [S, 0]]``.  We triangularise it with the
  column blocks swapped, ``[[Lv, 0, psi S], [0, 0, S]]`` -- the lower-triangular
  ``blockdiag(Lv, 0)`` with the p columns ``[psi S; S]`` appended -- by
  :func:`~contactlab.estimators.householder.tri_append`.  A column permutation
  is orthogonal, so the result is the post-array of A.33,
  ``[[V_nu^{1/2}(n|n), 0], [K(n), V_theta^{1/2}(n+1|n)]]`` with
  ``F F^T = psi P psi^T + V_nu`` (the innovation covariance), ``K F^T = P psi^T``
  and ``D D^T = P - K K^T``.  All square roots are lower-triangular with a
  non-negative diagonal (the package convention, see :mod:`.rls`).
* innovation ``nu = y - psi theta`` (A.34), ``F alpha = nu`` (A.35),
  ``theta += K alpha`` (A.36), ``l_c = -1/2 alpha^T alpha`` (A.37).
* running innovation variance (A.38), when ``estimate_noise=True``: we read
  A.38's ``sqrt((1/n) nu(n))`` as the column ``sqrt(1/n) nu(n)`` appended to
  the scaled old factor, ``[sqrt(1 - 1/n) Lv(n|n-1), sqrt(1/n) nu(n)] T2 =
  [Lv(n+1|n), 0]``, which is the square-root form of the running mean of
  ``nu nu^T`` (6.8, A.17) -- the square root of a vector is meaningless.  The
  thesis lists ``V_nu^{1/2}(n|n-1)`` among the inputs of A.32, so the estimate
  is fed back as the filter's ``V_nu``; it estimates the innovation covariance
  ``psi P psi^T + V_nu``, which tends to V_nu as P shrinks (conservative while
  P is large).  ``n`` counts the innovations absorbed plus
  ``noise_prior_count`` pseudo-innovations at the initial ``noise_sqrt``;
  ``noise_prior_count=0`` is the literal A.38 (the first innovation replaces
  the initial value).
* log-likelihood (A.39).  A.39 prints ``-1/2 log det V_nu^{1/2}(n+1|n) + l_c``.
  The Gaussian log-density of the innovation is ``-1/2 log det(F F^T) - 1/2
  alpha^T alpha - m/2 log 2 pi = -log det F + l_c - m/2 log 2 pi``: the factor
  1/2 belongs to ``log det V``, not to ``log det V^{1/2}``; and the covariance
  is the predictive one, F = V_nu^{1/2}(n|n) of A.33 (the one alpha is
  normalised by), not the estimate that already contains nu(n).  We return
  ``l(n) = -sum log F_ii + l_c(n) - m/2 log(2 pi)``; summed over n this is the
  exact log-likelihood of the sequence when V_nu is known.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np

from contactlab.estimators._arrays import (as_f64, batch_vector, sqrt_matrix,
                                           vector_regression)
from contactlab.estimators.householder import forward_subst, tri_append_n

__all__ = ["SquareRootKalman", "KalmanResult", "kalman_step", "sqrt_step", "step_scratch", "STRUCTURES"]

_LOG_2PI = math.log(2.0 * math.pi)

#: ``mode`` of the kernel: plain regressors, orthogonal regressors with the
#: structure tracked on-line (A.41-A.42), orthogonal with a fixed structure.
MODE_PLAIN, MODE_TRACK, MODE_FIXED = 0, 1, 2
#: regressor structures of :func:`kalman_step` by name
STRUCTURES = {"plain": MODE_PLAIN, "track": MODE_TRACK, "fixed": MODE_FIXED}


@numba.njit(cache=True)
def step_scratch(m, p):  # pragma: no cover - compiled
    """:func:`sqrt_step`'s scratch for ``m`` measurements and ``p`` parameters (at most):
    the pre-array, its appended columns, the orthogonal regressors, the noise's and the
    structure's appended columns, the innovation and its normalised form, the
    measurement."""
    q = m + p
    return (np.zeros((q, q)), np.zeros((q, p)), np.zeros((m, p)), np.zeros((m, 1)),
            np.zeros((p, m)), np.zeros(m), np.zeros(m), np.zeros(m))


@numba.njit(cache=True, inline="always")
def sqrt_step(psi, y, th, S, Ls, Ve, Lv, estimate, mode, count, prior_count, m, p,
              sc):  # pragma: no cover - compiled
    """One sample of one square-root Kalman filter (A.32-A.39), optionally on orthogonal
    regressors (A.40-A.42): the one step of the package, which the batch kernel below and
    the observer's compiled core (:func:`contactlab.observer.engine._kalman_channel`)
    both call.

    ``psi`` (>= m, >= p) regressors and ``y`` (>= m) measurements of the sample; the
    state, updated in place: ``th`` (p) parameters, ``S`` (p, p) their square-root
    covariance, ``Ls`` (p, p) the regressors' structure factor (``mode`` 1), ``Ve`` (m, m)
    the running square-root noise (``estimate``), ``Lv`` (m, m) the fixed one; ``count``
    innovations absorbed so far.  Arrays may be larger than m, p (their leading blocks
    are used).  ``sc``: :func:`step_scratch`, whose pre-array holds the post-array of A.33
    afterwards (``F`` in its leading m x m block) and whose ``nu``, ``al`` the innovation
    and its normalised form.  Returns ``(l_c, log-likelihood, count)``."""
    A, Z, h, Zv, Zs, nu, al = sc[0], sc[1], sc[2], sc[3], sc[4], sc[5], sc[6]
    q = m + p
    # orthogonal regressors: structure update (A.41), psi~ R = psi (A.40, A.42)
    if mode == 1:
        for i in range(p):
            for r in range(m):
                Zs[i, r] = psi[r, i]
        tri_append_n(Ls, Zs, p, m)
    if mode != 0:
        for r in range(m):
            for i in range(p):
                s = psi[r, i]
                for k in range(i):
                    d = Ls[k, k]
                    if d != 0.0:
                        s -= (Ls[i, k] / d) * h[r, k]
                h[r, i] = s
    else:
        for r in range(m):
            for i in range(p):
                h[r, i] = psi[r, i]
    # innovation (A.34)
    for r in range(m):
        s = y[r]
        for i in range(p):
            s -= h[r, i] * th[i]
        nu[r] = s
    # pre-array (A.32), columns permuted: [[Lv, 0 | psi S], [0, 0 | S]]
    for i in range(q):
        for j in range(q):
            A[i, j] = 0.0
    for i in range(m):
        for j in range(i + 1):
            A[i, j] = Ve[i, j] if estimate else Lv[i, j]
    for r in range(m):
        for j in range(p):
            s = 0.0
            for k in range(j, p):
                s += h[r, k] * S[k, j]
            Z[r, j] = s
    for i in range(p):
        for j in range(p):
            Z[m + i, j] = S[i, j]
    # Householder reduction to the post-array (A.33)
    tri_append_n(A, Z, q, p)
    # normalised innovation (A.35), update (A.36), statistics (A.37, A.39)
    forward_subst(A, nu, al, m)
    lc = 0.0
    logdet = 0.0
    for r in range(m):
        lc -= 0.5 * al[r] * al[r]
        logdet += math.log(A[r, r])
    for i in range(p):
        s = 0.0
        for r in range(m):
            s += A[m + i, r] * al[r]
        th[i] += s
        for j in range(p):
            S[i, j] = A[m + i, m + j]
    ll = lc - logdet - 0.5 * m * _LOG_2PI
    # running square-root innovation variance (A.38)
    if estimate:
        count += 1.0
        nn = prior_count + count
        c_old = math.sqrt(1.0 - 1.0 / nn)
        c_new = math.sqrt(1.0 / nn)
        for i in range(m):
            Zv[i, 0] = c_new * nu[i]
            for j in range(m):
                Ve[i, j] *= c_old
        tri_append_n(Ve, Zv, m, 1)
    return lc, ll, count


@numba.njit(cache=True)
def _kalman_kernel(psi, y, theta_all, S_all, Lv_fixed, Ve_all, vcount, prior_count,
                   estimate, mode, Ls_all,
                   nu_out, alpha_out, F_out, theta_out, lc_out, ll_out):  # pragma: no cover
    """Batch square-root Kalman filter: :func:`sqrt_step` for every filter and sample.
    State arrays are updated in place."""
    N, B, m, p = psi.shape
    sc = step_scratch(m, p)
    A, nu, al = sc[0], sc[5], sc[6]
    th = np.empty(p)
    S = np.empty((p, p))
    Ve = np.empty((m, m))
    Ls = np.empty((p, p))
    for b in range(B):
        for i in range(p):
            th[i] = theta_all[b, i]
            for j in range(p):
                S[i, j] = S_all[b, i, j]
                Ls[i, j] = Ls_all[b, i, j]
        for i in range(m):
            for j in range(m):
                Ve[i, j] = Ve_all[b, i, j]
        cnt = vcount[b]
        for t in range(N):
            lc, ll, cnt = sqrt_step(psi[t, b], y[t, b], th, S, Ls, Ve, Lv_fixed[b],
                                    estimate, mode, cnt, prior_count, m, p, sc)
            for r in range(m):
                nu_out[t, b, r] = nu[r]
                alpha_out[t, b, r] = al[r]
                for j in range(m):
                    F_out[t, b, r, j] = A[r, j]
            for i in range(p):
                theta_out[t, b, i] = th[i]
            lc_out[t, b] = lc
            ll_out[t, b] = ll
        for i in range(p):
            theta_all[b, i] = th[i]
            for j in range(p):
                S_all[b, i, j] = S[i, j]
                Ls_all[b, i, j] = Ls[i, j]
        for i in range(m):
            for j in range(m):
                Ve_all[b, i, j] = Ve[i, j]
        vcount[b] = cnt


@dataclass(frozen=True)
class KalmanResult:
    """Per-sample output of :meth:`SquareRootKalman.run` (time axis first).

    Attributes
    ----------
    innovations : (N, B, m) ``nu(n) = y(n) - psi(n) theta(n|n-1)`` (A.34).
    alpha : (N, B, m) normalised innovations, ``F alpha = nu`` (A.35).
    innovation_sqrt : (N, B, m, m) ``F = V_nu^{1/2}(n|n)`` of A.33, the square
        root of the predicted innovation covariance ``psi P psi^T + V_nu``.
    theta : (N, B, p) ``theta(n+1|n)`` after each update (A.36).
    change_stat : (N, B) ``l_c(n) = -1/2 alpha^T alpha`` (A.37).
    loglik : (N, B) ``log p(nu(n))`` (A.39 as corrected in the module notes).
    """

    innovations: np.ndarray
    alpha: np.ndarray
    innovation_sqrt: np.ndarray
    theta: np.ndarray
    change_stat: np.ndarray
    loglik: np.ndarray

    @property
    def chi2(self) -> np.ndarray:
        """(N, B) ``alpha^T alpha = nu^T V^{-1} nu``: chi-square(m) under the model (6.11)."""
        return -2.0 * self.change_stat

    @property
    def innovation_cov(self) -> np.ndarray:
        """(N, B, m, m) ``F F^T``."""
        F = self.innovation_sqrt
        return F @ np.swapaxes(F, -1, -2)


class SquareRootKalman:
    """Square-root Kalman filter with a prior on constant parameters (A.18-A.39).

    Parameters
    ----------
    theta0 : prior mean, (p,) or (B, p).
    theta_sqrt0 : prior square-root covariance ``V_theta^{1/2}(1|0)``: a
        scalar (times I), a (p,) vector of standard deviations, a (p, p)
        lower-triangular factor (``numpy.linalg.cholesky`` of the covariance)
        or (B, p, p).
    noise_sqrt : ``V_nu^{1/2}``, the measurement-noise square root: scalar,
        (m,), (m, m) lower-triangular or (B, m, m).  With
        ``estimate_noise=True`` it is the initial value of the running estimate.
    estimate_noise : False (default) keeps ``V_nu`` fixed; True replaces it by
        the running square-root estimate of A.38 (see module notes).
    noise_prior_count : pseudo-count of the initial ``noise_sqrt`` in the
        running estimate (``n`` of A.38 starts at ``noise_prior_count + 1``).

    Attributes
    ----------
    theta_ : (B, p) ``theta(n+1|n)`` after :meth:`filter` / :meth:`update`.
    theta_sqrt_ : (B, p, p) ``V_theta^{1/2}(n+1|n)``.
    noise_sqrt_ : (B, m, m) the ``V_nu^{1/2}`` the next step will use.
    n_samples_ : samples filtered since the start / :meth:`reset`.
    """

    _mode = 0

    def __init__(self, *, theta0, theta_sqrt0, noise_sqrt, estimate_noise: bool = False,
                 noise_prior_count: float = 8.0):
        self.theta0 = theta0
        self.theta_sqrt0 = theta_sqrt0
        self.noise_sqrt = noise_sqrt
        self.estimate_noise = estimate_noise
        self.noise_prior_count = noise_prior_count

    # -- state ---------------------------------------------------------------------
    def _n_params(self) -> int:
        t0 = as_f64(self.theta0, "theta0")
        if t0.ndim not in (1, 2) or t0.shape[-1] < 1:
            raise ValueError(f"theta0 must be (p,) or (B, p); got shape {t0.shape}")
        return t0.shape[-1]

    def _init_state(self, batch: int, m: int, p: int) -> None:
        if self._n_params() != p:
            raise ValueError(f"theta0 has p={self._n_params()} parameters but psi has p={p}")
        if not isinstance(self.estimate_noise, (bool, np.bool_)):
            raise ValueError(f"estimate_noise must be True or False; got {self.estimate_noise!r}")
        if not (np.isfinite(self.noise_prior_count) and self.noise_prior_count >= 0):
            raise ValueError("noise_prior_count must be a finite number >= 0; "
                             f"got {self.noise_prior_count!r}")
        self.theta_ = batch_vector(self.theta0, p, batch, "theta0")
        self.theta_sqrt_ = sqrt_matrix(self.theta_sqrt0, p, batch, "theta_sqrt0")
        self._noise_fixed = sqrt_matrix(self.noise_sqrt, m, batch, "noise_sqrt")
        if np.any(np.diagonal(self._noise_fixed, axis1=1, axis2=2) <= 0):
            raise ValueError("noise_sqrt must have a positive diagonal (V_nu > 0)")
        self._noise_est = self._noise_fixed.copy()
        self._vcount = np.zeros(batch)
        self._structure = np.zeros((batch, p, p))
        self.n_samples_ = 0
        self._shape = (batch, m, p)

    def _ensure_state(self, batch: int, m: int, p: int) -> None:
        if getattr(self, "_shape", None) is None:
            self._init_state(batch, m, p)
        elif self._shape != (batch, m, p):
            raise ValueError(f"this filter holds (B, m, p)={self._shape}; got data with "
                             f"{(batch, m, p)} (call reset() to start over)")

    def reset(self) -> "SquareRootKalman":
        """Forget all state; the next call starts again from the prior."""
        self._shape = None
        return self

    @property
    def noise_sqrt_(self) -> np.ndarray:
        return self._noise_est if self.estimate_noise else self._noise_fixed

    # -- recursion -------------------------------------------------------------------
    def run(self, psi, y) -> KalmanResult:
        """Filter N samples for every model; the state carries over between
        calls (consecutive chunks equal one call on the whole).  ``run`` is the
        batch name of every estimator and detector (``filter`` is its former name)."""
        psi, y = vector_regression(psi, y)
        N, B, m, p = psi.shape
        self._ensure_state(B, m, p)
        res = kalman_step(psi, y, theta=self.theta_, theta_sqrt=self.theta_sqrt_,
                          noise_sqrt=self._noise_fixed, noise_est=self._noise_est,
                          noise_count=self._vcount, structure_sqrt=self._structure,
                          structure=self._mode, estimate_noise=self.estimate_noise,
                          noise_prior_count=self.noise_prior_count)
        self.n_samples_ += N
        return res

    def update(self, psi, y) -> KalmanResult:
        """One step for every model: ``psi`` (B, m, p) or (B, p); ``y`` (B, m) or (B,).

        Returns a :class:`KalmanResult` without the time axis.
        """
        psi = np.asarray(psi, dtype=np.float64)
        y = np.asarray(y, dtype=np.float64)
        res = self.run(psi[None], y[None])
        return KalmanResult(**{k: v[0] for k, v in res.__dict__.items()})

    filter = run           # the former name of run


def kalman_step(psi, y, *, theta, theta_sqrt, noise_sqrt, noise_est=None, noise_count=None,
                structure_sqrt=None, structure="plain", estimate_noise: bool = False,
                noise_prior_count: float = 8.0) -> KalmanResult:
    """N steps (A.32-A.39) of B independent square-root Kalman filters whose state the
    caller holds: the stateless form of :meth:`SquareRootKalman.run`.

    ``psi`` (N, B, m, p), ``y`` (N, B, m) C-contiguous float64.  The state arrays are
    advanced in place: ``theta`` (B, p) estimate, ``theta_sqrt`` (B, p, p) its
    lower-triangular covariance square root, ``noise_sqrt`` (B, m, m) the fixed
    ``V_nu^{1/2}``, ``noise_est`` (B, m, m) and ``noise_count`` (B,) the running
    innovation-variance estimate (A.38; used when ``estimate_noise``), and
    ``structure_sqrt`` (B, p, p) the regressors' structure square root for the
    orthogonal forms (A.40-A.42).  ``structure``: ``"plain"`` regressors,
    ``"track"`` the structure on line, ``"fixed"`` a fixed structure (or the
    ``MODE_*`` code).  Returns the per-sample :class:`KalmanResult`.
    """
    N, B, m, p = psi.shape
    mode = STRUCTURES[structure] if isinstance(structure, str) else int(structure)
    if noise_est is None:
        noise_est = np.array(noise_sqrt, dtype=np.float64)
    if noise_count is None:
        noise_count = np.zeros(B)
    if structure_sqrt is None:
        structure_sqrt = np.zeros((B, p, p))
    out = dict(innovations=np.empty((N, B, m)), alpha=np.empty((N, B, m)),
               innovation_sqrt=np.empty((N, B, m, m)), theta=np.empty((N, B, p)),
               change_stat=np.empty((N, B)), loglik=np.empty((N, B)))
    _kalman_kernel(psi, y, theta, theta_sqrt, noise_sqrt, noise_est, noise_count,
                   float(noise_prior_count), bool(estimate_noise), mode, structure_sqrt,
                   out["innovations"], out["alpha"], out["innovation_sqrt"], out["theta"],
                   out["change_stat"], out["loglik"])
    return KalmanResult(**out)
