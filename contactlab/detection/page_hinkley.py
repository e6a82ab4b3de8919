"""The Page-Hinkley (CUSUM) change detector of section 6.3.1, for many detectors at once.

The decision function for a change from H0 to H1 is the largest log-likelihood
ratio over the change time ``r`` (6.15), i.e. the cumulative sum of the
increments ``Xi(t)`` minus its running minimum (6.17), computed recursively as

    DF(n) = max(0, DF(n-1) + Xi(n)),   DF(-1) = 0                      (6.18)

H1 is declared when ``DF(n) > T^2`` (6.16). On an alarm:

- the *change time* is estimated as the last sample at which ``DF`` was zero
  (thesis, fig 6.4); the new regime starts one sample later, which is the
  maximiser ``r`` of (6.15);
- the detector resets: ``DF = 0`` (the observer restarts its estimators after a
  change, section 6.4), so alarms form a renewal process.

Note on (6.15): taken literally, ``max_{r in [0, n]} sum_{t=r}^n Xi(t)`` can be
negative, while (6.17)/(6.18) are never below zero. They agree once ``r = n+1``
(an empty sum, "no change yet") is allowed; we implement (6.17)/(6.18).

A :class:`PageHinkley` holds ``D`` independent detectors (one per column of the
increments) each with ``K`` one-sided statistics (e.g. a test for an increase
and one for a decrease). An alarm fires when any of a detector's ``K``
statistics crosses its threshold; all ``K`` reset together and the alarm names
the side that fired. :meth:`PageHinkley.update` advances one sample;
:meth:`PageHinkley.run` processes a block with no per-sample Python (a numba
kernel, or (6.17) with ``np.cumsum``/``np.minimum.accumulate`` looping only over
alarms) and continues from the current state, so streaming, chunked and batch
use give identical alarms and change-time estimates.

:class:`MeanChangeDetector` and :class:`VarianceChangeDetector` wrap it with the
increments of :mod:`contactlab.detection.increments`.
"""

from __future__ import annotations

import math

import numpy as np

from contactlab.detection.alarms import Alarms, alarms_from_table, empty_alarms
from contactlab.detection.cusum import _cusum_numpy, _cusum_run, all_finite
from contactlab.detection.increments import (
    MEAN_SIDES,
    VARIANCE_SIDES,
    mean_increment,
    variance_increment,
)

ENGINES = ("numba", "numpy")
_NUMPY_BLOCK_ELEMENTS = 1 << 20  # samples x detectors x sides per block of the numpy engine
_NUMPY_BLOCK_ROWS = 1024


_NO_TRACE = np.empty((0, 0, 0))


class PageHinkley:
    """Page-Hinkley stopping rule (6.15)-(6.18) on ``D`` detectors at once.

    Parameters
    ----------
    threshold : ``T^2`` of (6.16), a scalar or one value per detector; a
        detector alarms when its decision function exceeds it.
    sides : names of the ``K`` one-sided statistics, one per entry of the
        increments' trailing axis (default one side, ``("up",)``).
    engine : how :meth:`run` computes: ``"numba"`` (the recursion (6.18) in a
        compiled loop; bit-identical to :meth:`update`) or ``"numpy"`` (the
        cumulative-sum form (6.17), vectorised over blocks of samples, looping
        over alarms only; identical up to rounding). The numpy engine makes one
        pass over a block per alarm, so it is slow when alarms are frequent.

    The attributes are set by the first :meth:`update` or :meth:`run`.

    Attributes
    ----------
    df_ : (D, K) the decision functions after the last sample (0 after an alarm).
    statistic_ : (D, K) the decision functions at the last sample *before* any
        reset, i.e. the values compared with the threshold.
    last_zero_ : (D, K) the last sample index at which each statistic was zero.
    n_seen_ : number of samples processed; the next sample has this index.

    Shapes of the increments: with one side, ``run`` takes ``(n,)`` (one
    detector) or ``(n, D)`` and ``update`` takes a scalar or ``(D,)``; with
    ``K > 1`` sides, ``run`` takes ``(n, K)`` or ``(n, D, K)`` and ``update``
    takes ``(K,)`` or ``(D, K)``.
    """

    def __init__(self, *, threshold, sides: tuple[str, ...] = ("up",), engine: str = "numba"):
        self.threshold = threshold
        self.sides = tuple(sides)
        self.engine = engine

    # -- state ---------------------------------------------------------------------
    def reset(self) -> PageHinkley:
        """Forget all state; the next sample gets index 0."""
        for name in ("df_", "statistic_", "last_zero_", "n_seen_", "threshold_", "_step_shape",
                     "_scalar"):
            self.__dict__.pop(name, None)
        return self

    def _ensure_state(self, n_detectors: int) -> None:
        if self.engine not in ENGINES:
            raise ValueError(f"engine must be one of {ENGINES}; got {self.engine!r}")
        if not self.sides:
            raise ValueError("sides must name at least one one-sided statistic")
        if hasattr(self, "df_"):
            if self.df_.shape[0] != n_detectors:
                raise ValueError(f"increments have {n_detectors} detectors (columns) but this "
                                 f"PageHinkley has {self.df_.shape[0]}; call reset() first")
            return
        thr = np.broadcast_to(np.asarray(self.threshold, dtype=float), (n_detectors,)).copy()
        if np.isnan(thr).any() or (thr < 0).any():
            raise ValueError(f"threshold (T^2) must be >= 0; got {self.threshold!r}")
        k = len(self.sides)
        self.threshold_ = thr
        self.df_ = np.zeros((n_detectors, k))
        self.statistic_ = np.zeros((n_detectors, k))
        self.last_zero_ = np.full((n_detectors, k), -1, dtype=np.int64)
        self.n_seen_ = 0

    def _as3d(self, x, *, step: bool) -> np.ndarray:
        x = np.asarray(x, dtype=float)
        k = len(self.sides)
        if not step and x.ndim == 3 and x.shape[2] == k and x.flags.c_contiguous:
            if not all_finite(x.reshape(-1)):
                raise ValueError("increments must be finite (found NaN or inf)")
            return x                                  # a block in the kernel's layout
        if step:  # one sample: (), (D,), (K,) or (D, K)
            if k == 1:
                if x.ndim > 2 or (x.ndim == 2 and x.shape[1] != 1):
                    raise ValueError(f"update takes a scalar or (D,) increments; got {x.shape}")
                x = x.reshape(-1, 1)
            else:
                if x.ndim == 1:
                    x = x[None, :]
                if x.ndim != 2 or x.shape[1] != k:
                    raise ValueError(f"update takes ({k},) or (D, {k}) increments for sides "
                                     f"{self.sides}; got {x.shape}")
            x = x[None]
        else:  # a block: (n,), (n, D), (n, K) or (n, D, K)
            if k == 1:
                if x.ndim == 1:
                    x = x[:, None, None]
                elif x.ndim == 2:
                    x = x[:, :, None]
                elif x.ndim != 3 or x.shape[2] != 1:
                    raise ValueError(f"run takes (n,) or (n, D) increments; got {x.shape}")
            else:
                if x.ndim == 2:
                    x = x[:, None, :]
                if x.ndim != 3 or x.shape[2] != k:
                    raise ValueError(f"run takes (n, {k}) or (n, D, {k}) increments for sides "
                                     f"{self.sides}; got {x.shape}")
        # the sum is finite when every term is (one pass, no temporary); only then
        # is the elementwise check skipped
        if not (math.isfinite(x.sum()) or np.isfinite(x).all()):
            raise ValueError("increments must be finite (found NaN or inf)")
        return np.ascontiguousarray(x)

    # -- streaming -----------------------------------------------------------------
    def update(self, increments) -> Alarms:
        """Advance every detector by one sample; return the alarms it raised.

        One step of (6.18) across the ``D`` detectors, vectorised with numpy
        (the same arithmetic as :meth:`run`, so the results are identical).
        """
        if self.__dict__.get("_scalar") and np.ndim(increments) == 0:
            return self._update_scalar(float(increments))
        x = np.asarray(increments, dtype=float)
        if x.shape != self.__dict__.get("_step_shape"):
            raw_shape = x.shape
            x = self._as3d(x, step=True)[0]  # validates the shape (and finiteness)
            self._ensure_state(x.shape[0])
            self._step_shape = raw_shape
            self._scalar = self.df_.size == 1
        else:
            x = x.reshape(self.df_.shape)
            if not np.isfinite(x).all():
                raise ValueError("increments must be finite (found NaN or inf)")
        t = self.n_seen_
        self.n_seen_ = t + 1
        v = self.df_ + x
        pos = v > 0.0
        df = np.where(pos, v, 0.0)
        if not pos.all():
            np.putmask(self.last_zero_, ~pos, t)
        self.statistic_ = df.copy()
        self.df_ = df
        over = df > self.threshold_[:, None]
        if not over.any():
            return self._no_alarms()
        det = np.flatnonzero(over.any(axis=1))
        side = np.argmax(np.where(over, df, -np.inf), axis=1)[det]
        change = self.last_zero_[det, side]
        df[det] = 0.0
        self.last_zero_[det] = t
        n = det.size
        return Alarms(np.full(n, t, dtype=np.int64), det.astype(np.int64),
                      side.astype(np.int64), change.astype(np.int64), self.sides)

    def _update_scalar(self, x: float) -> Alarms:
        """:meth:`update` for one detector with one side, in Python floats.

        Same IEEE double arithmetic as the array path, without numpy's
        per-call overhead on 1-element arrays.
        """
        if not math.isfinite(x):
            raise ValueError("increments must be finite (found NaN or inf)")
        t = self.n_seen_
        self.n_seen_ = t + 1
        v = float(self.df_[0, 0]) + x
        if v > 0.0:
            df = v
        else:
            df = 0.0
            self.last_zero_[0, 0] = t
        self.statistic_[0, 0] = df
        if df > self.threshold_[0]:
            change = int(self.last_zero_[0, 0])
            self.df_[0, 0] = 0.0
            self.last_zero_[0, 0] = t
            return Alarms(np.array([t], dtype=np.int64), np.zeros(1, dtype=np.int64),
                          np.zeros(1, dtype=np.int64), np.array([change], dtype=np.int64),
                          self.sides)
        self.df_[0, 0] = df
        return self._no_alarms()

    def _no_alarms(self) -> Alarms:
        if "_empty" not in self.__dict__:
            self._empty = empty_alarms(sides=self.sides, with_change_time=True)
        return self._empty

    # -- batch ---------------------------------------------------------------------
    def run(self, increments, *, trace: bool = False) -> Alarms:
        """Process a block of samples, continuing from the current state.

        Returns the alarms in time order; with ``trace=True`` the returned
        :class:`Alarms` carries the decision function at every sample (before
        any reset: an alarm sample shows the value that crossed), shape
        ``(n, D, K)``.
        """
        return self._run(self._as3d(increments, step=False), trace)

    def _run(self, x: np.ndarray, trace: bool = False) -> Alarms:
        """:meth:`run` on increments already checked: finite, C-contiguous (n, D, K)."""
        n, d, k = x.shape
        if "df_" not in self.__dict__ or self.df_.shape[0] != d:
            self._ensure_state(d)
        t0 = self.n_seen_
        if n == 0:
            out = empty_alarms(sides=self.sides, with_change_time=True)
            return out if not trace else Alarms(out.time, out.detector, out.side,
                                                out.change_time, self.sides, np.zeros((0, d, k)))
        if self.engine == "numba":
            # a stream of blocks: the per-call work is kept to the kernel's (no trace and
            # no statistics buffer allocated, the alarm table reused)
            tr = np.empty((n, d, k)) if trace else _NO_TRACE
            stat = np.empty((d, k))
            table = _cusum_run(x, self.threshold_, self.df_, self.last_zero_, t0, tr, trace,
                               stat)
        else:
            # blocks bound the cost of the alarm rounds (each round is one pass
            # over its block) and the memory of the temporaries
            block = int(np.clip(_NUMPY_BLOCK_ELEMENTS // (d * k), 64, _NUMPY_BLOCK_ROWS))
            tables, traces = [], []
            for i in range(0, n, block):
                table, self.df_, self.last_zero_, tr_i = _cusum_numpy(
                    x[i:i + block], self.threshold_, self.df_, self.last_zero_, t0 + i)
                tables.append(table)
                traces.append(tr_i if trace else tr_i[-1:])
            table = np.concatenate(tables)
            stat = traces[-1][-1].copy()
            tr = np.concatenate(traces) if trace else None
        self.statistic_ = stat
        self.n_seen_ = t0 + n
        if len(table) == 0 and not trace:
            return self._no_alarms()                  # most blocks of a stream: no alarm
        return alarms_from_table(table, sides=self.sides, with_change_time=True,
                                 trace=tr if trace else None)


class MeanChangeDetector:
    """Page-Hinkley test for a change in the mean of a scalar Gaussian signal.

    Increments ``Xi = (dmu / sigma^2)(y - mu0 - dmu/2)`` (the log-likelihood
    ratio of ``N(mu0 + dmu, sigma^2)`` to ``N(mu0, sigma^2)``; ``beta = s^2/2``
    with ``s = dmu/sigma``), decision function (6.18), threshold ``T^2`` (6.16).

    Parameters
    ----------
    mu0, sigma : mean and standard deviation before the change.
    dmu : size of the change to detect (> 0).
    threshold : ``T^2``, scalar or one per detector (column of ``y``).
    two_sided : also test ``mu0 - dmu`` (sides ``("up", "down")``).
    engine : see :class:`PageHinkley`.
    """

    def __init__(self, *, mu0: float = 0.0, dmu: float, sigma: float = 1.0, threshold,
                 two_sided: bool = False, engine: str = "numba"):
        self.mu0 = mu0
        self.dmu = dmu
        self.sigma = sigma
        self.threshold = threshold
        self.two_sided = two_sided
        self.engine = engine

    def increments(self, y) -> np.ndarray:
        """The increments for ``y``: ``y.shape + (K,)``."""
        if not self.dmu > 0:
            raise ValueError(f"dmu must be > 0 (use two_sided for decreases); got {self.dmu!r}")
        up = mean_increment(y, mu0=self.mu0, dmu=self.dmu, sigma=self.sigma)
        if not self.two_sided:
            return up[..., None]                                  # a view, no copy
        return np.stack([up, mean_increment(y, mu0=self.mu0, dmu=-self.dmu, sigma=self.sigma)],
                        axis=-1)

    @property
    def sides(self) -> tuple[str, ...]:
        return MEAN_SIDES if self.two_sided else MEAN_SIDES[:1]

    def _ph(self) -> PageHinkley:
        if not hasattr(self, "detector_"):
            self.detector_ = PageHinkley(threshold=self.threshold, sides=self.sides,
                                         engine=self.engine)
        return self.detector_

    def reset(self) -> MeanChangeDetector:
        self.__dict__.pop("detector_", None)
        return self

    def update(self, y) -> Alarms:
        """One sample: ``y`` scalar or ``(D,)``."""
        return self._ph().update(self.increments(np.asarray(y, dtype=float).reshape(-1)))

    def run(self, y, *, trace: bool = False) -> Alarms:
        """A block: ``y`` of shape ``(n,)`` or ``(n, D)``."""
        y = np.asarray(y, dtype=float)
        if y.ndim == 1:
            y = y[:, None]
        inc = self.increments(y)
        if y.ndim != 2 or not inc.flags.c_contiguous or not all_finite(inc.reshape(-1)):
            return self._ph().run(inc, trace=trace)   # the checks and their messages
        return self._ph()._run(inc, trace)            # a stream of blocks: checked once


class VarianceChangeDetector:
    """Page-Hinkley test for a change in the size of the innovation covariance.

    Feeds the increments (6.14) of ``chi2 = nu^T V^-1 nu`` (6.11) to (6.18).
    ``sides="both"`` runs the test for an increase to ``q V`` and the test for a
    decrease to ``V / q`` together (two one-sided detectors, alarm when either
    fires, the alarm names which); see
    :func:`~contactlab.detection.increments.variance_increment` for the
    decrease increment.

    Parameters
    ----------
    q : change in covariance (> 1), e.g. 2.5 in section 7.2.1.
    dim : size ``m`` of the innovation vector (degrees of freedom of chi2).
    threshold : ``T^2``, scalar or one per detector (column of ``chi2``).
    sides : ``"both"``, ``"increase"`` or ``"decrease"``.
    engine : see :class:`PageHinkley`.
    """

    def __init__(self, *, q: float, dim: int, threshold, sides: str = "both",
                 engine: str = "numba"):
        self.q = q
        self.dim = dim
        self.threshold = threshold
        self.sides = sides
        self.engine = engine

    @property
    def side_names(self) -> tuple[str, ...]:
        if self.sides == "both":
            return VARIANCE_SIDES
        if self.sides in VARIANCE_SIDES:
            return (self.sides,)
        raise ValueError(f"sides must be 'both', 'increase' or 'decrease'; got {self.sides!r}")

    def increments(self, chi2) -> np.ndarray:
        """The increments for ``chi2``: ``chi2.shape + (K,)``."""
        if not self.q > 1:
            raise ValueError(f"q must be > 1 (the decrease side uses 1/q); got {self.q!r}")
        qs = {"increase": self.q, "decrease": 1.0 / self.q}
        return np.stack([variance_increment(chi2, dim=self.dim, q=qs[s])
                         for s in self.side_names], axis=-1)

    def _ph(self) -> PageHinkley:
        if not hasattr(self, "detector_"):
            self.detector_ = PageHinkley(threshold=self.threshold, sides=self.side_names,
                                         engine=self.engine)
        return self.detector_

    def reset(self) -> VarianceChangeDetector:
        self.__dict__.pop("detector_", None)
        return self

    def update(self, chi2) -> Alarms:
        """One sample: ``chi2`` scalar or ``(D,)``."""
        return self._ph().update(self.increments(np.asarray(chi2, dtype=float).reshape(-1)))

    def run(self, chi2, *, trace: bool = False) -> Alarms:
        """A block: ``chi2`` of shape ``(n,)`` or ``(n, D)``."""
        chi2 = np.asarray(chi2, dtype=float)
        if chi2.ndim == 1:
            chi2 = chi2[:, None]
        return self._ph().run(self.increments(chi2), trace=trace)
