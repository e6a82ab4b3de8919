"""The block likelihood (7.4-7.5) with the signal level as a random effect.

Why.  In 7.2.2 the driving-noise variance ``V_nu`` of a class is a number:
the likelihood of a block whose vibration is 35 % stronger than the class's
average (another trial, a firmer press) is penalised by about
``M/2 (r - 1 - log r)`` per channel with ``r`` the variance ratio -- 2.5 nats
per channel for ``M = 98`` rows, 20 over eight strains -- as if the level were
known exactly.  When a class's level varies from block to block, that term
swamps the spectral evidence: on the synthetic texture suite with a log-level
spread of 0.5 between trials, blocks of a class that differs from another
*only in frequency* were labelled by their level (15 % to 30 % errors), and a
linear discriminant on log-variance and autocorrelations, which learns the
spread, won (0.80 against 0.75).

What.  Per class and channel the training blocks also give the spread of the
log level: ``d = log(noise_var_block / V_nu)``, whose variance is the level's
own variance plus the sampling variance of a variance estimate from
``M - q`` rows (``2 / (M - q)``); a quarter of the difference (d = 2 log s) is the variance
``tau^2`` of the log *amplitude* ``log s``.  A block ``Y`` of amplitude ``s``
is ``s`` times a block of the class's level, so with ``log s ~ N(0, tau^2)``

    p(Y) = E_s[ p_0(Y / s) s^{-M} ]                                          (1)

where ``p_0`` is 7.4-7.5 and ``s^{-M}`` the Jacobian.  Scaling a block by
``1/s`` scales its regressors, so ``Q`` is unchanged, ``S^{1/2}`` of the lag
regressors and ``Q^T Y`` scale by ``1/s``, the residual energy by ``1/s^2``
(the constant regressor of a model with a mean keeps its scale).  (1) is
computed in ``u = log s`` by the trapezoid rule on a uniform grid over
``+-6 tau`` whose step resolves both the prior and the block's own likelihood
in ``u`` (width about ``1 / sqrt(2 M)``; a 21-node Gauss-Hermite rule on the
prior alone was off by 0.1 nat against adaptive quadrature), per channel
(channels stay independent, as in 7.2.2).  ``tau = 0`` is 7.4-7.5 exactly.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
from scipy.special import logsumexp

__all__ = ["level_sd", "scaled_features", "level_marginal"]

MAX_NODES = 401


def level_sd(features) -> np.ndarray:
    """(C,) standard deviation of the log amplitude over a class's training blocks,
    less the sampling spread of a variance estimate (module notes; 0 if none)."""
    nv = np.asarray(features.noise_var, dtype=np.float64)
    if nv.shape[0] < 3:
        return np.zeros(nv.shape[1])
    d = np.log(nv / nv.mean(axis=0))
    dof = features.rows - features.n_params
    var = np.var(d, axis=0, ddof=1) - 2.0 / dof
    return np.sqrt(np.maximum(var, 0.0)) / 2.0


def scaled_features(features, s):
    """The features of every block divided by ``s`` (broadcast against (K, C))."""
    s = np.asarray(s, dtype=np.float64)
    factor = np.broadcast_to(1.0 / s[..., None], features.scale.shape).copy()
    if features.mean:
        factor[..., 0] = 1.0                        # the constant regressor does not scale
    return replace(features, reflection=features.reflection / s[..., None],
                   scale=features.scale * factor,
                   residual_energy=features.residual_energy / s ** 2)


def level_marginal(loglik, features, tau) -> np.ndarray:
    """(K, C) log of (1): ``loglik(features)`` -> (K, C) is 7.4-7.5 for given features,
    ``tau`` (C,) the log-amplitude spread."""
    tau = np.asarray(tau, dtype=np.float64)
    if not np.any(tau > 0):
        return loglik(features)
    M = features.rows
    top = float(tau.max())
    step = min(top, 1.0 / np.sqrt(2.0 * M)) / 2.0
    n = int(min(np.ceil(12.0 * top / step), MAX_NODES)) | 1          # odd: 0 is a node
    x = np.linspace(-6.0, 6.0, n)                                     # in units of tau
    logw = -0.5 * x ** 2 + np.log(x[1] - x[0]) - 0.5 * np.log(2 * np.pi)
    logw[[0, -1]] += np.log(0.5)                                      # trapezoid ends
    terms = []
    for xi, lw in zip(x, logw):
        log_s = tau * xi                                             # (C,)
        terms.append(loglik(scaled_features(features, np.exp(log_s))) - M * log_s + lw)
    return logsumexp(np.stack(terms), axis=0)
