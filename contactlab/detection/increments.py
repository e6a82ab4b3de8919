"""Log-likelihood-ratio increments Xi(t) that the Page-Hinkley test sums.

Section 6.3.1 tests the innovations ``nu(t)`` of an estimator (6.7) for a
change. With ``gamma_i(t) = log p(nu(t) | H_i)`` the increment is
``Xi_01(t) = gamma_1(t) - gamma_0(t)`` and the log-likelihood ratio of a change
at ``r`` is ``sum_{t=r}^n Xi_01(t)`` (6.13). This module gives the increments
for the two alternatives used in the thesis:

- a change in the *size of the innovation covariance*: H0 ``nu ~ N(0, V)``
  against H1 ``nu ~ N(0, q V)`` (6.14), computed from the chi-square statistic
  ``nu^T V^-1 nu`` (6.11);
- a change in the *mean of a scalar Gaussian signal*: H0 ``y ~ N(mu0, sigma^2)``
  against H1 ``y ~ N(mu0 + dmu, sigma^2)`` (the setting of figs 6.3-6.6).

Two-sided tests run two one-sided tests side by side; the ``*_increments``
functions stack their increments on a trailing axis of length 2, ready for
:class:`~contactlab.detection.page_hinkley.PageHinkley`.
"""

from __future__ import annotations

import numpy as np
from numba import njit

#: Names of the two sides of a two-sided test, in the order of the trailing axis.
VARIANCE_SIDES = ("increase", "decrease")
MEAN_SIDES = ("up", "down")


def chi_square(nu, cov) -> np.ndarray:
    """The test statistic ``nu^T V^-1 nu`` of (6.11), chi-square(m) under H0.

    Parameters
    ----------
    nu : (..., m) innovations.
    cov : (m, m) or (..., m, m) innovation covariance ``V`` (symmetric positive
        definite), broadcast against ``nu``'s leading axes.
    """
    nu = np.asarray(nu, dtype=float)
    cov = np.asarray(cov, dtype=float)
    if nu.ndim == 0:
        raise ValueError("nu must have a trailing axis of length m (the measurement size)")
    m = nu.shape[-1]
    if cov.ndim < 2 or cov.shape[-2:] != (m, m):
        raise ValueError(f"cov must have shape (..., {m}, {m}) to match nu; got {cov.shape}")
    sol = np.linalg.solve(cov, nu[..., None])[..., 0]
    return np.einsum("...i,...i->...", nu, sol)


def variance_increment(chi2, *, dim: int, q: float) -> np.ndarray:
    """Xi for H1 ``nu ~ N(0, q V)`` against H0 ``nu ~ N(0, V)`` (6.14).

    ``Xi = 1/2 (-m log q + (1 - 1/q) chi2)`` with ``chi2 = nu^T V^-1 nu`` and
    ``m = dim``. Any ``q > 0, q != 1`` is allowed:

    - ``q > 1`` tests for an *increase* of the covariance by ``q`` (the thesis's
      alternative);
    - ``q < 1`` tests for a *decrease*. Writing the decrease alternative as
      ``N(0, V/q')`` with ``q' = 1/q > 1``,
      ``log N(nu; 0, V/q') - log N(nu; 0, V) = 1/2 (m log q' + (1 - q') chi2)``
      (the determinant gains ``q'^-m``, the quadratic form is multiplied by
      ``q'``), which is (6.14) with ``q`` replaced by ``1/q'``.

    Under H0 (``E chi2 = m``) the mean increment ``m/2 (1 - 1/q - log q)`` is
    negative for every ``q != 1``, so the sum (6.17) drifts down until a change.
    """
    _check_q(q)
    if int(dim) != dim or dim < 1:
        raise ValueError(f"dim must be a positive integer (the size m of nu); got {dim!r}")
    chi2 = np.asarray(chi2, dtype=float)
    return 0.5 * (-dim * np.log(q) + (1.0 - 1.0 / q) * chi2)


def variance_increments(chi2, *, dim: int, q: float) -> np.ndarray:
    """Increments of the two-sided covariance test: shape ``chi2.shape + (2,)``.

    Side 0 (``"increase"``) is (6.14) with ``q``; side 1 (``"decrease"``) is the
    decrease test with ``1/q`` (see :func:`variance_increment`). ``q > 1``.
    """
    _check_q(q)
    if q < 1:
        raise ValueError(f"q must be > 1 for the two-sided test (it tests q and 1/q); got {q!r}")
    return np.stack([variance_increment(chi2, dim=dim, q=q),
                     variance_increment(chi2, dim=dim, q=1.0 / q)], axis=-1)


def mean_increment(y, *, mu0: float, dmu: float, sigma: float) -> np.ndarray:
    """Xi for a change in mean ``mu0 -> mu0 + dmu`` of ``y ~ N(., sigma^2)``.

    ``log N(y; mu0 + dmu, sigma^2) - log N(y; mu0, sigma^2)
    = (dmu / sigma^2) (y - mu0 - dmu / 2)``. Its mean is ``-beta`` before the
    change and ``+beta`` after, with ``beta = s^2 / 2``, ``s = dmu / sigma``
    (section 6.3.1). A negative ``dmu`` tests for a decrease.
    """
    if sigma <= 0:
        raise ValueError(f"sigma must be > 0; got {sigma!r}")
    if dmu == 0:
        raise ValueError("dmu must be nonzero (the size of the mean change to detect)")
    y = np.asarray(y, dtype=float)
    out = np.empty(y.shape)
    # one compiled pass (a stream of short blocks pays one call, not three numpy passes);
    # the same operations in the same order as (dmu/s^2)(y - mu0 - dmu/2)
    _mean_increment_kernel(y.reshape(-1), out.reshape(-1), float(mu0), 0.5 * dmu,
                           dmu / sigma**2)
    return out


@njit(cache=True)
def _mean_increment_kernel(y, out, mu0, half, scale):  # pragma: no cover - compiled
    for i in range(y.shape[0]):
        out[i] = ((y[i] - mu0) - half) * scale


def mean_increments(y, *, mu0: float, dmu: float, sigma: float) -> np.ndarray:
    """Increments of the two-sided mean test: shape ``y.shape + (2,)``.

    Side 0 (``"up"``) tests ``mu0 + |dmu|``, side 1 (``"down"``) ``mu0 - |dmu|``.
    """
    d = abs(dmu)
    return np.stack([mean_increment(y, mu0=mu0, dmu=d, sigma=sigma),
                     mean_increment(y, mu0=mu0, dmu=-d, sigma=sigma)], axis=-1)


def _check_q(q: float) -> None:
    if not (q > 0) or q == 1:
        raise ValueError(f"q (the change in covariance) must be > 0 and != 1; got {q!r}")
