"""Square-root estimators of appendix A.2: one estimator per hypothesised model.

Modules (figure 6.1's "estimator" box):

- :mod:`.householder` -- the Householder triangularisation ``[L Z] T = [L' 0]``
  shared by every square-root step (numba kernels).
- :mod:`.rls` -- square-root recursive least squares, A.10-A.17, with the
  exact sequence log-likelihood of footnote 3 (no prior: training,
  segmentation).
- :mod:`.kalman` -- square-root Kalman filter with a prior, A.18-A.39
  (labelling), vector measurements, fixed or on-line noise variance.
- :mod:`.orthogonal` -- the same filter on orthogonal regressors, A.40-A.42,
  whose parameters are the training RLS's normalised reflection coefficients.
- :mod:`.models` -- regressor builders: AR(p) with/without mean, the
  linear-decay impact model; :func:`estimate` and :func:`estimate_ar`.

Conventions: arrays are time-first with a batch axis ``B`` next (channels or
models run together: ``psi`` (N, B, p) / (N, B, m, p)); square roots are
lower-triangular with a non-negative diagonal, ``I = R R^T``.
"""

from contactlab.estimators.kalman import KalmanResult, SquareRootKalman, kalman_step
from contactlab.estimators.models import (ARModel, LinearDecayModel, LinearFit, LinearModel,
                                          estimate, estimate_ar)
from contactlab.estimators.orthogonal import (OrthogonalKalman, from_orthogonal,
                                              orthogonal_prior, to_orthogonal, unit_structure)
from contactlab.estimators.rls import RLSResult, SquareRootRLS, exact_sequence_loglik

__all__ = [
    "SquareRootRLS", "RLSResult", "exact_sequence_loglik",
    "SquareRootKalman", "KalmanResult", "kalman_step",
    "OrthogonalKalman", "unit_structure", "to_orthogonal", "from_orthogonal", "orthogonal_prior",
    "LinearModel", "ARModel", "LinearDecayModel", "LinearFit", "estimate", "estimate_ar",
]
