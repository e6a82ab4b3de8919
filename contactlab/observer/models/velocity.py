"""Velocity feature models of 9.1.1: fixed (F) and moving (M).

* F -- the robot is not moving: the measured velocity is the measurement
  noise, ``v ~ N(0, sigma^2 I)`` (9.1.1: "a vector normal distribution with
  zero mean and variance corresponding to the measurement noise").
* M -- the robot is moving: every velocity in ``[low, high]`` per component
  is equally likely (9.1.1: uniform on [-0.01, 0.01]; the maximum-entropy
  choice of footnote 1, ch. 5).  The measured velocity is that velocity plus
  the same measurement noise, so its density is the uniform convolved with
  N(0, sigma^2): ``(Phi((high - v)/sigma) - Phi((low - v)/sigma)) / (high - low)``.
  (Our choice: a bare uniform gives probability zero to a measurement just
  outside the range and would kill the correct path on one noisy sample.)

Both are stateless (no parameters are estimated per instance).  Their
parameters are given in the graph file or trained from labelled samples
(:meth:`FixedVelocity.fit`, :meth:`MovingVelocity.fit`): F's ``sigma`` is the
root mean square of the velocity over the samples labelled still (the
zero-mean normal's maximum-likelihood variance); M's range is symmetric,
``+-`` the 99th percentile of ``|v|`` over the samples labelled moving (our
choice: the thesis's fixed +-0.01 m/s assumes its apparatus's speeds), and its
``sigma`` the velocity's white-noise level within those runs
(:func:`contactlab.constraints.noise.raw_noise_sd`, the median over runs and
components).  The innovation the
detector tests is the measurement standardised by the model's variance:
``v / sigma`` for F, ``(v - centre) / sqrt(width^2/12 + sigma^2)`` for M
(our choice; the thesis does not say what the velocity models' detectors
test), chi-square with m = number of components under the model's
second moment.  F tests only an increase of it (6.14): a velocity below the
noise (a still finger whose encoders hold one count) is still F's best
explanation, and the decrease test fired on every such stretch.  M keeps every
test the observer runs: its covariance-decrease test is how a stop is found
(the maze's moving -> fixed corner transitions).

One compiled step scores a sample (:func:`velocity_step`); the models' ``run``
loops it over a chunk and the observer's compiled core
(:mod:`contactlab.observer.engine`) calls it per sample, so both give the same
numbers to the bit.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from contactlab.observer.models.base import LOG_2PI, FeatureModel

__all__ = ["FixedVelocity", "MovingVelocity", "velocity_step", "log_ndtr"]


class FixedVelocity(FeatureModel):
    """F: zero velocity, ``v ~ N(0, sigma^2 I)``."""

    kind = "velocity-fixed"
    tests = ("increase",)

    def __init__(self, *, name: str = "F", sigma: float | None = None,
                 signal: str = "velocity", change_size: float | None = None):
        super().__init__(name=name, signal=signal, change_size=change_size)
        if sigma is not None and not sigma > 0:
            raise ValueError(f"{name}: sigma must be > 0; got {sigma!r}")
        self.sigma = None if sigma is None else float(sigma)

    def fit(self, X, y=None) -> "FixedVelocity":
        """``sigma`` from labelled still samples (segments (n_i, C)): the pooled RMS."""
        segs = self._segments(X, self.name)
        v = np.concatenate(segs)
        self.sigma = max(float(np.sqrt(np.mean(v * v))), 1e-12)
        self._record(segs)
        return self

    def params(self) -> dict:
        return {"sigma": self.sigma}

    @property
    def _p(self) -> np.ndarray:
        self._fitted("sigma")
        return np.array([0.0, self.sigma, 0.0, 0.0, self.sigma ** 2, 0.0])

    def run(self, state, x, *, t0, starts):
        return _run_kernel(np.ascontiguousarray(x, dtype=np.float64), self._p, len(starts))

    def chi2(self, x) -> np.ndarray:
        """The chi-square of each sample of ``x`` (n, C), as :meth:`run` gives it."""
        return _chi_kernel(np.ascontiguousarray(x, dtype=np.float64), self._p)

    def core_spec(self, channels):
        return _core_spec(self, FixedVelocity, channels)


class MovingVelocity(FeatureModel):
    """M: each component uniform on ``[low, high]``, measured with N(0, sigma^2) noise."""

    kind = "velocity-moving"

    def __init__(self, *, name: str = "M", low: float | None = None,
                 high: float | None = None, sigma: float | None = None,
                 signal: str = "velocity", change_size: float | None = None,
                 rest_sigma: float | None = None):
        super().__init__(name=name, signal=signal, change_size=change_size)
        if rest_sigma is not None and not rest_sigma > 0:
            raise ValueError(f"{name}: rest_sigma must be > 0; got {rest_sigma!r}")
        self.rest_sigma = None if rest_sigma is None else float(rest_sigma)
        self._given_change_size = change_size
        self.low = self.high = self.sigma = None
        if any(v is not None for v in (low, high, sigma)):
            self._set(low, high, sigma)

    def _set(self, low, high, sigma) -> None:
        name = self.name
        if low is None or high is None or sigma is None:
            raise ValueError(f"{name}: give low, high and sigma together (or call fit)")
        if not low < high:
            raise ValueError(f"{name}: need low < high; got [{low}, {high}]")
        if not sigma > 0:
            raise ValueError(f"{name}: sigma must be > 0; got {sigma!r}")
        self.low, self.high, self.sigma = float(low), float(high), float(sigma)
        if self._given_change_size is None and self.rest_sigma is not None:
            # the covariance-decrease test's alternative (6.14 with V / q) is the robot at
            # rest, v ~ N(0, rest_sigma^2): F's variance (9.1.1's pair F/M is "a test for
            # deciding if the robot was moving or not")
            self.change_size = max(self.variance / self.rest_sigma ** 2, 1.0 + 1e-9)

    def fit(self, X, y=None) -> "MovingVelocity":
        """Range and noise from labelled moving runs (segments (n_i, C), module notes)."""
        from contactlab.constraints.noise import raw_noise_sd

        segs = self._segments(X, self.name)
        high = float(np.quantile(np.abs(np.concatenate(segs)), 0.99))
        noise = [raw_noise_sd(s) for s in segs if len(s) >= 5]
        sigma = float(np.median(np.concatenate(noise))) if noise else 0.1 * high
        sigma = max(sigma, 1e-3 * high, 1e-12)
        self._set(-max(high, 1e-9), max(high, 1e-9), sigma)
        self._record(segs)
        return self

    @property
    def variance(self) -> float:
        """Per-component second moment about the centre: ``width^2 / 12 + sigma^2``."""
        return (self.high - self.low) ** 2 / 12.0 + self.sigma ** 2

    def with_rest(self, rest_sigma: float) -> "MovingVelocity":
        """A copy whose decrease test's alternative is ``N(0, rest_sigma^2)`` (the F model
        of the same graph, :func:`~contactlab.observer.models.composite.build_models`)."""
        return MovingVelocity(name=self.name, low=self.low, high=self.high, sigma=self.sigma,
                              signal=self.signal, rest_sigma=rest_sigma)

    def params(self) -> dict:
        return {"low": self.low, "high": self.high, "sigma": self.sigma}

    @property
    def _p(self) -> np.ndarray:
        self._fitted("low", "high", "sigma")
        return np.array([1.0, self.sigma, self.low, self.high, self.variance,
                         0.5 * (self.low + self.high)])

    def logpdf(self, x) -> np.ndarray:
        """Per-component log density of the measured velocity."""
        self._fitted("low", "high", "sigma")
        x = np.asarray(x, dtype=np.float64)
        return _logpdf_array(np.ascontiguousarray(x.reshape(-1)), self.low, self.high,
                             self.sigma).reshape(x.shape)

    def run(self, state, x, *, t0, starts):
        return _run_kernel(np.ascontiguousarray(x, dtype=np.float64), self._p, len(starts))

    def chi2(self, x) -> np.ndarray:
        """The chi-square of each sample of ``x`` (n, C), as :meth:`run` gives it."""
        return _chi_kernel(np.ascontiguousarray(x, dtype=np.float64), self._p)

    def core_spec(self, channels):
        return _core_spec(self, MovingVelocity, channels)


def _core_spec(model, cls, channels):
    """The compiled core's spec of a velocity model: stateless, parameters :func:`velocity_step`'s."""
    if type(model).run is not cls.run:
        return None
    from contactlab.observer.engine import REG_VELOCITY

    return {"reg": REG_VELOCITY, "channels": channels, "prior": np.zeros(1), "params": model._p}


@numba.njit(cache=True)
def log_ndtr(x):  # pragma: no cover - compiled
    """``log Phi(x)``, the standard normal's log distribution function, to full precision in
    both tails: ``log1p(-Phi(-x))`` above 0, ``log(erfc(-x / sqrt 2) / 2)`` down to -20, and
    below it the asymptotic series ``-x^2/2 - log(-x) - log(2 pi)/2 + log(1 - 1/x^2 + 3/x^4
    - ...)`` (summed while its terms shrink), as scipy's ``log_ndtr`` does below -20."""
    if x > 0.0:
        return math.log1p(-0.5 * math.erfc(x / math.sqrt(2.0)))
    if x > -20.0:
        return math.log(0.5 * math.erfc(-x / math.sqrt(2.0)))
    x2 = x * x
    term = 1.0
    total = 1.0
    k = 1
    while True:
        nxt = -term * (2 * k - 1) / x2
        if abs(nxt) >= abs(term) or abs(nxt) < 1e-17:
            break
        term = nxt
        total += term
        k += 1
    return -0.5 * x2 - math.log(-x) - 0.5 * LOG_2PI + math.log(total)


@numba.njit(cache=True)
def _logpdf(v, low, high, sigma):  # pragma: no cover - compiled
    """M's log density of one measured component: ``log(Phi(b) - Phi(a)) - log(high - low)``
    with ``a, b = (low - v) / sigma, (high - v) / sigma``, from the upper tail where both are
    near one."""
    a = (low - v) / sigma
    b = (high - v) / sigma
    if a > 0.0:
        lo, hi = -b, -a
    else:
        lo, hi = a, b
    lhi = log_ndtr(hi)
    d = log_ndtr(lo) - lhi
    return lhi + math.log1p(-math.exp(d if d < 0.0 else 0.0)) - math.log(high - low)


@numba.njit(cache=True)
def _logpdf_array(x, low, high, sigma):  # pragma: no cover - compiled
    out = np.empty(x.shape[0])
    for i in range(x.shape[0]):
        out[i] = _logpdf(x[i], low, high, sigma)
    return out


@numba.njit(cache=True)
def velocity_chi(p, x):  # pragma: no cover - compiled
    """The chi-square of one velocity sample ``x`` (C components) under :func:`velocity_step`'s
    parameters ``p``: F ``|x|^2 / sigma^2``, M ``|x - centre|^2 / (width^2/12 + sigma^2)``."""
    chi = 0.0
    if p[0] == 0.0:
        for c in range(x.shape[0]):
            z = x[c] / p[1]
            chi += z * z
        return chi
    for c in range(x.shape[0]):
        d = x[c] - p[5]
        chi += d * d
    return chi / p[4]


@numba.njit(cache=True)
def velocity_step(p, x):  # pragma: no cover - compiled
    """Score one velocity sample ``x`` (C components): ``(log-likelihood, chi-square)``.
    ``p``: moving (0 F, 1 M), sigma, low, high, the second moment and the centre.  F:
    ``-|x|^2 / (2 sigma^2) - C (log sigma + log(2 pi) / 2)``; M: the components'
    :func:`_logpdf`; the chi-square :func:`velocity_chi`'s."""
    C = x.shape[0]
    chi = velocity_chi(p, x)
    if p[0] == 0.0:
        return -0.5 * chi - C * (math.log(p[1]) + 0.5 * LOG_2PI), chi
    ll = 0.0
    for c in range(C):
        ll += _logpdf(x[c], p[2], p[3], p[1])
    return ll, chi


@numba.njit(cache=True)
def _chi_kernel(x, p):  # pragma: no cover - compiled
    """:func:`velocity_chi` of each sample of ``x`` (n, C)."""
    out = np.empty(x.shape[0])
    for t in range(x.shape[0]):
        out[t] = velocity_chi(p, x[t])
    return out


@numba.njit(cache=True)
def _run_kernel(x, p, U):  # pragma: no cover - compiled
    """:func:`velocity_step` over samples ``x`` (n, C), the same for ``U`` instances
    (stateless): (n, U) log-likelihoods and chi-squares."""
    n = x.shape[0]
    ll = np.empty((n, U))
    chi2 = np.empty((n, U))
    for t in range(n):
        a, b = velocity_step(p, x[t])
        for u in range(U):
            ll[t, u] = a
            chi2[t, u] = b
    return ll, chi2
