"""Square-root recursive least squares with Householder updates (A.2.1, A.4-A.17).

The model is the linear predictor of A.4 with a scalar measurement per model,

    y(n) = psi(n) theta + nu(n),      psi(n) a (1, p) row,

run for a batch of ``B`` independent models at once (channels, or candidate
models): arrays are ``psi`` (N, B, p), ``y`` (N, B).  A vector measurement
whose components have *independent* parameters (the thesis treats every strain
channel this way) is a batch; a vector measurement with *shared* parameters
belongs in :class:`~contactlab.estimators.kalman.SquareRootKalman` (m >= 1).

Convention for R (the thesis writes both ``R R^T`` (A.10-A.11) and ``R^T`` in
the position of the factor (A.41)).  Here, throughout the package, **R is
lower-triangular with a non-negative diagonal and I(n) = R(n) R(n)^T** (A.11).
In Gram-Schmidt terms the regressor matrix is ``S = Q R^T`` (``R^T`` is the
usual upper-triangular QR factor), the unnormalised reflection coefficients
are ``k~ = Q^T Y``, solving ``R k~ = X`` (A.12), and ``R^T theta = k~`` (A.13).

Augmented triangularisation instead of carrying X.  A.12 solves ``R k~ = X``
with ``X(n) = sum psi^T y`` (A.8).  We carry k~ inside the factor instead: the
``(p+1) x (p+1)`` lower-triangular factor of the information matrix of the
augmented row ``[psi(n)  y(n)]`` is::

    L = [[R,     0],          L L^T = [[I,   X ],
         [k~^T,  e]]                   [X^T, E0]],   e^2 = E0 - k~^T k~,

and A.10 applied to ``[L  [psi^T; y]]`` updates R, k~ and e with one
Householder triangularisation per sample.  Reasons: (1) the triangular solve of
A.12 disappears (k~ is read off the last row); (2) X, which grows like n and
carries the squared conditioning of the data, is never formed; (3) ``e`` is the
residual energy of the full-order fit computed without the cancellation in
``E0 - k~^T k~``, and the residual energy of any order m is
``e^2 + sum_{j>m} k~_j^2``, a sum of positives (footnote 3).

A priori and a posteriori residuals.  ``psi_bar = R^{-1} psi^T`` (A.12) and
the orthogonal-frame recursion ``nu_j = nu_{j-1} - psi_bar_j k~_j``,
``nu_0 = y`` (A.14-A.15) give, for every order j at once, ``y - psi_{1:j}
theta_j``.  With ``R(n), k~(n)`` (after the update, as the thesis writes A.12)
these are the *a posteriori* residuals; with ``R(n-1), k~(n-1)`` they are the
*a priori* prediction errors -- the innovations of 6.7, which the change
detector needs.  Both are returned; the variance estimate (A.17), the
per-sample log-likelihood (A.16) and the chi-square statistic (6.11) use the
order-p *a priori* errors unless ``variance_source="posterior"``.

Log-likelihoods include the Gaussian constant ``-1/2 log(2 pi)`` per scalar
measurement, which the thesis drops; it cancels in every likelihood ratio
between models of the same measurement dimension.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np

from contactlab.estimators._arrays import batch_mask, scalar_regression
from contactlab.estimators.householder import back_subst_t, forward_subst, tri_append

__all__ = ["SquareRootRLS", "RLSResult", "exact_sequence_loglik"]

_LOG_2PI = math.log(2.0 * math.pi)


@numba.njit(cache=True, nogil=True)
def _rls_kernel(psi, y, L_all, var, var_n, count, start, use_prior, regularized,
                prior_err, post_err, refl, variance, loglik, stat):
    """Batch square-root RLS (A.10-A.17) over N samples for B models.

    State (in/out): ``L_all`` (B, p+1, p+1) augmented factors, ``var`` (B,)
    running variance (A.17), ``var_n`` (B,) samples in it, ``count`` (B,)
    samples absorbed.  Outputs are (N, B, ...) arrays filled here.  Without
    regularisation an order-j error is NaN until j samples define it (rounding
    leaves tiny non-zero pivots in a rank-deficient factor, so a zero test on
    the pivots would not do).
    """
    N, B, p = psi.shape
    q = p + 1
    L = np.empty((q, q))
    Z = np.empty((q, 1))
    row = np.empty(p)
    pb = np.empty(p)
    for b in range(B):
        for i in range(q):
            for j in range(q):
                L[i, j] = L_all[b, i, j]
        v = var[b]
        vn = var_n[b]
        c = count[b]
        for t in range(N):
            yt = y[t, b]
            # a priori: psi_bar from R(n-1) (A.12), orthogonal residuals (A.14-A.15)
            for i in range(p):
                row[i] = psi[t, b, i]
                Z[i, 0] = row[i]
            forward_subst(L, row, pb, p)
            e = yt
            prior_err[t, b, 0] = e
            for j in range(p):
                e -= pb[j] * L[p, j]
                prior_err[t, b, j + 1] = e if (regularized or c > j) else np.nan
            e_prior = prior_err[t, b, p]
            # information update (A.10) on the augmented factor
            Z[p, 0] = yt
            tri_append(L, Z)
            # a posteriori residuals with R(n), k~(n)
            forward_subst(L, row, pb, p)
            e = yt
            post_err[t, b, 0] = e
            for j in range(p):
                e -= pb[j] * L[p, j]
                post_err[t, b, j + 1] = e if (regularized or c >= j) else np.nan
                refl[t, b, j] = L[p, j]
            e_src = e_prior if use_prior else post_err[t, b, p]
            # per-sample log-likelihood (A.16) with the previous variance, then A.17
            if c >= start and math.isfinite(e_src):
                if vn >= 1 and v > 0.0:
                    r2 = e_src * e_src / v
                    stat[t, b] = r2
                    loglik[t, b] = -0.5 * (_LOG_2PI + math.log(v) + r2)
                else:
                    stat[t, b] = np.nan
                    loglik[t, b] = np.nan
                vn += 1
                v += (e_src * e_src - v) / vn
            else:
                stat[t, b] = np.nan
                loglik[t, b] = np.nan
            variance[t, b] = v if vn >= 1 else np.nan
            c += 1
        for i in range(q):
            for j in range(q):
                L_all[b, i, j] = L[i, j]
        var[b] = v
        var_n[b] = vn
        count[b] = c


@numba.njit(cache=True)
def _solve_orders(L_all, m, out):
    """theta_m = R_m^{-T} k~_m (A.13) for every model in the batch."""
    B = L_all.shape[0]
    p = L_all.shape[1] - 1
    k = np.empty(m)
    x = np.empty(m)
    for b in range(B):
        for j in range(m):
            k[j] = L_all[b, p, j]
        back_subst_t(L_all[b], k, x, m)
        for j in range(m):
            out[b, j] = x[j]


@dataclass(frozen=True)
class RLSResult:
    """Per-sample output of :meth:`SquareRootRLS.run` (time axis first).

    Attributes
    ----------
    prior_errors : (N, B, p+1) a priori prediction errors (innovations, 6.7) of
        every order: ``[..., j] = y(n) - psi_{1:j}(n) theta_j(n-1)``; column 0
        is y itself (A.15).  NaN (without regularisation) while fewer than j
        samples came before n.
    posterior_errors : (N, B, p+1) a posteriori residuals
        ``y(n) - psi_{1:j}(n) theta_j(n)`` (A.14 with R(n), k~(n)); NaN while
        fewer than j samples (including n) have been seen.
    reflection : (N, B, p) unnormalised reflection coefficients k~(n) (A.12).
    variance : (N, B) running variance V_nu(n) (A.17) *after* sample n; NaN
        before the variance estimate has started.
    loglik : (N, B) per-sample log-likelihood (A.16) of the error at n under
        the variance estimated from the errors before n; NaN until available.
    chi2 : (N, B) ``nu(n)^2 / V_nu(n-1)`` -- the chi-square(1) statistic of 6.11
        that the Page-Hinkley detector sums over channels (the name
        :attr:`KalmanResult.chi2` uses; ``stat`` is its former name).
    """

    prior_errors: np.ndarray
    posterior_errors: np.ndarray
    reflection: np.ndarray
    variance: np.ndarray
    loglik: np.ndarray
    chi2: np.ndarray

    @property
    def stat(self) -> np.ndarray:
        """The former name of :attr:`chi2`."""
        return self.chi2

    @property
    def innovations(self) -> np.ndarray:
        """(N, B) full-order a priori errors -- the innovations of 6.7."""
        return self.prior_errors[..., -1]

    @property
    def residuals(self) -> np.ndarray:
        """(N, B) full-order a posteriori residuals."""
        return self.posterior_errors[..., -1]


class SquareRootRLS:
    """Square-root recursive least squares (A.10-A.17), batched over models.

    Parameters
    ----------
    variance_warmup : number of samples (since start or restart) skipped before
        the running variance of A.17 starts.  The thesis's segmentation starts
        it on the ninth measurement: ``variance_warmup=8`` (default).  It never
        starts before sample ``p + 1`` (index p), the first with an order-p
        a priori prediction.
    variance_source : ``"prior"`` (default) feeds the a priori prediction
        errors (innovations, 6.7) into A.16/A.17; ``"posterior"`` the a
        posteriori residuals (the literal reading of A.12-A.15).
    regularization : ``delta >= 0``; the factor starts as ``delta * I``
        (information ``delta^2 I``, a ridge prior).  0 (default) gives exact
        least squares; the a priori errors are then NaN until the leading
        blocks of R are non-singular.

    Attributes
    ----------
    factor_ : (B, p+1, p+1) augmented factor ``[[R, 0], [k~^T, e]]``.
    info_sqrt_ : (B, p, p) R (lower-triangular, ``I = R R^T``, A.11).
    reflection_ : (B, p) k~ (A.12).
    residual_energy_ : (B,) ``e^2 = E0 - k~^T k~`` (footnote 3).
    energy_ : (B,) E0 = sum y^2.
    n_samples_ : (B,) samples absorbed since start / restart.
    variance_ : (B,) running variance (A.17); NaN before it starts.
    """

    def __init__(self, *, variance_warmup: int = 8, variance_source: str = "prior",
                 regularization: float = 0.0):
        self.variance_warmup = variance_warmup
        self.variance_source = variance_source
        self.regularization = regularization

    # -- parameters and state ------------------------------------------------------
    def _check_params(self) -> None:
        if not isinstance(self.variance_warmup, (int, np.integer)) or self.variance_warmup < 0:
            raise ValueError("variance_warmup must be an integer >= 0; "
                             f"got {self.variance_warmup!r}")
        if self.variance_source not in ("prior", "posterior"):
            raise ValueError("variance_source must be 'prior' or 'posterior'; "
                             f"got {self.variance_source!r}")
        if not (np.isfinite(self.regularization) and self.regularization >= 0):
            raise ValueError("regularization must be a finite number >= 0; "
                             f"got {self.regularization!r}")

    def _init_state(self, batch: int, p: int) -> None:
        self._check_params()
        q = p + 1
        self.factor_ = np.zeros((batch, q, q))
        idx = np.arange(p)
        self.factor_[:, idx, idx] = float(self.regularization)
        self.variance_ = np.full(batch, np.nan)
        self._var_n = np.zeros(batch, dtype=np.int64)
        self.n_samples_ = np.zeros(batch, dtype=np.int64)

    def _ensure_state(self, batch: int, p: int) -> None:
        if getattr(self, "factor_", None) is None:
            self._init_state(batch, p)
        elif self.factor_.shape[:2] != (batch, p + 1):
            raise ValueError(
                f"this estimator holds B={self.factor_.shape[0]} models of order "
                f"p={self.factor_.shape[1] - 1}; got data with B={batch}, p={p} "
                "(call reset() to start over with another shape)")

    def reset(self, mask=None) -> "SquareRootRLS":
        """Restart the models in ``mask`` (all when None) -- e.g. after a change.

        With ``mask=None`` the state is dropped entirely and the next call may
        use a different (B, p).
        """
        if mask is None or getattr(self, "factor_", None) is None:
            self.factor_ = None
            return self
        sel = batch_mask(mask, self.factor_.shape[0])
        q = self.factor_.shape[1]
        fresh = np.zeros((int(sel.sum()), q, q))
        idx = np.arange(q - 1)
        fresh[:, idx, idx] = float(self.regularization)
        self.factor_[sel] = fresh
        self.variance_[sel] = np.nan
        self._var_n[sel] = 0
        self.n_samples_[sel] = 0
        return self

    # -- recursion ---------------------------------------------------------------
    def run(self, psi, y) -> RLSResult:
        """Absorb ``N`` samples for every model; per-sample outputs.

        ``psi`` (N, B, p), ``y`` (N, B) (or (N, p), (N,) for one model).  The
        state carries over between calls, so consecutive calls on consecutive
        chunks equal one call on the whole.
        """
        psi, y = scalar_regression(psi, y)
        N, B, p = psi.shape
        self._ensure_state(B, p)
        q = p + 1
        out = dict(
            prior_errors=np.empty((N, B, q)), posterior_errors=np.empty((N, B, q)),
            reflection=np.empty((N, B, p)), variance=np.empty((N, B)),
            loglik=np.empty((N, B)), chi2=np.empty((N, B)))
        start = max(int(self.variance_warmup), p)
        var = np.nan_to_num(self.variance_, nan=0.0)
        _rls_kernel(psi, y, self.factor_, var, self._var_n, self.n_samples_, start,
                    self.variance_source == "prior", float(self.regularization) > 0.0,
                    out["prior_errors"], out["posterior_errors"], out["reflection"],
                    out["variance"], out["loglik"], out["chi2"])
        self.variance_ = np.where(self._var_n > 0, var, np.nan)
        return RLSResult(**out)

    def update(self, psi, y) -> RLSResult:
        """One sample for every model: ``psi`` (B, p), ``y`` (B,).

        Returns an :class:`RLSResult` whose arrays have no time axis.
        """
        psi = np.asarray(psi, dtype=np.float64)
        y = np.asarray(y, dtype=np.float64)
        res = self.run(psi[None], y[None])
        return RLSResult(**{k: v[0] for k, v in res.__dict__.items()})

    # -- read-outs --------------------------------------------------------------------
    def _require(self) -> np.ndarray:
        if getattr(self, "factor_", None) is None:
            raise RuntimeError("SquareRootRLS has no data yet; call run() or update() first")
        return self.factor_

    def _order(self, order) -> int:
        p = self._require().shape[1] - 1
        m = p if order is None else int(order)
        if not 1 <= m <= p:
            raise ValueError(f"order must be between 1 and p={p}; got {order!r}")
        return m

    @property
    def info_sqrt_(self) -> np.ndarray:
        f = self._require()
        return f[:, :-1, :-1]

    @property
    def reflection_(self) -> np.ndarray:
        f = self._require()
        return f[:, -1, :-1]

    @property
    def residual_energy_(self) -> np.ndarray:
        f = self._require()
        return f[:, -1, -1] ** 2

    @property
    def energy_(self) -> np.ndarray:
        f = self._require()
        return np.sum(f[:, -1, :] ** 2, axis=1)

    def coef(self, order: int | None = None) -> np.ndarray:
        """(B, m) least-squares parameters of the order-m model, ``R_m^T theta_m = k~_m`` (A.13).

        Any order ``1 <= m <= p`` comes from the same factor: the leading
        m x m block of R and the first m reflection coefficients.
        """
        m = self._order(order)
        out = np.empty((self.factor_.shape[0], m))
        _solve_orders(self.factor_, m, out)
        return out

    def orthogonal_coef(self, order: int | None = None) -> np.ndarray:
        """(B, m) orthogonal parameters ``k~_j / R_jj`` -- the quantity the
        orthogonal-regressor filter estimates (A.40-A.42, eq. 7.3).

        ``R_jj`` is the norm of the j-th regressor column after removing its
        projection on the earlier ones, so ``k~_j / R_jj`` is the coefficient of
        y on that orthogonalised column: unlike k~ (which grows like sqrt(n))
        it does not depend on the number of samples.
        """
        m = self._order(order)
        f = self.factor_
        diag = np.diagonal(f[:, :m, :m], axis1=1, axis2=2)
        with np.errstate(divide="ignore", invalid="ignore"):
            return f[:, -1, :m] / diag

    def order_residual_energy(self, order: int | None = None) -> np.ndarray:
        """(B,) residual energy of the order-m fit, ``E0 - k~_m^T k~_m``."""
        m = self._order(order)
        f = self.factor_
        return f[:, -1, -1] ** 2 + np.sum(f[:, -1, m:-1] ** 2, axis=1)

    def sequence_loglik(self, order: int | None = None) -> np.ndarray:
        """(B,) exact log-likelihood of the whole sequence at the MLE (footnote 3).

        See :func:`exact_sequence_loglik`; ``n`` is ``n_samples_``.
        """
        return exact_sequence_loglik(self.order_residual_energy(order), self.n_samples_)


def exact_sequence_loglik(residual_energy, n) -> np.ndarray:
    """Gaussian log-likelihood of n scalar residuals at the ML variance.

    Footnote 3 prints ``-n/2 (log((E0 - k~^T k~)/n) + m)``.  For a scalar
    measurement with ``sigma^2 = (E0 - k~^T k~)/n`` the maximised Gaussian
    log-likelihood is ``-n/2 (log sigma^2 + 1) - n/2 log(2 pi)``: the "+ m" is
    the measurement dimension (``-n/2 (log det V + m)`` for an m-vector with ML
    covariance V), which is 1 here -- not the model order.  We use ``+ 1`` and
    include the ``log(2 pi)`` term (tested against a direct computation from
    numpy.linalg.lstsq residuals).
    """
    e = np.asarray(residual_energy, dtype=np.float64)
    n = np.asarray(n, dtype=np.float64)
    with np.errstate(divide="ignore", invalid="ignore"):
        return -0.5 * n * (np.log(e / n) + 1.0 + _LOG_2PI)
