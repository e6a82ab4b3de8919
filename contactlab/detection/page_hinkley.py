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
from numba import njit

from contactlab.detection.alarms import Alarms, alarms_from_table, empty_alarms, push_alarm
from contactlab.detection.increments import (
    MEAN_SIDES,
    VARIANCE_SIDES,
    mean_increment,
    variance_increment,
)

ENGINES = ("numba", "numpy")
_NUMPY_BLOCK_ELEMENTS = 1 << 20  # samples x detectors x sides per block of the numpy engine
_NUMPY_BLOCK_ROWS = 1024


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

    Attributes (after the first :meth:`update` or :meth:`run`)
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
        if not np.isfinite(x).all():
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
        x = self._as3d(increments, step=False)
        n, d, k = x.shape
        self._ensure_state(d)
        t0 = self.n_seen_
        if n == 0:
            out = empty_alarms(sides=self.sides, with_change_time=True)
            return out if not trace else Alarms(out.time, out.detector, out.side,
                                                out.change_time, self.sides, np.zeros((0, d, k)))
        if self.engine == "numba":
            tr = np.empty((n, d, k) if trace else (0, 0, 0))
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
        return alarms_from_table(table, sides=self.sides, with_change_time=True,
                                 trace=tr if trace else None)


@njit(cache=True, inline="always")
def cusum_step(df, x):
    """One sample of the Page-Hinkley (CUSUM) recursion 6.18: ``max(0, df + x)``.

    The one compiled form of the recursion: the detector's kernel, the
    observer's detector rows and the ROC Monte Carlo of :mod:`.roc` all call it
    (numba inlines it into their loops); callable from Python too.  A result of
    exactly 0 marks a "last zero" (the change-time estimate of fig 6.4).
    """
    v = df + x
    return v if v > 0.0 else 0.0


@njit(cache=True)
def _cusum_kernel(x, thr, df, last_zero, t0, trace, keep_trace, stat, out, d0, i0
                  ):  # pragma: no cover
    """(6.18) over x (n, D, K) from detector ``d0``, sample ``i0``; updates df and
    last_zero in place and writes alarm rows (time, detector, side, change time)
    into ``out``.

    ``stat`` receives the statistics of the last sample before any reset.  Each
    detector runs over the whole block with its state in registers (one and two
    sides specialised): one add, one compare and one branch per sample.  When
    ``out`` is full the kernel stops before the sample that might need a new row
    and returns ``(rows, d, i)`` to resume from; ``(rows, D, 0)`` when done.  Rows
    come in (detector, time) order; the caller sorts them by time.
    """
    n, n_det, n_side = x.shape
    cap = out.shape[0]
    m = 0
    for d in range(d0, n_det):
        th = thr[d]
        start = i0 if d == d0 else 0
        if n_side == 1:
            s0 = df[d, 0]
            z0 = last_zero[d, 0]
            pre0 = s0
            for i in range(start, n):
                if m == cap:
                    df[d, 0] = s0
                    last_zero[d, 0] = z0
                    return m, d, i
                s0 = cusum_step(s0, x[i, d, 0])
                if s0 == 0.0:
                    z0 = t0 + i
                if keep_trace:
                    trace[i, d, 0] = s0
                pre0 = s0
                if s0 > th:
                    out[m, 0] = t0 + i
                    out[m, 1] = d
                    out[m, 2] = 0
                    out[m, 3] = z0
                    m += 1
                    s0 = 0.0
                    z0 = t0 + i
            df[d, 0] = s0
            last_zero[d, 0] = z0
            stat[d, 0] = pre0
        elif n_side == 2:
            s0 = df[d, 0]
            s1 = df[d, 1]
            z0 = last_zero[d, 0]
            z1 = last_zero[d, 1]
            pre0 = s0
            pre1 = s1
            for i in range(start, n):
                if m == cap:
                    df[d, 0] = s0
                    df[d, 1] = s1
                    last_zero[d, 0] = z0
                    last_zero[d, 1] = z1
                    return m, d, i
                s0 = cusum_step(s0, x[i, d, 0])
                s1 = cusum_step(s1, x[i, d, 1])
                if s0 == 0.0:
                    z0 = t0 + i
                if s1 == 0.0:
                    z1 = t0 + i
                if keep_trace:
                    trace[i, d, 0] = s0
                    trace[i, d, 1] = s1
                pre0 = s0
                pre1 = s1
                if s0 > th or s1 > th:
                    out[m, 0] = t0 + i
                    out[m, 1] = d
                    if s0 > th and not s1 > s0:        # ties go to the first side
                        out[m, 2] = 0
                        out[m, 3] = z0
                    else:
                        out[m, 2] = 1
                        out[m, 3] = z1
                    m += 1
                    s0 = 0.0
                    s1 = 0.0
                    z0 = t0 + i
                    z1 = t0 + i
            df[d, 0] = s0
            df[d, 1] = s1
            last_zero[d, 0] = z0
            last_zero[d, 1] = z1
            stat[d, 0] = pre0
            stat[d, 1] = pre1
        else:
            for i in range(start, n):
                if m == cap:
                    return m, d, i
                t = t0 + i
                best = -1
                best_v = 0.0
                for k in range(n_side):
                    df[d, k] = cusum_step(df[d, k], x[i, d, k])
                    if df[d, k] == 0.0:
                        last_zero[d, k] = t
                    if keep_trace:
                        trace[i, d, k] = df[d, k]
                    if i == n - 1:
                        stat[d, k] = df[d, k]
                    if df[d, k] > th and (best < 0 or df[d, k] > best_v):
                        best = k
                        best_v = df[d, k]
                if best >= 0:
                    out[m, 0] = t
                    out[m, 1] = d
                    out[m, 2] = best
                    out[m, 3] = last_zero[d, best]
                    m += 1
                    for k in range(n_side):
                        df[d, k] = 0.0
                        last_zero[d, k] = t
    return m, n_det, 0


def _cusum_run(x, thr, df, last_zero, t0, trace, keep_trace, stat) -> np.ndarray:
    """:func:`_cusum_kernel` over the whole block, growing the alarm table as needed;
    rows in (time, detector) order."""
    n, n_det, _ = x.shape
    cap = max(64, min(n * n_det, 4096))
    parts = []
    d, i = 0, 0
    while d < n_det:
        out = np.empty((cap, 4), dtype=np.int64)
        m, d, i = _cusum_kernel(x, thr, df, last_zero, t0, trace, keep_trace, stat, out, d, i)
        parts.append(out[:m])
        cap *= 2
    table = parts[0] if len(parts) == 1 else np.concatenate(parts)
    if n_det > 1 and len(table) > 1:
        table = table[np.lexsort((table[:, 1], table[:, 0]))]
    return table


def _cusum_numpy(x, thr, df0, lz0, t0):
    """(6.17) over x (n, D, K): DF = S - running min of S, looping over alarms only.

    Rows of ``S``: row 0 is the last zero before this block (value 0, time
    ``lz0``), row 1 the state at ``t0 - 1`` (value ``df0``), row ``2 + i`` the
    sample ``t0 + i``. After an alarm at row ``a`` the running minimum restarts
    at ``a`` (the reset). Each round handles the next alarm of every detector.
    """
    n, n_det, n_side = x.shape
    rows = n + 2
    s = np.empty((rows, n_det, n_side))
    s[0] = 0.0
    s[1] = df0
    np.cumsum(x, axis=0, out=s[2:])
    s[2:] += df0
    row_idx = np.arange(rows)
    anchor = np.zeros(n_det, dtype=np.int64)
    trace = np.empty((n, n_det, n_side))
    df_end = np.zeros((n_det, n_side))
    lz_end = lz0.copy()
    active = np.arange(n_det)
    alarms = []

    def row_time(r, det, side):  # row index -> sample index
        return np.where(r == 0, lz0[det, side], t0 - 2 + r)

    while active.size:
        sa = s[:, active]
        valid = row_idx[:, None] >= anchor[active][None, :]
        m = np.minimum.accumulate(np.where(valid[:, :, None], sa, np.inf), axis=0)
        dfv = np.where(valid[:, :, None], sa - m, -np.inf)
        zero_row = np.maximum.accumulate(np.where(dfv == 0.0, row_idx[:, None, None], -1), axis=0)
        over = dfv > thr[active][None, :, None]
        eligible = (row_idx[:, None] >= 2) & (row_idx[:, None] > anchor[active][None, :])
        crossing = over.any(axis=2) & eligible
        has = crossing.any(axis=0)
        first = np.argmax(crossing, axis=0)
        cols = np.arange(active.size)
        # trace rows (anchor, stop] of this round, stop = alarm row or the end
        stop = np.where(has, first, rows - 1)
        lo = np.maximum(anchor[active], 1)
        for c in cols:  # one slice copy per detector per round (not per sample)
            trace[lo[c] - 1:stop[c] - 1, active[c]] = dfv[lo[c] + 1:stop[c] + 1, c]
        # alarms
        ca = cols[has]
        if ca.size:
            a = first[ca]
            side = np.argmax(np.where(over[a, ca], dfv[a, ca], -np.inf), axis=1)
            zr = zero_row[a, ca, side]
            det = active[ca]
            alarms.append(np.stack([t0 - 2 + a, det, side, row_time(zr, det, side)], axis=1))
            anchor[det] = a
        # detectors with no further alarm: final state
        cd = cols[~has]
        if cd.size:
            det = active[cd]
            df_end[det] = dfv[rows - 1, cd]
            zr = zero_row[rows - 1, cd]  # (c, K)
            lz_end[det] = row_time(zr, det[:, None], np.arange(n_side)[None, :])
        active = active[has]
    if alarms:
        table = np.concatenate(alarms).astype(np.int64)
        table = table[np.lexsort((table[:, 1], table[:, 0]))]
    else:
        table = np.empty((0, 4), dtype=np.int64)
    return table, df_end, lz_end, trace


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
        return self._ph().run(self.increments(y), trace=trace)


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
