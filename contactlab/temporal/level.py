"""The block likelihood (7.4-7.5) with the signal level as a random effect that
moves with the spectrum.

Why a random level.  In 7.2.2 the driving-noise variance ``V_nu`` of a class
is a number: the likelihood of a block whose vibration is 35 % stronger than
the class's average (another trial, a firmer press) is penalised by about
``M/2 (r - 1 - log r)`` per channel with ``r`` the variance ratio -- 2.5 nats
per channel for ``M = 98`` rows, 20 over eight strains -- as if the level were
known exactly.  When a class's level varies from block to block, that term
swamps the spectral evidence: on the synthetic texture suite with a log-level
spread of 0.5 between trials, blocks of a class that differs from another
*only in frequency* were labelled by their level.

Why it moves with the spectrum.  What a texture fixes is the *signal's*
variance; its driving-noise variance is that variance times
``1 / sum(h_j^2)`` of the AR filter, a function of the AR parameters.  When a
class's resonance varies from block to block (another stroking speed), its
driving noise varies with it: a resonance 15 % lower needs a weaker drive for
the same level.  A prior in which ``k`` and ``V_nu`` are independent mistakes
that for a change of level, and a class that differs only in level (with the
same drive as a higher-pitched class) is taken for that class.  On the
texture suite with varying frequency that made the block likelihood lose to a
linear discriminant fed the log *signal* variance (0.855 against 0.878,
20 train/test pairs); with the joint prior below it wins (0.891).

What.  Per class and channel the training blocks give the log amplitude of
their drive, ``u = log(noise_var_block / V_nu) / 2``; its mean ``u0``
(``level_mean``), its spread ``tau`` (``level_sd``: the sample variance less
the sampling variance of a variance estimate from ``M - q`` rows,
``1 / (2 (M - q))``) and its covariance with the orthogonal parameters
``c = cov(k, u)`` (``level_cov``).  Treating ``(k, u)`` as jointly normal
(our extension of 7.3; the thesis treats ``k`` alone as normal):

    u ~ N(u0, tau^2),   k | u ~ N(m + c (u - u0) / tau^2,  V - c c^T / tau^2)     (1)

and a block ``Y`` of amplitude ``s = exp(u)`` is ``s`` times a block of the
class's level, so

    p(Y) = E_u[ p_0(Y / s | k ~ (1)) s^{-M} ]                                    (2)

with ``p_0`` 7.4-7.5.  Scaling a block by ``1/s`` scales its regressors, so
``Q`` is unchanged, ``S^{1/2}`` of the lag regressors and ``Q^T Y`` scale by
``1/s``, the residual energy by ``1/s^2`` (the constant regressor of a model
with a mean keeps its scale).  ``c = 0`` and ``u0 = 0`` is the level effect
alone; ``tau = 0`` is 7.4-7.5 exactly.

Computation.  (2) is a one-dimensional integral in ``u`` per block and
channel, by the trapezoid rule on a uniform grid over ``u0 +- 6 tau`` whose
step resolves both the prior and the block's own likelihood in ``u`` (width
about ``1 / sqrt(2 M)``), up to :data:`MAX_NODES` nodes, every node at once:

* without a mean regressor, ``p_0(Y/s) s^{-M}`` is 7.4-7.5 of ``Y`` itself with
  the noise variance ``V_nu s^2``, so the q x q covariance of ``Q^T Y`` is
  ``S^{1/2} V' S^{1/2} + V_nu s^2 I``.  One symmetric eigendecomposition of
  ``S^{1/2} V' S^{1/2} / V_nu = U diag(l) U^T`` per block and channel gives its
  determinant ``V_nu^q prod(l + s^2)`` and inverse at every node by
  elementwise arithmetic;
* with a mean regressor the node axis is a batch axis of the q x q Cholesky
  factorisations (blocks taken in chunks that bound the memory).
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
from scipy.special import logsumexp

__all__ = ["level_model", "level_sd", "conditional_prior", "scaled_features", "level_marginal",
           "nodes"]

MAX_NODES = 401
#: largest number of (node, block, channel, parameter) values held at once
_CHUNK = 1_000_000
_LOG_2PI = math.log(2.0 * math.pi)
#: the conditional covariance of (1) keeps at least this share of the prior's (a
#: sample covariance of k and u can claim a correlation of 1)
_MAX_R2 = 0.98


def _log_amplitude(features) -> tuple[np.ndarray, int]:
    """(K, C) ``u = log(noise_var_block / mean) / 2`` and the rows' degrees of freedom."""
    nv = np.asarray(features.noise_var, dtype=np.float64)
    return 0.5 * np.log(nv / nv.mean(axis=0)), features.rows - features.n_params


def level_sd(features) -> np.ndarray:
    """(C,) standard deviation ``tau`` of the log amplitude over a class's training
    blocks, less the sampling spread of a variance estimate (0 if none)."""
    u, dof = _log_amplitude(features)
    if u.shape[0] < 3:
        return np.zeros(u.shape[1])
    return np.sqrt(np.maximum(np.var(u, axis=0, ddof=1) - 0.5 / dof, 0.0))


def level_model(features) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(level_mean (C,), level_sd (C,), level_cov (C, q))`` of (1) from a class's
    training blocks: the mean and spread of the log amplitude ``u`` and its
    covariance with the orthogonal parameters (zeros where ``tau = 0``)."""
    u, _ = _log_amplitude(features)
    tau = level_sd(features)
    K, C, q = features.orthogonal.shape
    if K < 3:
        return np.zeros(C), tau, np.zeros((C, q))
    du = u - u.mean(axis=0)
    dk = features.orthogonal - features.orthogonal.mean(axis=0)
    cov = np.einsum("kci,kc->ci", dk, du) / (K - 1)
    on = tau > 0
    return np.where(on, u.mean(axis=0), 0.0), tau, np.where(on[:, None], cov, 0.0)


def conditional_prior(theta_mean, theta_cov, tau, level_cov):
    """``(m, slope, V')`` of (1): ``k | u ~ N(m + slope (u - u0), V')``; ``slope`` (C, q)
    is shrunk so that ``V'`` keeps at least ``1 - _MAX_R2`` of the prior variance
    along it."""
    m = np.asarray(theta_mean, dtype=np.float64)
    V = np.asarray(theta_cov, dtype=np.float64)
    tau = np.asarray(tau, dtype=np.float64)
    c = np.zeros(m.shape) if level_cov is None else np.asarray(level_cov, np.float64)
    t2 = np.where(tau > 0, tau ** 2, 1.0)
    c = np.where((tau > 0)[..., None], c, 0.0)
    r2 = np.einsum("...i,...i->...", c, np.linalg.solve(V, c[..., None])[..., 0]) / t2
    c = c * np.sqrt(np.minimum(1.0, _MAX_R2 / np.maximum(r2, 1e-300)))[..., None]
    return m, c / t2[..., None], V - c[..., :, None] * c[..., None, :] / t2[..., None, None]


def scaled_features(features, s):
    """The features of every block divided by ``s`` (broadcast against (K, C))."""
    s = np.asarray(s, dtype=np.float64)
    factor = np.broadcast_to(1.0 / s[..., None], np.broadcast_shapes(
        s.shape + (1,), features.scale.shape)).copy()
    if features.mean:
        factor[..., 0] = 1.0                        # the constant regressor does not scale
    return replace(features, reflection=features.reflection / s[..., None],
                   scale=features.scale * factor,
                   residual_energy=features.residual_energy / s ** 2)


def nodes(tau, rows: int) -> tuple[np.ndarray, np.ndarray]:
    """Trapezoid nodes ``x`` (in units of ``tau``) and log weights of N(0, 1) for the
    largest ``tau``: a step resolving the prior and a block's likelihood in ``u``."""
    top = float(np.max(tau))
    step = min(top, 1.0 / np.sqrt(2.0 * rows)) / 2.0
    n = int(min(np.ceil(12.0 * top / step), MAX_NODES)) | 1           # odd: 0 is a node
    x = np.linspace(-6.0, 6.0, n)
    logw = -0.5 * x ** 2 + np.log(x[1] - x[0]) - 0.5 * _LOG_2PI
    logw[[0, -1]] += np.log(0.5)                                      # trapezoid ends
    return x, logw


def level_marginal(features, theta_mean, theta_cov, noise_var, tau, *, level_mean=None,
                   level_cov=None) -> np.ndarray:
    """(K, C) log of (2) for every block and channel of ``features`` under the class
    prior ``theta_mean`` (C, q), ``theta_cov`` (C, q, q), ``noise_var`` (C,) and the
    level model ``tau`` (C,), ``level_mean`` (C,), ``level_cov`` (C, q) (None: 0)."""
    from contactlab.temporal.likelihood import loglik_params

    tau = np.asarray(tau, dtype=np.float64)
    if not np.any(tau > 0):
        return loglik_params(features, theta_mean, theta_cov, noise_var)
    C = tau.shape[-1]
    u0 = np.zeros(C) if level_mean is None else np.asarray(level_mean, dtype=np.float64)
    m, slope, Vc = conditional_prior(theta_mean, theta_cov, tau, level_cov)
    x, logw = nodes(tau, features.rows)
    du = tau * x[:, None]                                             # (n, C): u - u0
    K, q = features.n_blocks, features.n_params
    # the prior may be one per block (a leave-one-out): every array (K, C, ...)
    m, slope = (np.broadcast_to(a, (K, C, q)) for a in (m, slope))
    Vc = np.broadcast_to(Vc, (K, C, q, q))
    v = np.broadcast_to(np.asarray(noise_var, np.float64), (K, C))
    per = max(1, _CHUNK // max(1, x.size * C * q * (q if features.mean else 1)))
    fn = _nodes_chol if features.mean else _nodes_eig
    out = np.empty((K, C))
    for a in range(0, K, per):
        b = slice(a, a + per)
        ll = fn(features.take(b), m[b], slope[b], Vc[b], v[b], u0, du)
        out[b] = logsumexp(ll + logw[:, None, None], axis=0)
    return out


def _nodes_eig(f, m, slope, Vc, v, u0, du) -> np.ndarray:
    """(n, K, C) 7.4-7.5 of ``Y`` under ``k ~ N(m + slope du, Vc)`` and noise
    ``v exp(2 u)``, plus the prior's Jacobian-free terms; models without a mean."""
    s, M, q = f.scale, f.rows, f.n_params                             # s (K, C, q)
    A = s[..., :, None] * Vc * s[..., None, :] / v[..., None, None]
    lam, U = np.linalg.eigh(A)                                        # (K, C, q), (K, C, q, q)
    rt = np.sqrt(v)[..., None]
    w0 = np.einsum("kcji,kcj->kci", U, (f.reflection - s * m) / rt)
    w1 = np.einsum("kcji,kcj->kci", U, s * slope / rt)
    u = u0 + du                                                       # (n, C)
    s2 = np.exp(2.0 * u)[:, None, :, None]                            # (n, 1, C, 1)
    w = w0[None] - du[:, None, :, None] * w1[None]                    # (n, K, C, q)
    d = lam[None] + s2
    head = -0.5 * (q * (_LOG_2PI + np.log(v)) + np.log(d).sum(-1) + (w * w / d).sum(-1))
    vv = v[None] * np.exp(2.0 * u)[:, None, :]                        # (n, K, C)
    tail = -0.5 * ((M - q) * (_LOG_2PI + np.log(vv)) + f.residual_energy[None] / vv)
    return head + tail


def _nodes_chol(f, m, slope, Vc, v, u0, du) -> np.ndarray:
    """(n, K, C) ``log p_0(Y/s) - M u`` of (2) with the node axis as a batch axis (any
    model, used for those with a mean regressor)."""
    from contactlab.temporal.likelihood import loglik_params

    u = (u0 + du)[:, None, :]                                         # (n, 1, C)
    scaled = scaled_features(f, np.exp(u))
    mean = m + du[:, None, :, None] * slope                           # (n, K, C, q)
    return loglik_params(scaled, mean, Vc, v) - f.rows * u
