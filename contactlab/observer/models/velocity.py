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
"""

from __future__ import annotations

import numpy as np
from scipy.special import log_ndtr

from contactlab.observer.models.base import LOG_2PI, FeatureModel

__all__ = ["FixedVelocity", "MovingVelocity"]


class FixedVelocity(FeatureModel):
    """F: zero velocity, ``v ~ N(0, sigma^2 I)``."""

    kind = "velocity-fixed"
    tests = ("increase",)

    def __init__(self, *, name: str = "F", sigma: float, signal: str = "velocity",
                 change_size: float | None = None):
        super().__init__(name=name, signal=signal, change_size=change_size)
        if not sigma > 0:
            raise ValueError(f"{name}: sigma must be > 0; got {sigma!r}")
        self.sigma = float(sigma)

    @classmethod
    def from_segments(cls, segments, *, name: str = "F", signal: str = "velocity") -> "FixedVelocity":
        """``sigma`` from labelled still samples (segments (n_i, C)): the pooled RMS."""
        v = np.concatenate([np.asarray(s, np.float64).reshape(len(s), -1) for s in segments])
        if v.size == 0:
            raise ValueError(f"{name}: no labelled samples")
        return cls(name=name, sigma=max(float(np.sqrt(np.mean(v * v))), 1e-12), signal=signal)

    def params(self) -> dict:
        return {"sigma": self.sigma}

    def run(self, state, x, *, t0, starts):
        z2 = (x / self.sigma) ** 2
        C = x.shape[1]
        ll = -0.5 * z2.sum(axis=1) - C * (np.log(self.sigma) + 0.5 * LOG_2PI)
        U = len(starts)
        return (np.repeat(ll[:, None], U, axis=1), np.repeat(z2.sum(axis=1)[:, None], U, axis=1))


class MovingVelocity(FeatureModel):
    """M: each component uniform on ``[low, high]``, measured with N(0, sigma^2) noise."""

    kind = "velocity-moving"

    def __init__(self, *, name: str = "M", low: float, high: float, sigma: float,
                 signal: str = "velocity", change_size: float | None = None,
                 rest_sigma: float | None = None):
        super().__init__(name=name, signal=signal, change_size=change_size)
        if not low < high:
            raise ValueError(f"{name}: need low < high; got [{low}, {high}]")
        if not sigma > 0:
            raise ValueError(f"{name}: sigma must be > 0; got {sigma!r}")
        if rest_sigma is not None and not rest_sigma > 0:
            raise ValueError(f"{name}: rest_sigma must be > 0; got {rest_sigma!r}")
        self.low, self.high, self.sigma = float(low), float(high), float(sigma)
        self.rest_sigma = None if rest_sigma is None else float(rest_sigma)
        if change_size is None and self.rest_sigma is not None:
            # the covariance-decrease test's alternative (6.14 with V / q) is the robot at
            # rest, v ~ N(0, rest_sigma^2): F's variance (9.1.1's pair F/M is "a test for
            # deciding if the robot was moving or not")
            self.change_size = max(self.variance / self.rest_sigma ** 2, 1.0 + 1e-9)

    @property
    def variance(self) -> float:
        """Per-component second moment about the centre: ``width^2 / 12 + sigma^2``."""
        return (self.high - self.low) ** 2 / 12.0 + self.sigma ** 2

    def with_rest(self, rest_sigma: float) -> "MovingVelocity":
        """A copy whose decrease test's alternative is ``N(0, rest_sigma^2)`` (the F model
        of the same graph, :func:`~contactlab.observer.models.composite.build_models`)."""
        return MovingVelocity(name=self.name, low=self.low, high=self.high, sigma=self.sigma,
                              signal=self.signal, rest_sigma=rest_sigma)

    @classmethod
    def from_segments(cls, segments, *, name: str = "M", signal: str = "velocity") -> "MovingVelocity":
        """Range and noise from labelled moving runs (segments (n_i, C), module notes)."""
        from contactlab.constraints.noise import raw_noise_sd

        segs = [np.asarray(s, np.float64).reshape(len(s), -1) for s in segments]
        v = np.concatenate(segs) if segs else np.zeros((0, 1))
        if v.size == 0:
            raise ValueError(f"{name}: no labelled samples")
        high = float(np.quantile(np.abs(v), 0.99))
        noise = [raw_noise_sd(s) for s in segs if len(s) >= 5]
        sigma = float(np.median(np.concatenate(noise))) if noise else 0.1 * high
        sigma = max(sigma, 1e-3 * high, 1e-12)
        return cls(name=name, low=-max(high, 1e-9), high=max(high, 1e-9), sigma=sigma,
                   signal=signal)

    def params(self) -> dict:
        return {"low": self.low, "high": self.high, "sigma": self.sigma}

    def logpdf(self, x) -> np.ndarray:
        """Per-component log density of the measured velocity."""
        x = np.asarray(x, dtype=np.float64)
        a = (self.low - x) / self.sigma
        b = (self.high - x) / self.sigma
        # log(Phi(b) - Phi(a)), b > a; use the upper tail where both are near 1
        flip = a > 0
        lo = np.where(flip, -b, a)
        hi = np.where(flip, -a, b)
        lhi = log_ndtr(hi)
        diff = lhi + np.log1p(-np.exp(np.minimum(log_ndtr(lo) - lhi, 0.0)))
        return diff - np.log(self.high - self.low)

    def run(self, state, x, *, t0, starts):
        ll = self.logpdf(x).sum(axis=1)
        centre = 0.5 * (self.low + self.high)
        chi2 = ((x - centre) ** 2).sum(axis=1) / self.variance
        U = len(starts)
        return np.repeat(ll[:, None], U, axis=1), np.repeat(chi2[:, None], U, axis=1)
