"""Temporal feature models: AR(p) (with a forcing mean) under a trained prior (7.1, 7.3.1).

Each instance is an orthogonal-regressor square-root Kalman filter (A.2.3,
A.40-A.42) started at the prior learned from training segments: the mean and
square-root covariance of the orthogonal parameters, the training correlation
structure R (``structure="fixed"``) and the mean driving-noise variance,
which stays fixed (7.3.1: "the mean of the variance was also stored").  The
C channels of the signal are independent (7.1), so a node's log-likelihood is
the sum over channels and its innovation is C-dimensional with a diagonal
covariance (m = C in 6.14).

The regressors of the first sample of an instance use the p measurements
before its start (the Markov measurement process of 6.1 conditions on the
past samples, which are observed whatever node produced them).
"""

from __future__ import annotations

import numpy as np

from contactlab.estimators.models import ARModel
from contactlab.observer.models._kalman import (MODES, as_channel_prior, prior_state,
                                                repeat_state, run_kalman)
from contactlab.observer.models.base import FeatureModel

__all__ = ["TemporalFeature"]


class TemporalFeature(FeatureModel):
    """AR(``order``) model (``mean``: with a forcing mean, parameter order {mu, a1..ap}).

    Parameters
    ----------
    theta_mean : (C, q) or (q,) prior mean of the parameters (orthogonal
        parameters unless ``structure="plain"``), q = order + mean.
    theta_sqrt : (C, q, q), (q, q) or (q,) lower-triangular square root of the
        prior covariance.
    noise_var : (C,) or scalar driving-noise variance V_nu.
    structure : ``"fixed"`` (A.42 with the training structure, the thesis's
        labelling filter), ``"track"`` (A.41 on-line from ``structure_sqrt``) or
        ``"plain"`` (natural parameters, A.32-A.39 without A.40).
    structure_sqrt : (C, q, q) or (q, q) training information factor L
        (required for ``"fixed"``; initial factor for ``"track"``).
    estimate_noise : replace V_nu by the running estimate of A.38.
    """

    kind = "temporal"

    def __init__(self, *, name: str, order: int, mean: bool, theta_mean, theta_sqrt, noise_var,
                 structure: str = "fixed", structure_sqrt=None, signal: str = "hf",
                 estimate_noise: bool = False, noise_prior_count: float = 8.0,
                 change_size: float | None = None):
        super().__init__(name=name, signal=signal, change_size=change_size)
        self.ar = ARModel(order=order, mean=mean)
        q = self.ar.n_params
        if structure not in MODES:
            raise ValueError(f"{name}: structure must be one of {list(MODES)}; got {structure!r}")
        self.structure = structure
        self.theta_mean, self.theta_sqrt, self.noise_var = as_channel_prior(
            theta_mean, theta_sqrt, noise_var, q, name)
        C = self.theta_mean.shape[0]
        if structure_sqrt is None:
            if structure == "fixed":
                raise ValueError(f"{name}: structure='fixed' needs structure_sqrt")
            L = np.eye(q) * (1e-6 if structure == "track" else 1.0)
        else:
            L = np.asarray(structure_sqrt, dtype=np.float64)
        try:
            self.structure_sqrt = np.broadcast_to(L, (C, q, q)).copy()
        except ValueError:
            raise ValueError(f"{name}: structure_sqrt must be ({q}, {q}) or ({C}, {q}, {q})") from None
        if structure == "fixed" and np.any(np.diagonal(self.structure_sqrt, axis1=1, axis2=2) <= 0):
            raise ValueError(f"{name}: structure_sqrt must have a positive diagonal")
        self.estimate_noise = estimate_noise
        self.noise_prior_count = noise_prior_count
        self.lag = self.ar.order

    @classmethod
    def from_trained(cls, model, *, name: str | None = None, signal: str = "hf",
                     structure: str = "fixed", change_size: float | None = None):
        """From a trained :class:`contactlab.temporal.TemporalModel` (its documented fields)."""
        cov = np.asarray(model.theta_cov, dtype=np.float64)
        return cls(name=name or model.label, order=int(model.order), mean=bool(model.mean),
                   theta_mean=model.theta_mean, theta_sqrt=np.linalg.cholesky(cov),
                   noise_var=model.noise_var, structure=structure,
                   structure_sqrt=model.structure_sqrt, signal=signal, change_size=change_size)

    def with_mean_sd(self, mean_sd: float) -> "TemporalFeature":
        """A copy whose prior standard deviation of the mean is ``mean_sd`` (9.1.1: "the
        expected standard deviation of the mean was increased to 2.5", so that one
        stationary model covers every stationary level of y_h).

        With the constant regressor first, the first orthogonal parameter is the
        signal's level (A.42: ``k~_0 / R_00`` is the sample mean of the block), so its
        row of the prior square root is rescaled to standard deviation ``mean_sd``:
        ``S' = D S`` with ``D = diag(mean_sd / sd_0, 1, ...)`` keeps the prior's
        correlations and its lower-triangular form.  (Under ``structure="plain"`` the
        first parameter is the forcing term mu of the natural parameters instead.)
        """
        import copy

        if not self.ar.mean:
            raise ValueError(f"{self.name}: mean_sd needs a model with a mean (mean=True)")
        if not (np.ndim(mean_sd) == 0 and np.isfinite(mean_sd) and mean_sd > 0):
            raise ValueError(f"{self.name}: mean_sd must be a number > 0; got {mean_sd!r}")
        out = copy.copy(self)
        sd0 = np.sqrt(np.sum(self.theta_sqrt[:, 0, :] ** 2, axis=-1))          # (C,)
        S = self.theta_sqrt.copy()
        S[:, 0, :] *= (float(mean_sd) / sd0)[:, None]
        out.theta_sqrt = S
        out.__dict__.pop("_templates", None)
        return out

    @property
    def channels(self) -> int:
        return self.theta_mean.shape[0]

    def _prior(self, channels):
        if self.channels == channels:
            return self.theta_mean, self.theta_sqrt, self.noise_var, self.structure_sqrt
        # a prior given once is shared by every channel
        return (np.repeat(self.theta_mean, channels, 0), np.repeat(self.theta_sqrt, channels, 0),
                np.repeat(self.noise_var, channels, 0), np.repeat(self.structure_sqrt, channels, 0))

    def check_channels(self, channels: int) -> None:
        if self.channels not in (1, channels):
            raise ValueError(f"model {self.name!r} was trained on {self.channels} channels; "
                             f"the {self.signal!r} signal has {channels}")

    def init_state(self, starts, channels):
        cache = self.__dict__.setdefault("_templates", {})
        if channels not in cache:
            cache[channels] = prior_state(1, *self._prior(channels))
        return repeat_state(cache[channels], len(starts))

    def batch_key(self):
        return (type(self), self.signal, self.ar.order, self.ar.mean, self.structure, self.estimate_noise,
                self.noise_prior_count)

    def kalman_spec(self, channels):
        if type(self).run is not TemporalFeature.run or type(self).init_state is not TemporalFeature.init_state:
            return None
        from contactlab.observer.engine import REG_AR
        return {"reg": REG_AR, "order": self.ar.order, "mean": bool(self.ar.mean),
                "q": self.ar.n_params, "mode": MODES[self.structure],
                "estimate_noise": bool(self.estimate_noise),
                "noise_prior_count": float(self.noise_prior_count), "channels": channels,
                "prior": self.init_state(np.zeros(1, dtype=np.int64), channels)}

    def run(self, state, x, *, t0, starts):
        return run_kalman(state, self.ar.regressors(x), x[self.lag:], mode=MODES[self.structure],
                          estimate_noise=self.estimate_noise,
                          noise_prior_count=self.noise_prior_count)
