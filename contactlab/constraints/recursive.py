"""Recursive form: the information matrix updated sample by sample.

For a Cartesian contact the constraint frame is the same everywhere on the
manifold (8.1.1.1), so every estimate depends on the data only through the
count n and the joint information I (8.19).  :class:`RecursiveConstraint`
keeps the running sums of the scaled samples and their outer products (in
normalised units, after the friction filter when asked); ``I`` -- centred as
the estimator centres -- and a full fit are available after any sample, and
:meth:`update` can return the information after every sample of a chunk
(cumulative sums: no per-sample Python loop).
"""

from __future__ import annotations

import math

import numpy as np

from contactlab.constraints.cartesian import CartesianConstraint, ConstraintFit, min_samples
from contactlab.constraints.friction import friction_filter
from contactlab.constraints.scaling import reciprocal_scaling
from contactlab.errors import DataError, UsageError

__all__ = ["RecursiveConstraint"]


class RecursiveConstraint:
    """Running joint information for a :class:`CartesianConstraint` estimator.

    With ``friction=True`` and no velocity the filter needs a velocity per
    sample; give ``velocity`` to :meth:`update` (the batch fit's central
    difference of positions is not causal).
    """

    def __init__(self, estimator: CartesianConstraint | None = None, *, k: int = 3):
        self.estimator = estimator or CartesianConstraint()
        est = self.estimator
        motion_sd = est.velocity_sd if est.motion == "velocity" else est.position_sd
        self.scaling = reciprocal_scaling(motion_sd, est.force_sd, k)
        self.k = k
        self.center_motion, self.center_force = est._centering()
        self.reset()

    def reset(self) -> "RecursiveConstraint":
        self.n_ = 0
        self.sum_ = np.zeros(2 * self.k)
        self.sum2_ = np.zeros((2 * self.k, 2 * self.k))
        return self

    def _scaled(self, position, force, velocity) -> np.ndarray:
        k, est = self.k, self.estimator
        pos = np.atleast_2d(np.asarray(position, dtype=np.float64))
        frc = np.atleast_2d(np.asarray(force, dtype=np.float64))
        vel = None if velocity is None else np.atleast_2d(np.asarray(velocity, dtype=np.float64))
        if pos.shape[-1] != k or frc.shape != pos.shape or (vel is not None
                                                             and vel.shape != pos.shape):
            raise UsageError(f"position, force (and velocity) must be (n, {k}) alike")
        if not (np.isfinite(pos).all() and np.isfinite(frc).all()
                and (vel is None or np.isfinite(vel).all())):
            raise DataError("NaN or infinite values", field="position/force/velocity")
        if est.motion == "velocity" and vel is None:
            raise UsageError("motion='velocity' needs velocity measurements")
        if est.friction:
            if vel is None:
                raise UsageError("the recursive friction filter needs velocity measurements")
            frc = friction_filter(frc, vel, min_speed=3.0 * float(np.max(est.velocity_sd)))
        motion = vel if est.motion == "velocity" else pos
        return np.concatenate([motion * self.scaling.beta, frc * self.scaling.alpha], axis=1)

    def _centred(self, n, s, s2) -> np.ndarray:
        """I from counts and sums (broadcast over leading axes)."""
        mu = s / n[..., None]
        c = np.zeros(2 * self.k, dtype=bool)
        c[:self.k], c[self.k:] = self.center_motion, self.center_force
        mc = np.where(c, mu, 0.0)
        M2 = s2 / n[..., None, None]
        return (M2 - mc[..., :, None] * mu[..., None, :] - mu[..., :, None] * mc[..., None, :]
                + mc[..., :, None] * mc[..., None, :])

    def update(self, position, force, velocity=None, *, return_path: bool = False):
        """Absorb samples (n, k) (or one sample (k,)).  With ``return_path`` returns
        the information matrix after each of them, (n, 2k, 2k)."""
        y = self._scaled(position, force, velocity)
        if return_path:
            cs = self.sum_ + np.cumsum(y, axis=0)
            cs2 = self.sum2_ + np.cumsum(y[:, :, None] * y[:, None, :], axis=0)
            counts = self.n_ + np.arange(1, len(y) + 1, dtype=np.float64)
            path = self._centred(counts, cs, cs2)
        self.n_ += len(y)
        self.sum_ = self.sum_ + y.sum(axis=0)
        self.sum2_ = self.sum2_ + y.T @ y
        return path if return_path else None

    @property
    def information_(self) -> np.ndarray:
        """The joint information I (2k, 2k) of every sample so far (normalised units)."""
        if self.n_ == 0:
            return np.full((2 * self.k, 2 * self.k), math.nan)
        return self._centred(np.array(float(self.n_)), self.sum_, self.sum2_)

    def estimate(self) -> ConstraintFit:
        """The estimator's fit of everything absorbed (no per-sample residuals)."""
        if self.n_ < min_samples(self.k):
            raise DataError(f"{self.n_} samples absorbed; need at least "
                            f"{min_samples(self.k)}", field="position")
        return self.estimator.estimate_information(self.information_, self.n_, scaling=self.scaling)
