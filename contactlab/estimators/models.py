"""Linear predictive measurement models of chapter 7 (regressor builders).

Each model turns a signal ``y`` (N, B) -- time first, one column per channel,
every channel its own independent model -- into the regression of A.4,
``target(n) = psi(n) theta + nu(n)``, batched as ``psi`` (M, B, k) and
``target`` (M, B), ready for :class:`~contactlab.estimators.rls.SquareRootRLS`
or the Kalman filters.  A 1-D ``y`` is one channel (B = 1).

* :class:`ARModel` -- AR(p) without a mean, ``psi(n) = [y(n-1) ... y(n-p)]``,
  or with a mean in the thesis's parameter order ``{mu, a_1, a_2, ...}``,
  ``psi(n) = [1, y(n-1), ..., y(n-p)]`` (7.1).  Rows start at the first sample
  with a full history (n = p), so ``M = N - p`` and ``target = y[p:]``.
* :class:`LinearDecayModel` -- the impact envelope of 7.1 in the log domain,
  ``y(n) = mu + a n + nu(n)``, ``psi(n) = [1, n]``, n counted from ``start``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from contactlab.estimators.rls import SquareRootRLS

__all__ = ["LinearModel", "ARModel", "LinearDecayModel", "LinearFit", "estimate", "estimate_ar"]


def _as_channels(y) -> np.ndarray:
    a = np.asarray(y, dtype=np.float64)
    if a.ndim == 1:
        a = a[:, None]
    if a.ndim != 2:
        raise ValueError(f"y must be (N,) or (N, B) with time first; got shape {a.shape}")
    return a


class LinearModel:
    """Base of the regressor builders: ``design(y) -> (psi, target)``."""

    #: names of the parameters, in the order of the columns of psi
    @property
    def param_names(self) -> tuple[str, ...]:
        raise NotImplementedError

    @property
    def n_params(self) -> int:
        return len(self.param_names)

    #: samples consumed before the first row (the history a row needs)
    @property
    def lag(self) -> int:
        return 0

    def regressors(self, y) -> np.ndarray:
        """(M, B, k) regressor rows psi(n), n = lag .. N-1."""
        raise NotImplementedError

    def targets(self, y) -> np.ndarray:
        """(M, B) measurements the rows predict, ``y[lag:]``."""
        return _as_channels(y)[self.lag:]

    def design(self, y) -> tuple[np.ndarray, np.ndarray]:
        """``(regressors(y), targets(y))``."""
        return self.regressors(y), self.targets(y)


class ARModel(LinearModel):
    """Autoregressive model AR(p), with or without a forcing mean (7.1).

    Parameters
    ----------
    order : p >= 1, the number of AR coefficients.
    mean : include the forcing mean mu as the first parameter (thesis order
        ``{mu, a_1, ..., a_p}``).
    """

    def __init__(self, *, order: int = 2, mean: bool = False):
        if not isinstance(order, (int, np.integer)) or order < 1:
            raise ValueError(f"order must be an integer >= 1; got {order!r}")
        if not isinstance(mean, (bool, np.bool_)):
            raise ValueError(f"mean must be True or False; got {mean!r}")
        self.order = int(order)
        self.mean = bool(mean)

    def __repr__(self) -> str:
        return f"ARModel(order={self.order}, mean={self.mean})"

    @property
    def param_names(self) -> tuple[str, ...]:
        names = tuple(f"a{i}" for i in range(1, self.order + 1))
        return (("mu",) + names) if self.mean else names

    @property
    def n_params(self) -> int:
        return self.order + int(self.mean)

    @property
    def lag(self) -> int:
        return self.order

    def regressors(self, y) -> np.ndarray:
        a = _as_channels(y)
        N, B = a.shape
        p = self.order
        M = max(N - p, 0)
        psi = np.empty((M, B, self.n_params))
        off = 1 if self.mean else 0
        if self.mean:
            psi[:, :, 0] = 1.0
        for i in range(1, p + 1):
            psi[:, :, off + i - 1] = a[p - i:N - i]
        return psi

    def regressor_from_history(self, history) -> np.ndarray:
        """(B, k) the row psi(n) for streaming, from the last p samples.

        ``history`` (p, B) or (p,) holds ``y(n-p) ... y(n-1)`` oldest first.
        """
        h = _as_channels(history)
        if h.shape[0] != self.order:
            raise ValueError(f"history must hold the last {self.order} samples; got {h.shape[0]}")
        lags = h[::-1].T                      # (B, p): y(n-1) ... y(n-p)
        if self.mean:
            return np.concatenate([np.ones((lags.shape[0], 1)), lags], axis=1)
        return np.ascontiguousarray(lags)


class LinearDecayModel(LinearModel):
    """Impact model ``y(n) = mu + a n + nu(n)``, parameters ``{mu, a}`` (7.1).

    Parameters
    ----------
    start : the value of n at the first sample (0: the impact begins there).
    """

    def __init__(self, *, start: int = 0):
        if not isinstance(start, (int, np.integer)):
            raise ValueError(f"start must be an integer; got {start!r}")
        self.start = int(start)

    def __repr__(self) -> str:
        return f"LinearDecayModel(start={self.start})"

    @property
    def param_names(self) -> tuple[str, ...]:
        return ("mu", "a")

    def regressors(self, y) -> np.ndarray:
        a = _as_channels(y)
        N, B = a.shape
        psi = np.empty((N, B, 2))
        psi[:, :, 0] = 1.0
        psi[:, :, 1] = (np.arange(N, dtype=np.float64) + self.start)[:, None]
        return psi


@dataclass(frozen=True)
class LinearFit:
    """Least-squares fit of a :class:`LinearModel` to every channel.

    coef : (B, k) parameters in ``model.param_names`` order (A.13).
    reflection : (B, k) unnormalised reflection coefficients k~ (A.12).
    orthogonal : (B, k) orthogonal parameters ``k~_j / R_jj`` (A.42, eq. 7.3).
    variance : (B,) ML driving-noise variance, residual energy / n.
    loglik : (B,) exact sequence log-likelihood at the MLE (footnote 3).
    n : number of rows used.
    info_sqrt : (B, k, k) R, the lower-triangular information factor.
    """

    model: LinearModel
    coef: np.ndarray
    reflection: np.ndarray
    orthogonal: np.ndarray
    variance: np.ndarray
    loglik: np.ndarray
    n: int
    info_sqrt: np.ndarray


def estimate(model: LinearModel, y) -> LinearFit:
    """Estimate ``model`` on every channel of ``y`` (N, B) with the square-root RLS."""
    psi, target = model.design(y)
    n = psi.shape[0]
    if n < model.n_params:
        raise ValueError(f"{model!r} needs at least {model.n_params + model.lag} samples; "
                         f"got {n + model.lag}")
    rls = SquareRootRLS()
    rls.run(psi, target)
    return LinearFit(model=model, coef=rls.coef(), reflection=rls.reflection_.copy(),
                     orthogonal=rls.orthogonal_coef(), variance=rls.residual_energy_ / n,
                     loglik=rls.sequence_loglik(), n=n, info_sqrt=rls.info_sqrt_.copy())


def estimate_ar(y, *, order: int = 2, mean: bool = False) -> LinearFit:
    """Estimate AR(``order``) (with a mean if ``mean``) on every channel of ``y``."""
    return estimate(ARModel(order=order, mean=mean), y)

