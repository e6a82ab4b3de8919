"""Direction of constraint (8.3): prior information on the constraint frame.

The alignment penalty (8.69) ``alpha = k - sum_i svd(P_hat^T P_N)_i`` (0 for
the same frame, at most k) with an exponential prior of rate ``a`` gives the
combined criterion (8.70)

    l = -n/2 min_P (log det V + k) + log(a) - a alpha,

``a = 2/3 * 1 / (1 - cos(d))`` for a prior standard deviation ``d`` of the
alignment error (8.3; the thesis prints "2/3(1/1 - cos)", read as
``1/(1 - cos d)``).  The criterion takes the unconstrained best frame and
penalises its misalignment with each nominal frame, as written; hypotheses of
the same degree then differ only through ``alpha``.  Signs of the bases do not
matter: a contact on the top of a plane cannot be told from one on its bottom
(the thesis's stated limitation).
"""

from __future__ import annotations

import math

import numpy as np

from contactlab.constraints.alignment import direction_cosines, joint_projection
from contactlab.constraints.frames import embed
from contactlab.errors import UsageError

__all__ = ["prior_rate", "alignment_penalty", "direction_log_likelihood", "decide_direction"]


def prior_rate(prior_sd_deg: float) -> float:
    """``a = 2/3 * 1/(1 - cos(prior_sd))`` (8.3)."""
    if not 0 < prior_sd_deg <= 180:
        raise UsageError(f"prior_sd_deg must be in (0, 180]; got {prior_sd_deg!r}")
    return 2.0 / 3.0 / (1.0 - math.cos(math.radians(prior_sd_deg)))


def alignment_penalty(P_hat, P_nominal) -> np.ndarray:
    """``alpha = k - sum svd(P_hat^T P_N)`` (8.69) for joint projections (..., 2k, k)."""
    P_hat = np.asarray(P_hat, dtype=np.float64)
    return P_hat.shape[-1] - direction_cosines(P_hat, P_nominal).sum(axis=-1)


def direction_log_likelihood(loglik, P_hat, P_nominal, *, prior_sd_deg: float = 15.0):
    """The combined criterion 8.70: ``loglik + log(a) - a * alpha``."""
    a = prior_rate(prior_sd_deg)
    return np.asarray(loglik) + math.log(a) - a * alignment_penalty(P_hat, P_nominal)


def decide_direction(fits, nominal_normals, *, prior_sd_deg: float = 15.0):
    """Choose among nominal frames for every block of ``fits``.

    ``fits``: :class:`~contactlab.constraints.BlockFits` fitted with
    ``degree=None`` or with every degree the hypotheses need;
    ``nominal_normals``: list of physical unit normals (k, m_h), one per
    hypothesis.  Returns ``(choice (B,), scores (B, H))``.
    """
    if not nominal_normals:
        raise UsageError("decide_direction needs at least one nominal frame")
    B = len(fits)
    scores = np.empty((B, len(nominal_normals)))
    for h, normals in enumerate(nominal_normals):
        N = np.asarray(normals, dtype=np.float64)
        m = N.shape[1]
        Pn = joint_projection(fits.scaling.normals_to_scaled(N))
        P_hat = embed(fits.frames[:, m], m)
        scores[:, h] = direction_log_likelihood(fits.log_likelihoods[:, m], P_hat, Pn,
                                                prior_sd_deg=prior_sd_deg)
    scores = np.where(np.isfinite(scores), scores, -np.inf)
    return np.argmax(scores, axis=1), scores
