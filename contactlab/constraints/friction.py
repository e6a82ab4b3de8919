"""Friction compensation filter (8.29).

``w~_i = (Id - v_i v_i^T / v_i^T v_i) w_i``: the component of each measured
force along that sample's velocity -- the direction of the frictional force
on a sliding contact -- is removed; the rest is kept.

The thesis applies the filter after normalising units.  A frictional force is
parallel to the velocity in *physical* units; after an anisotropic (per-axis)
change of scale it no longer is, so :class:`~contactlab.constraints.CartesianConstraint`
applies the filter in physical units (identical when the scales are uniform).
At (near) zero speed the direction is undefined and the thesis is silent: a
sample whose speed is at most ``min_speed`` passes unchanged (our choice;
the estimators use three times the velocity accuracy).
"""

from __future__ import annotations

import numpy as np

from contactlab.errors import UsageError

__all__ = ["friction_filter"]


def friction_filter(force, velocity, *, min_speed: float = 0.0) -> np.ndarray:
    """Remove from each force sample its component along that sample's velocity (8.29).

    ``force``, ``velocity``: (n, k) (or (..., n, k)) in the same frame.
    Samples with ``|v| <= min_speed`` are returned unchanged.
    """
    w = np.asarray(force, dtype=np.float64)
    v = np.asarray(velocity, dtype=np.float64)
    if w.shape != v.shape:
        raise UsageError(f"force and velocity must have the same shape; got {w.shape} "
                         f"and {v.shape}")
    if not (np.isfinite(min_speed) and min_speed >= 0):
        raise UsageError(f"min_speed must be >= 0; got {min_speed!r}")
    vv = np.einsum("...i,...i->...", v, v)
    moving = vv > min_speed ** 2
    safe = np.where(moving, vv, 1.0)
    along = np.einsum("...i,...i->...", v, w) / safe
    return w - np.where(moving, along, 0.0)[..., None] * v
