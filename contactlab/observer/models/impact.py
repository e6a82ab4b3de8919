"""The impact feature: linear decay of the log vibration energy (7.1, fig 7.3).

``y(n) = mu + a (n - start) + nu(n)``, n counted from the instance's start
(the impact begins where the path enters the node), with a trained normal
prior on ``(mu, a)`` and a fixed driving-noise variance; each instance is a
square-root Kalman filter (A.18-A.39) per channel, channels independent.
"""

from __future__ import annotations

import numpy as np

from contactlab.estimators.models import LinearDecayModel, estimate
from contactlab.observer.models._kalman import (MODE_PLAIN, as_channel_prior, prior_state,
                                                repeat_state, run_kalman)
from contactlab.observer.models.base import FeatureModel

__all__ = ["ImpactFeature"]


class ImpactFeature(FeatureModel):
    """Impact-decay model with prior ``theta ~ N(theta_mean, S S^T)`` on ``(mu, a)``.

    Parameters
    ----------
    theta_mean : (C, 2) or (2,) prior mean of ``(mu, a)``.
    theta_sqrt : (C, 2, 2), (2, 2) or (2,) square root of the prior covariance.
    noise_var : (C,) or scalar driving-noise variance.
    """

    kind = "impact"

    def __init__(self, *, name: str, theta_mean=None, theta_sqrt=None, noise_var=None,
                 signal: str = "hf", change_size: float | None = None):
        super().__init__(name=name, signal=signal, change_size=change_size)
        self.theta_mean = self.theta_sqrt = self.noise_var = None
        if any(v is not None for v in (theta_mean, theta_sqrt, noise_var)):
            if theta_mean is None or theta_sqrt is None or noise_var is None:
                raise ValueError(f"{name}: give theta_mean, theta_sqrt and noise_var "
                                 f"together (or call fit)")
            self.theta_mean, self.theta_sqrt, self.noise_var = as_channel_prior(
                theta_mean, theta_sqrt, noise_var, 2, name)

    def fit(self, X, y=None) -> "ImpactFeature":
        """Prior from labelled impact segments (each (N_i, C) or (N_i,), starting at the impact).

        Least squares per segment (``LinearDecayModel``), then the sample mean
        and covariance of ``(mu, a)`` over segments and the mean residual
        variance, per channel.  Needs at least 3 segments.
        """
        X = [np.asarray(seg, dtype=np.float64) for seg in X]
        coefs, var = [], []
        for seg in X:
            f = estimate(LinearDecayModel(), seg)
            coefs.append(f.coef)
            var.append(f.variance)
        if len(coefs) < 3:
            raise ValueError(f"{self.name}: an impact prior needs at least 3 segments; "
                             f"got {len(coefs)}")
        c = np.stack(coefs)                                  # (K, C, 2)
        mean = c.mean(axis=0)
        d = c - mean
        cov = np.einsum("kci,kcj->cij", d, d) / (len(c) - 1)
        cov += np.eye(2) * 1e-12 * np.trace(cov, axis1=1, axis2=2)[:, None, None]
        self.theta_mean, self.theta_sqrt, self.noise_var = as_channel_prior(
            mean, np.linalg.cholesky(cov), np.mean(var, axis=0), 2, self.name)
        self.__dict__.pop("_templates", None)
        self.n_samples_ = int(sum(len(s) for s in X))
        self.n_segments_ = len(coefs)
        return self

    @property
    def channels(self) -> int:
        self._fitted("theta_mean", "theta_sqrt", "noise_var")
        return self.theta_mean.shape[0]

    def check_channels(self, channels: int) -> None:
        if self.channels not in (1, channels):
            raise ValueError(f"model {self.name!r} has a prior for {self.channels} channels; "
                             f"the {self.signal!r} signal has {channels}")

    def init_state(self, starts, channels):
        cache = self.__dict__.setdefault("_templates", {})
        if channels not in cache:
            rep = 1 if self.channels == channels else channels
            cache[channels] = prior_state(
                1, np.repeat(self.theta_mean, rep, 0), np.repeat(self.theta_sqrt, rep, 0),
                np.repeat(self.noise_var, rep, 0), np.broadcast_to(np.eye(2), (channels, 2, 2)))
        return repeat_state(cache[channels], len(starts))

    def kalman_spec(self, channels):
        if type(self).run is not ImpactFeature.run or type(self).init_state is not ImpactFeature.init_state:
            return None
        from contactlab.observer.engine import REG_TIME
        return {"reg": REG_TIME, "order": 0, "mean": True, "q": 2, "mode": MODE_PLAIN,
                "estimate_noise": False, "noise_prior_count": 8.0, "channels": channels,
                "prior": self.init_state(np.zeros(1, dtype=np.int64), channels)}

    def run(self, state, x, *, t0, starts):
        N, C = x.shape
        U = len(starts)
        psi = np.empty((N, U, C, 2))
        psi[..., 0] = 1.0
        n = (t0 + np.arange(N))[:, None] - np.asarray(starts)[None, :]      # (N, U)
        psi[..., 1] = n[:, :, None]
        return run_kalman(state, psi, x, mode=MODE_PLAIN)
