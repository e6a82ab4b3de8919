"""Units normalised by measurement accuracy, preserving reciprocity (8.7-8.9).

Each force component is multiplied by ``alpha_i`` and each motion component
(position or velocity) by ``beta_i``.  Reciprocity (a constraint force does no
work on an allowed motion, 8.2) survives the change of scale if and only if
``alpha_i * beta_i = d`` is the same for every axis ``i`` (8.9).

With one accuracy per quantity (``sigma_x`` for every motion axis, ``sigma_w``
for every force axis) the obvious scales ``1/sigma_x``, ``1/sigma_w`` already
satisfy 8.9.  With per-axis accuracies they generally do not, and the thesis
only says "care must be taken".  We choose the scales closest to
``1/sigma`` in the log sense subject to 8.9: minimise
``sum_i (log alpha_i + log sigma_w,i)^2 + (log beta_i + log sigma_x,i)^2``
subject to ``log alpha_i + log beta_i = D``, whose solution is
``D = -mean_i(log sigma_x,i + log sigma_w,i)``,
``log alpha_i = (D + log sigma_x,i - log sigma_w,i) / 2``,
``log beta_i = D - log alpha_i``.  It reduces to ``1/sigma`` when the
accuracies are uniform per quantity.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from contactlab.errors import UsageError

__all__ = ["Scaling", "reciprocal_scaling"]


@dataclass(frozen=True)
class Scaling:
    """Per-axis scales: ``motion' = beta * motion``, ``force' = alpha * force``.

    ``alpha * beta`` is the same constant ``d`` on every axis (8.9).
    """

    beta: np.ndarray     # (k,) motion scale
    alpha: np.ndarray    # (k,) force scale

    @property
    def d(self) -> float:
        """The conserved product ``alpha_i beta_i`` (8.9)."""
        return float(self.alpha[0] * self.beta[0])

    def normals_to_physical(self, normals: np.ndarray) -> np.ndarray:
        """Normalised-unit normals (k, m) -> physical unit normals (columns orthonormalised).

        A normal multiplies motion in the residual ``n'^T beta x``, so the
        physical normal is ``beta n'``.
        """
        return _orthonormal_columns(self.beta[:, None] * normals)

    def free_to_physical(self, free: np.ndarray) -> np.ndarray:
        """Normalised-unit free directions (k, f) -> physical unit directions: ``alpha t'``."""
        return _orthonormal_columns(self.alpha[:, None] * free)

    def normals_to_scaled(self, normals: np.ndarray) -> np.ndarray:
        """Physical normals -> normalised-unit normals (inverse of :meth:`normals_to_physical`)."""
        return _orthonormal_columns(normals / self.beta[:, None])

    def free_to_scaled(self, free: np.ndarray) -> np.ndarray:
        return _orthonormal_columns(free / self.alpha[:, None])


def _orthonormal_columns(a: np.ndarray) -> np.ndarray:
    """Orthonormal basis of the span of the columns of ``a`` (same column count, QR),
    each column signed so that its largest-magnitude entry is positive."""
    if a.shape[-1] == 0:
        return a.copy()
    q, _ = np.linalg.qr(a)
    return canonical_signs(q)


def canonical_signs(q: np.ndarray) -> np.ndarray:
    """Flip columns of ``q`` (..., k, c) so each column's largest-|.| entry is positive."""
    if q.shape[-1] == 0:
        return q.copy()
    idx = np.argmax(np.abs(q), axis=-2)                     # (..., c)
    big = np.take_along_axis(q, idx[..., None, :], axis=-2)  # (..., 1, c)
    return q * np.where(big < 0, -1.0, 1.0)


def reciprocal_scaling(motion_sd, force_sd, k: int = 3) -> Scaling:
    """The reciprocity-preserving scales for accuracies ``motion_sd``, ``force_sd``.

    Each may be a scalar or a (k,) array of per-axis standard deviations (> 0).
    """
    sx = np.broadcast_to(np.asarray(motion_sd, dtype=np.float64), (k,)).copy()
    sw = np.broadcast_to(np.asarray(force_sd, dtype=np.float64), (k,)).copy()
    for name, s in (("motion accuracy", sx), ("force accuracy", sw)):
        if not (np.all(np.isfinite(s)) and np.all(s > 0)):
            raise UsageError(f"{name} must be finite and > 0; got {s.tolist()}")
    r, s = np.log(sx), np.log(sw)
    big_d = -np.mean(r + s)
    log_alpha = (big_d + r - s) / 2.0
    log_beta = big_d - log_alpha
    return Scaling(beta=np.exp(log_beta), alpha=np.exp(log_alpha))
