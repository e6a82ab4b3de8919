"""The log-energy comparison of 7.2.2 (fig 7.8): a normal fitted per class to
the block means of ``y_h`` and the error those normals predict.

:func:`normal_confusion_1d` is exact: the Bayes decision regions of J
one-dimensional normals (weighted by their priors) are bounded by the real
roots of the pairwise quadratics ``log pi_i N(x; mu_i, s_i) = log pi_j N(x;
mu_j, s_j)``; between consecutive roots one class wins throughout, and the
probability of each region under each class is a difference of normal
distribution functions (taken in the tail where it is small, so error rates
like the thesis's 5e-4 -- or far smaller -- keep their relative precision).
"""

from __future__ import annotations

import numpy as np
from scipy.special import ndtr     # the normal cdf (scipy.stats costs 1 s to import)

__all__ = ["normal_confusion_1d", "normal_error_1d", "normal_fit", "normal_params", "classify_1d",
           "normal_confusion_mc"]


def _mass(lo, hi, mu, sd):
    """P(lo < X < hi) for X ~ N(mu, sd^2), accurate in either tail."""
    a, b = (lo - mu) / sd, (hi - mu) / sd
    if a > 0:
        return float(ndtr(-a) - ndtr(-b))
    return float(ndtr(b) - ndtr(a))


def _check(means, stds, priors):
    mu = np.asarray(means, dtype=np.float64).ravel()
    sd = np.asarray(stds, dtype=np.float64).ravel()
    if mu.size < 1 or sd.shape != mu.shape:
        raise ValueError("means and stds must be equal-length, non-empty")
    if not (np.isfinite(mu).all() and np.isfinite(sd).all() and (sd > 0).all()):
        raise ValueError("means must be finite and stds finite and > 0")
    pi = np.full(mu.size, 1.0 / mu.size) if priors is None else \
        np.asarray(priors, dtype=np.float64).ravel()
    if pi.shape != mu.shape or (pi <= 0).any() or not np.isclose(pi.sum(), 1.0):
        raise ValueError("priors must be positive and sum to 1, one per class")
    return mu, sd, pi


def classify_1d(x, means, stds, priors=None) -> np.ndarray:
    """Index of the class maximising ``pi_j N(x; mu_j, s_j)`` for every x."""
    mu, sd, pi = _check(means, stds, priors)
    x = np.asarray(x, dtype=np.float64)
    score = np.log(pi) - np.log(sd) - 0.5 * ((x[..., None] - mu) / sd) ** 2
    return np.argmax(score, axis=-1)


def normal_confusion_1d(means, stds, priors=None) -> np.ndarray:
    """(J, J) ``P(choose j | true class i)`` of the Bayes rule for J 1-D normals.

    ``priors`` default equal (the thesis's forced choice between hypotheses).
    """
    mu, sd, pi = _check(means, stds, priors)
    J = mu.size
    roots = []
    for i in range(J):
        for j in range(i + 1, J):
            a = 0.5 / sd[j] ** 2 - 0.5 / sd[i] ** 2
            b = mu[i] / sd[i] ** 2 - mu[j] / sd[j] ** 2
            c = (0.5 * mu[j] ** 2 / sd[j] ** 2 - 0.5 * mu[i] ** 2 / sd[i] ** 2
                 + np.log(pi[i] / sd[i]) - np.log(pi[j] / sd[j]))
            if abs(a) < 1e-300:
                if b != 0:
                    roots.append(-c / b)
                continue
            disc = b * b - 4 * a * c
            if disc >= 0:
                r = np.sqrt(disc)
                q = -0.5 * (b + np.copysign(r, b))        # stable quadratic roots
                roots.extend([q / a, c / q] if q != 0 else [0.0])
    edges = np.unique(np.asarray(roots, dtype=np.float64))
    edges = np.concatenate([[-np.inf], edges, [np.inf]])
    out = np.zeros((J, J))
    for lo, hi in zip(edges[:-1], edges[1:]):
        if lo == hi:
            continue
        mid = (lo + hi) / 2 if np.isfinite(lo) and np.isfinite(hi) else \
            (hi - 1.0 if np.isfinite(hi) else lo + 1.0 if np.isfinite(lo) else 0.0)
        w = int(classify_1d(mid, mu, sd, pi))
        for i in range(J):
            out[i, w] += _mass(lo, hi, mu[i], sd[i])
    return out


def normal_error_1d(means, stds, priors=None) -> float:
    """Bayes error ``sum_i pi_i sum_{j != i} P(j | i)`` of J 1-D normals."""
    mu, sd, pi = _check(means, stds, priors)
    conf = normal_confusion_1d(mu, sd, pi)
    off = conf.sum(axis=1) - np.diagonal(conf)
    return float(np.sum(pi * off))


def normal_fit(values, labels, classes) -> tuple[np.ndarray, np.ndarray]:
    """Per-class sample mean and standard deviation (ddof=1) of ``values``."""
    values = np.asarray(values, dtype=np.float64)
    labels = np.asarray(labels)
    mu, sd = [], []
    for c in classes:
        v = values[labels == c]
        if v.size < 2:
            raise ValueError(f"class {c!r} has {v.size} block(s); a normal fit needs 2")
        mu.append(v.mean())
        sd.append(v.std(ddof=1))
    return np.asarray(mu), np.asarray(sd)


def normal_params(samples) -> tuple[np.ndarray, np.ndarray]:
    """Mean (d,) and covariance (d, d) (ddof=1) of ``samples`` (n, d) or (n,)."""
    x = np.asarray(samples, dtype=np.float64)
    x = x[:, None] if x.ndim == 1 else x
    if len(x) < 2:
        raise ValueError(f"a normal fit needs at least 2 samples; got {len(x)}")
    return x.mean(axis=0), np.atleast_2d(np.cov(x, rowvar=False, ddof=1))


def normal_confusion_mc(means, covs, *, priors=None, n: int = 100_000, seed: int = 0
                        ) -> np.ndarray:
    """(J, J) confusion of the Bayes rule for J d-dimensional normals, by Monte Carlo
    (``n`` draws per class), e.g. the normal fit to the feature scatter of fig 7.9."""
    mu = np.asarray(means, dtype=np.float64)
    cov = np.asarray(covs, dtype=np.float64)
    J, d = mu.shape
    if cov.shape != (J, d, d):
        raise ValueError(f"covs must be (J, d, d) = {(J, d, d)}; got {cov.shape}")
    pi = np.full(J, 1.0 / J) if priors is None else np.asarray(priors, dtype=np.float64)
    L = np.linalg.cholesky(cov)
    logdet = 2 * np.log(np.diagonal(L, axis1=1, axis2=2)).sum(axis=1)
    rng = np.random.default_rng(seed)
    out = np.zeros((J, J))
    for i in range(J):
        x = mu[i] + rng.standard_normal((n, d)) @ L[i].T
        z = np.linalg.solve(L[None], (x[:, None, :] - mu[None])[..., None])[..., 0]
        score = np.log(pi) - 0.5 * logdet - 0.5 * np.sum(z * z, axis=-1)
        out[i] = np.bincount(np.argmax(score, axis=1), minlength=J) / n
    return out
