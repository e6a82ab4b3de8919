"""Marginal likelihood of a block under a class model (7.2.2, eqs 7.3-7.5).

For one channel of a block, ``Y = Q S^{1/2} k + nu`` (7.3) with ``k ~ N(m, V)``
(the class prior) and ``nu ~ N(0, V_nu I)`` independent, so ``Y`` is normal with
``E[Y] = Q S^{1/2} m`` (7.4) and ``V[Y] = Q S^{1/2} V (Q S^{1/2})^T + V_nu I``
(7.5) -- an M x M covariance.  We never form it.  Complete Q to an orthonormal
basis ``[Q, Q_perp]``; then

* ``Q^T Y = k~ ~ N(S^{1/2} m, S^{1/2} V S^{1/2} + V_nu I_q)`` (q dimensions),
* ``Q_perp^T Y ~ N(0, V_nu I_{M-q})``, independent, with squared norm the
  residual energy ``e^2``,

and, the change of basis being orthogonal (Jacobian 1),

    log p(Y) = log N(k~; S^{1/2} m, S^{1/2} V S^{1/2} + V_nu I)
               - (M - q)/2 log(2 pi V_nu) - e^2 / (2 V_nu).

Everything comes from the block's RLS factor (:mod:`.features`): a q x q
Cholesky per block, channel and class instead of an M x M one, and no
cancellation (``e^2`` is the factor's own corner, not ``Y^T Y - k~^T k~``).

The same number is the prediction-error decomposition of the prior-initialised
orthogonal Kalman filter whose fixed structure is the block's own (A.40-A.42):
:func:`block_loglik_kalman` computes it that way, and the tests check both
against a dense multivariate normal.  As in 7.2.2, Q and S are the test
block's own (A is the block's regressor matrix, conditioned on).  Channels are
independent, so a class's block log-likelihood is the sum over channels.
"""

from __future__ import annotations

import math

import numpy as np

from contactlab.estimators import ARModel, OrthogonalKalman
from contactlab.temporal.features import BlockFeatures, block_windows
from contactlab.temporal.model import TemporalModel

__all__ = ["block_loglik", "block_loglik_kalman", "loglik_params"]

_LOG_2PI = math.log(2.0 * math.pi)


def _check(features: BlockFeatures, model: TemporalModel) -> None:
    if (features.order, features.mean) != (model.order, model.mean):
        raise ValueError(f"features are AR({features.order}, mean={features.mean}) but model "
                         f"{model.label!r} is AR({model.order}, mean={model.mean})")
    if features.channels != model.channels:
        raise ValueError(f"features have {features.channels} channels but model "
                         f"{model.label!r} has {model.channels}")


def block_loglik(features: BlockFeatures, model: TemporalModel, *,
                 per_channel: bool = False) -> np.ndarray:
    """Log-likelihood (7.4-7.5) of every block under ``model``.

    Returns (K,) summed over channels, or (K, C) with ``per_channel``.
    Includes every constant (a proper density of the M = block - p targets).
    """
    _check(features, model)
    ll = loglik_params(features, model.theta_mean, model.theta_cov, model.noise_var,
                       level_sd=model.level_sd, level_mean=model.level_mean,
                       level_cov=model.level_cov)
    return ll if per_channel else ll.sum(axis=1)


def loglik_params(features: BlockFeatures, theta_mean, theta_cov, noise_var,
                  level_sd=None, level_mean=None, level_cov=None) -> np.ndarray:
    """(K, C) log-likelihood (7.4-7.5) of every block and channel under the prior
    ``theta_mean`` (..., C, q), ``theta_cov`` (..., C, q, q), ``noise_var`` (..., C),
    broadcast against the K blocks (one model, or one per block); with
    ``level_sd`` (C,) > 0 the level is a random effect, with mean ``level_mean``
    (C,) and covariance ``level_cov`` (C, q) with the parameters
    (:func:`contactlab.temporal.level.level_marginal`)."""
    if level_sd is not None and np.any(np.asarray(level_sd) > 0):
        from contactlab.temporal.level import level_marginal
        return level_marginal(features, theta_mean, theta_cov, noise_var, level_sd,
                              level_mean=level_mean, level_cov=level_cov)
    s = features.scale                                   # (K, C, q)
    q = features.n_params
    M = features.rows
    v = np.asarray(noise_var, dtype=np.float64)
    cov = s[..., :, None] * theta_cov * s[..., None, :] + v[..., None, None] * np.eye(q)
    u = features.reflection - s * theta_mean
    chol = np.linalg.cholesky(cov)
    z = np.linalg.solve(chol, u[..., None])[..., 0]
    logdet = 2.0 * np.log(np.diagonal(chol, axis1=-2, axis2=-1)).sum(axis=-1)
    head = -0.5 * (q * _LOG_2PI + logdet + np.sum(z * z, axis=-1))
    tail = -0.5 * ((M - q) * (_LOG_2PI + np.log(v)) + features.residual_energy / v)
    return head + tail


def block_loglik_kalman(y, starts, features: BlockFeatures, model: TemporalModel, *,
                        per_channel: bool = False) -> np.ndarray:
    """The same log-likelihood by the prediction-error decomposition of the
    fixed-structure orthogonal square-root Kalman filter (A.32-A.42), started at
    the class prior, with each block's own training-style structure.

    ``y`` (N, C) the signal, ``starts`` the blocks' first samples (those
    ``features`` were computed from).  Slower than :func:`block_loglik`; it is
    the cross-check that the closed form is 7.4-7.5.
    """
    _check(features, model)
    a = np.asarray(y, dtype=np.float64)
    if a.ndim == 1:
        a = a[:, None]
    K, C, q = features.orthogonal.shape
    block = features.rows + features.order
    win = block_windows(a, starts, block).reshape(block, K * C)
    psi, target = ARModel(order=model.order, mean=model.mean).design(win)
    theta0 = np.broadcast_to(model.theta_mean, (K, C, q)).reshape(K * C, q)
    sqrt_cov = np.broadcast_to(np.linalg.cholesky(model.theta_cov), (K, C, q, q))
    noise = np.broadcast_to(np.sqrt(model.noise_var), (K, C)).reshape(K * C)
    kf = OrthogonalKalman(theta0=np.ascontiguousarray(theta0),
                          theta_sqrt0=np.ascontiguousarray(sqrt_cov.reshape(K * C, q, q)),
                          noise_sqrt=noise[:, None, None].copy(), structure="fixed",
                          structure_sqrt0=features.info_sqrt.reshape(K * C, q, q).copy())
    res = kf.run(np.ascontiguousarray(psi), np.ascontiguousarray(target))
    ll = res.loglik.sum(axis=0).reshape(K, C)
    return ll if per_channel else ll.sum(axis=1)
