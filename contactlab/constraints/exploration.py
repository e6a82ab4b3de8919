"""Exploration diagnostic (9.1.2, 9.3): is there enough information to decide?

"Without exploration the system would not be provided with sufficient data to
make a decision" (9.1.1); "the constraint covariance matrix indicates the
directions in which there is insufficient information" (9.3).  A direction u
of R^k carries information about whether it is free or constrained when the
block moved along it or pushed along it.  In normalised units (measurement
noise variance 1) that is the variance of motion plus the mean square of force
along u, ``u^T (Ixx + Iww) u``, against the noise.  The decision needs every
direction explored: all k eigenvalues of ``Ixx + Iww`` significant.  For a
contact with m constraints this is the thesis's "rank of the allowed motions
plus the allowed forces is always k" (8.1.1).

Significance threshold (our choice): 4, twice the noise level of ``Ixx + Iww``
(unit noise variance in each of motion and force).  The sample eigenvalues of
noise alone scatter about 2 with a standard deviation of about
``2 sqrt(2/n)`` (0.57 at the thesis's 25-sample blocks), so noise alone rarely
reaches 4 for n >= 25; shorter blocks deserve a higher threshold.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["DEFAULT_THRESHOLD", "Exploration", "exploration"]

#: eigenvalue of Ixx + Iww (normalised units) above which a direction counts as explored
DEFAULT_THRESHOLD = 4.0


@dataclass(frozen=True, eq=False)
class Exploration:
    """Per block: ``eigenvalues`` (B, k) of ``Ixx + Iww`` ascending, ``directions``
    (B, k, k) their eigenvectors (columns, normalised units), ``significant``
    (B,) how many exceed ``threshold``, ``explored`` (B,) all k significant."""

    eigenvalues: np.ndarray
    directions: np.ndarray
    significant: np.ndarray
    explored: np.ndarray
    threshold: float

    def unexplored(self, b: int = 0) -> np.ndarray:
        """Directions (k, u) of block ``b`` lacking information (normalised units)."""
        mask = self.eigenvalues[b] <= self.threshold
        return self.directions[b][:, mask]


def exploration(information, *, threshold: float = DEFAULT_THRESHOLD) -> Exploration:
    """Exploration diagnostic of joint information matrices (B, 2k, 2k) or (2k, 2k)."""
    I = np.asarray(information, dtype=np.float64)
    if I.ndim == 2:
        I = I[None]
    k = I.shape[-1] // 2
    lam, vec = np.linalg.eigh(I[:, :k, :k] + I[:, k:, k:])
    sig = (lam > threshold).sum(axis=1)
    return Exploration(lam, vec, sig, sig == k, float(threshold))
