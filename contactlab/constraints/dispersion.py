"""Frame uncertainty beyond the measurement noise: the spread between blocks' estimates.

A constraint frame's standard error (:attr:`ConstraintFit.angle_sd_deg_`, from the
observed information of 8.18) counts the measurement noise only.  A real contact adds
what the rigid constraint form does not model: a compliant surface whose penetration
follows the pressing force, a frame that creeps (a workpiece shifting, a mount
settling).  Pooling more samples then shrinks the standard error while the error does
not shrink, and the reported uncertainty stops covering the error.

The blocks of one contact segment tell how much more there is.  Each block estimated
alone gives a frame with its own noise-only standard error ``s_b``; if the noise were
all, the blocks' frames would scatter about the pooled one as those errors say.  Their
excess scatter is the variance of the frame between blocks, the random-effects
estimate of DerSimonian and Laird (1986) for ``d`` tilt components per frame (2 for a
plane's normal and for an edge's pair, the small rotations of 8.3):

    Q = sum_b w_b a_b^2,      w_b = 1 / s_b^2,      a_b the angle from block b's frame
                                                     to the pooled one
    tau^2 = max(0, (Q - d (K - 1)) / (d (sum w - sum w^2 / sum w)))

(``K`` blocks; ``E[Q] = d (K - 1) + d tau^2 (sum w - sum w^2 / sum w)`` when each
block's frame is the common one plus a tilt of variance ``tau^2`` per component plus
its noise).  The frame at a block then differs from the pooled estimate by the pooled
estimate's own error and that block's departure, so the standard error of the pooled
frame *as an estimate of the block's* is ``sqrt(s^2 + tau^2)`` (the prediction
interval of a random-effects model): what ``contactlab estimate --block`` reports.
A frame that creeps makes the newest block depart from the pooled frame by more than
the spread about their mean says (the pooled frame lags); the newest block's own
departure beyond its noise, ``(a^2 - 2 s^2) / 2`` per component, is then the larger
and is taken instead.
"""

from __future__ import annotations

import numpy as np

__all__ = ["between_block_variance"]


def between_block_variance(angles_deg, sds_deg, *, dof: int = 2) -> float:
    """``tau^2`` (deg^2 per tilt component) of the module notes from the angles (deg)
    between each block's frame and the pooled one and the blocks' standard errors
    (deg); 0 with fewer than 2 usable blocks (finite angle, positive finite sd)."""
    a = np.asarray(angles_deg, dtype=np.float64).ravel()
    s = np.asarray(sds_deg, dtype=np.float64).ravel()
    if a.shape != s.shape:
        raise ValueError(f"angles and standard errors differ in length: {a.size} and {s.size}")
    ok = np.isfinite(a) & np.isfinite(s) & (s > 0)
    a, w = a[ok], 1.0 / s[ok] ** 2
    if a.size < 2:
        return 0.0
    q = float(np.sum(w * a * a))
    c = float(w.sum() - np.sum(w * w) / w.sum())
    if c <= 0:
        return 0.0
    return max(0.0, (q - dof * (a.size - 1)) / (dof * c))
