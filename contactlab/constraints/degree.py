"""Degree of constraint (8.2).

Two tests of how many of the k directions are constrained:

- the likelihood test: fit the constraint form for every class m = 0..k and
  choose the highest log-likelihood 8.18 (:func:`decide_degree`; built into
  :class:`~contactlab.constraints.CartesianConstraint` with ``degree=None``);
- the eigenvector-alignment test on the stiffness form: the statistic is the
  pair (sum of the singular values of the motion block of P, sum of those of
  the force block) -- the direction cosines between P's span and the motion
  and force coordinate spaces (:func:`alignment_statistic`).  Its mean and
  covariance per class are learnt from examples and a block is given the
  class of highest normal likelihood (:class:`AlignmentDegreeTest`).  This is
  the thesis's "simplified version" that assumes rich data and only looks at
  the eigenvectors of the k smallest eigenvalues; the thesis warns that on
  pure noise it picks a class at random with a very high relative likelihood
  (the index probabilities of 8.68 are left out).  :meth:`AlignmentDegreeTest.
  log_likelihoods` exposes the scores so that the overconfidence can be shown.
"""

from __future__ import annotations

import numpy as np

from contactlab.errors import UsageError

__all__ = ["decide_degree", "alignment_statistic", "AlignmentDegreeTest"]


def decide_degree(log_likelihoods) -> np.ndarray:
    """Index of the highest finite log-likelihood per row of (..., k+1); -1 if none."""
    ll = np.asarray(log_likelihoods, dtype=np.float64)
    finite = np.isfinite(ll)
    best = np.argmax(np.where(finite, ll, -np.inf), axis=-1)
    return np.where(finite.any(axis=-1), best, -1)


def alignment_statistic(P) -> np.ndarray:
    """(..., 2): sums of singular values of the motion (first k rows) and force
    blocks of joint projections P (..., 2k, k)."""
    P = np.asarray(P, dtype=np.float64)
    k = P.shape[-1]
    su = np.linalg.svd(P[..., :k, :], compute_uv=False).sum(axis=-1)
    sl = np.linalg.svd(P[..., k:, :], compute_uv=False).sum(axis=-1)
    return np.stack([su, sl], axis=-1)


class AlignmentDegreeTest:
    """The eigenvector-alignment degree test (8.2, simplified 8.68).

    ``fit(statistics, classes)`` learns a normal model (mean, covariance plus
    ``ridge`` Id) of the statistic per class; ``predict`` picks the class of
    highest likelihood.
    """

    def __init__(self, *, ridge: float = 1e-6):
        self.ridge = float(ridge)

    def fit(self, statistics, classes) -> "AlignmentDegreeTest":
        s = np.asarray(statistics, dtype=np.float64)
        c = np.asarray(classes, dtype=np.int64)
        if s.ndim != 2 or s.shape[0] != c.shape[0]:
            raise UsageError("statistics must be (N, 2) with one class per row")
        self.classes_ = np.unique(c)
        self.means_ = np.stack([s[c == k].mean(axis=0) for k in self.classes_])
        covs = []
        for k in self.classes_:
            sk = s[c == k]
            cov = np.cov(sk.T) if len(sk) > 1 else np.zeros((s.shape[1], s.shape[1]))
            covs.append(cov + self.ridge * np.eye(s.shape[1]))
        self.covs_ = np.stack(covs)
        return self

    def log_likelihoods(self, statistics) -> np.ndarray:
        """(N, classes) normal log-densities of each statistic under each class."""
        s = np.asarray(statistics, dtype=np.float64)
        d = s[:, None, :] - self.means_[None]
        inv = np.linalg.inv(self.covs_)
        maha = np.einsum("nci,cij,ncj->nc", d, inv, d)
        _, logdet = np.linalg.slogdet(self.covs_)
        return -0.5 * (maha + logdet[None] + s.shape[1] * np.log(2 * np.pi))

    def predict(self, statistics) -> np.ndarray:
        return self.classes_[np.argmax(self.log_likelihoods(statistics), axis=1)]
