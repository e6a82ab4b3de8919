"""Square-root Kalman filter on orthogonal regressors (A.2.3, A.40-A.42).

Training (7.2.2) produces orthogonal parameters with the square-root RLS; the
labelling filter then estimates the *same* quantities, because their training
distribution is close to normal where the natural AR coefficients' is not.

Which normalisation makes them the same quantity.  Let ``L`` be the
lower-triangular factor of the information, ``I = L L^T`` (the package's R,
A.11), ``D^{1/2} = diag(L)`` and ``U = L D^{-1/2}`` (unit lower-triangular, so
``I = U D U^T`` is the LDL^T factorisation).  In the thesis's notation of
A.41-A.42 ``R~ = L^T`` and the normalised correlation structure is

    R = D^{-1/2} R~ = U^T          (unit upper-triangular, A.42),

the orthogonal regressors are ``psi~ = psi R^{-1}`` (A.40), and since
``psi theta = psi~ (R theta)`` the filter's state is

    theta~ = R theta = D^{-1/2} L^T theta = D^{-1/2} k~,

i.e. the RLS's unnormalised reflection coefficients divided by the diagonal
of the factor, ``theta~_j = k~_j / L_jj``
(:meth:`~contactlab.estimators.rls.SquareRootRLS.orthogonal_coef`).  This is
the ``k`` of eq. 7.3, ``Y = Q S^{1/2} k``, with ``S^{1/2} = diag(L)``:
``theta~_j`` is the coefficient of y on the j-th Gram-Schmidt-orthogonalised
regressor column.  Unlike k~ (which grows like sqrt(n)) it does not depend on
the number of samples, and R does not either (it is invariant to scaling I),
which is what lets priors learned on training blocks be used on-line.

A.41 as printed updates with the *normalised* ``R(n-1)``; that would discard
the information's scale every sample.  We read it as the information update
A.10 on the un-normalised factor L (``structure_``), with the normalisation
A.42 applied only to form R for A.40.  R(n) includes psi(n) (A.41-A.42 precede
A.40), which is causal because psi(n) is known before y(n).

With ``structure="track"`` R changes with n, so theta~ = R(n) theta drifts
slightly while R converges; with ``structure="fixed"`` R is the training
structure given in ``structure_sqrt0`` and the filter is exactly a Kalman
filter on the reparametrised model.
"""

from __future__ import annotations

import numpy as np

from contactlab.estimators._arrays import as_f64, sqrt_matrix
from contactlab.estimators.kalman import MODE_FIXED, MODE_TRACK, SquareRootKalman

__all__ = ["OrthogonalKalman", "unit_structure", "to_orthogonal", "from_orthogonal",
           "orthogonal_prior"]


def unit_structure(info_sqrt) -> np.ndarray:
    """Normalised correlation structure ``R = D^{-1/2} L^T`` (A.42), unit upper-triangular.

    ``info_sqrt`` is the lower-triangular factor L of the information,
    (p, p) or (B, p, p) (e.g. :attr:`SquareRootRLS.info_sqrt_`).
    """
    L = as_f64(info_sqrt, "info_sqrt")
    d = np.diagonal(L, axis1=-2, axis2=-1)
    if np.any(d <= 0):
        raise ValueError("info_sqrt must have a positive diagonal (full-rank information)")
    return np.swapaxes(L / d[..., None, :], -1, -2)


def to_orthogonal(theta, info_sqrt) -> np.ndarray:
    """Natural parameters -> orthogonal parameters, ``theta~ = R theta``."""
    R = unit_structure(info_sqrt)
    return np.einsum("...ij,...j->...i", R, as_f64(theta, "theta"))


def from_orthogonal(theta_o, info_sqrt) -> np.ndarray:
    """Orthogonal parameters -> natural parameters, ``theta = R^{-1} theta~``."""
    R = unit_structure(info_sqrt)
    t = as_f64(theta_o, "theta_o")
    R, t = np.broadcast_arrays(R, t[..., None])
    return np.linalg.solve(R, t)[..., 0]


def orthogonal_prior(samples, *, ddof: int = 1) -> tuple[np.ndarray, np.ndarray]:
    """Prior (mean, lower-triangular square-root covariance) from training estimates.

    ``samples`` (K, p): orthogonal parameters of K training blocks
    (:meth:`SquareRootRLS.orthogonal_coef`).  Returns ``(mean (p,), cholesky
    of the sample covariance (p, p))`` -- ``theta0`` and ``theta_sqrt0`` of
    :class:`OrthogonalKalman`.
    """
    x = as_f64(samples, "samples")
    if x.ndim != 2 or x.shape[0] <= x.shape[1]:
        raise ValueError(f"samples must be (K, p) with K > p; got {x.shape}")
    cov = np.atleast_2d(np.cov(x, rowvar=False, ddof=ddof))
    return x.mean(axis=0), np.linalg.cholesky(cov)


class OrthogonalKalman(SquareRootKalman):
    """Square-root Kalman filter on orthogonal regressors (A.40-A.42).

    Parameters are those of :class:`SquareRootKalman` (``theta0`` and
    ``theta_sqrt0`` now describe the *orthogonal* parameters, e.g. from
    :func:`orthogonal_prior`) plus:

    structure : ``"track"`` (default) maintains the information factor by
        Householder updates (A.41) and normalises it (A.42) every sample;
        ``"fixed"`` keeps the structure of ``structure_sqrt0``.
    structure_sqrt0 : initial lower-triangular information factor L: a
        scalar delta (``delta * I``, default 1e-6), (p, p) or (B, p, p).  For
        ``"fixed"`` it must be full rank -- typically the training RLS's
        ``info_sqrt_`` (only its normalised shape matters).  For ``"track"`` a
        training factor (scaled to the weight you want it to carry) avoids
        the start-up transient of a nearly empty structure.

    State in addition to the base class: ``structure_`` (B, p, p) L;
    ``unit_structure_`` R (A.42); ``coef_`` natural parameters
    ``R^{-1} theta~``; ``coef_cov_`` their covariance.
    """

    def __init__(self, *, theta0, theta_sqrt0, noise_sqrt, structure: str = "track",
                 structure_sqrt0=1e-6, estimate_noise: bool = False,
                 noise_prior_count: float = 8.0):
        super().__init__(theta0=theta0, theta_sqrt0=theta_sqrt0, noise_sqrt=noise_sqrt,
                         estimate_noise=estimate_noise, noise_prior_count=noise_prior_count)
        self.structure = structure
        self.structure_sqrt0 = structure_sqrt0

    @property
    def _mode(self) -> int:
        if self.structure == "track":
            return MODE_TRACK
        if self.structure == "fixed":
            return MODE_FIXED
        raise ValueError(f"structure must be 'track' or 'fixed'; got {self.structure!r}")

    def _init_state(self, batch: int, m: int, p: int) -> None:
        mode = self._mode
        super()._init_state(batch, m, p)
        L = sqrt_matrix(self.structure_sqrt0, p, batch, "structure_sqrt0")
        d = np.diagonal(L, axis1=1, axis2=2)
        if np.any(d < 0):
            raise ValueError("structure_sqrt0 must have a non-negative diagonal")
        if mode == MODE_FIXED and np.any(d == 0):
            raise ValueError("structure='fixed' needs a full-rank structure_sqrt0")
        self._structure = L

    @property
    def structure_(self) -> np.ndarray:
        return self._structure

    @property
    def unit_structure_(self) -> np.ndarray:
        return unit_structure(self._structure)

    @property
    def coef_(self) -> np.ndarray:
        """(B, p) natural parameters ``R^{-1} theta~`` with the current R."""
        return from_orthogonal(self.theta_, self._structure)

    @property
    def coef_cov_(self) -> np.ndarray:
        """(B, p, p) covariance of :attr:`coef_`, ``R^{-1} V R^{-T}``."""
        R = self.unit_structure_
        G = np.linalg.solve(R, self.theta_sqrt_)
        return G @ np.swapaxes(G, -1, -2)
