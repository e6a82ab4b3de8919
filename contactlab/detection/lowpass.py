"""Lowpass filter followed by a threshold: the detector section 6.3.1 compares against.

The first-order lag filter of fig 6.6,

    x(n+1) = a x(n) + (1 - a) y(n+1),

alarms when ``x`` exceeds the threshold (one-sided) or when ``|x|`` does
(``absolute=True``; the alarm names the side, ``"up"`` or ``"down"``). With a
unit-gain input ``y ~ N(mu, sigma^2)`` the stationary variance of ``x`` is
``S = (1 - a)/(1 + a) sigma^2`` (the solution of ``S = a^2 S + (1-a)^2 sigma^2``).
It takes the same computation per sample as Page-Hinkley but gives no estimate
of the change time (fig 6.6); :class:`Alarms` carry ``change_time=None``.

After an alarm the filter restarts from ``x0`` (like the Page-Hinkley reset),
so alarms form a renewal process. :meth:`LowpassThreshold.update` advances one
sample with numpy across ``D`` detectors; :meth:`LowpassThreshold.run` does a
block in a compiled loop with the same arithmetic, so both give identical
alarms.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from contactlab.detection.alarms import Alarms, alarms_from_table, empty_alarms, push_alarm

SIDES_ONE = ("up",)
SIDES_ABS = ("up", "down")


def stationary_variance(a, *, sigma: float = 1.0):
    """``S = (1 - a)/(1 + a) sigma^2``, the variance of ``x`` under white input."""
    a = np.asarray(a, dtype=float)
    return (1.0 - a) / (1.0 + a) * sigma**2


class LowpassThreshold:
    """First-order lag filter + threshold on ``D`` signals at once (fig 6.6).

    Parameters
    ----------
    a : filter constant in (0, 1), scalar or one per detector.
    threshold : alarm level for ``x`` (> 0), scalar or one per detector.
    absolute : alarm on ``|x| > threshold`` instead of ``x > threshold``.
    x0 : filter state before the first sample and after each alarm.

    The attributes are set by the first :meth:`update` or :meth:`run`.

    Attributes
    ----------
    x_ : (D,) filter state after the last sample (``x0`` after an alarm).
    statistic_ : (D,) filter output at the last sample before any reset.
    n_seen_ : number of samples processed.
    """

    def __init__(self, *, a, threshold, absolute: bool = False, x0: float = 0.0):
        self.a = a
        self.threshold = threshold
        self.absolute = absolute
        self.x0 = x0

    @property
    def sides(self) -> tuple[str, ...]:
        return SIDES_ABS if self.absolute else SIDES_ONE

    def reset(self) -> LowpassThreshold:
        for name in ("x_", "statistic_", "n_seen_", "a_", "threshold_"):
            self.__dict__.pop(name, None)
        return self

    def _ensure_state(self, n_detectors: int) -> None:
        if hasattr(self, "x_"):
            if self.x_.shape[0] != n_detectors:
                raise ValueError(f"signal has {n_detectors} detectors (columns) but this "
                                 f"LowpassThreshold has {self.x_.shape[0]}; call reset() first")
            return
        a = np.broadcast_to(np.asarray(self.a, dtype=float), (n_detectors,)).copy()
        if not ((a > 0) & (a < 1)).all():
            raise ValueError(f"a (filter constant) must be in (0, 1); got {self.a!r}")
        thr = np.broadcast_to(np.asarray(self.threshold, dtype=float), (n_detectors,)).copy()
        if not (thr > 0).all():
            raise ValueError(f"threshold must be > 0; got {self.threshold!r}")
        self.a_, self.threshold_ = a, thr
        self.x_ = np.full(n_detectors, float(self.x0))
        self.statistic_ = self.x_.copy()
        self.n_seen_ = 0

    def update(self, y) -> Alarms:
        """Advance every filter by one sample ``y`` (scalar or ``(D,)``)."""
        y = np.asarray(y, dtype=float)
        if y.ndim > 1:
            raise ValueError(f"update takes a scalar or (D,) sample; got {y.shape}")
        y = y.reshape(-1)
        if not np.isfinite(y).all():
            raise ValueError("signal must be finite (found NaN or inf)")
        if "x_" not in self.__dict__ or self.x_.shape[0] != y.size:
            self._ensure_state(y.size)
        t = self.n_seen_
        self.n_seen_ = t + 1
        x = self.a_ * self.x_ + (1.0 - self.a_) * y
        self.statistic_ = x.copy()
        up = x > self.threshold_
        hit = (up | (x < -self.threshold_)) if self.absolute else up
        if not hit.any():
            self.x_ = x
            return self._no_alarms()
        det = np.flatnonzero(hit)
        side = np.where(up[det], 0, 1).astype(np.int64)
        x[det] = self.x0
        self.x_ = x
        return Alarms(np.full(det.size, t, dtype=np.int64), det.astype(np.int64), side, None,
                      self.sides)

    def _no_alarms(self) -> Alarms:
        if "_empty" not in self.__dict__:
            self._empty = empty_alarms(sides=self.sides, with_change_time=False)
        return self._empty

    def run(self, y, *, trace: bool = False) -> Alarms:
        """Filter a block ``y`` of shape ``(n,)`` or ``(n, D)``, continuing the state.

        With ``trace=True`` the alarms carry ``x`` at every sample (before any
        reset), shape ``(n, D, 1)``.
        """
        y = np.asarray(y, dtype=float)
        if y.ndim == 1:
            y = y[:, None]
        if y.ndim != 2:
            raise ValueError(f"run takes a signal of shape (n,) or (n, D); got {y.shape}")
        if not np.isfinite(y).all():
            raise ValueError("signal must be finite (found NaN or inf)")
        y = np.ascontiguousarray(y)
        n, d = y.shape
        self._ensure_state(d)
        t0 = self.n_seen_
        tr = np.empty((n, d) if trace else (0, 0))
        stat = self.statistic_.copy()
        table = _lowpass_kernel(y, self.a_, self.threshold_, self.absolute, float(self.x0),
                                self.x_, t0, tr, trace, stat)
        self.statistic_ = stat
        self.n_seen_ = t0 + n
        return alarms_from_table(table, sides=self.sides, with_change_time=False,
                                 trace=tr[:, :, None] if trace else None)


@njit(cache=True)
def _lowpass_kernel(y, a, thr, absolute, x0, x, t0, trace, keep_trace, stat):  # pragma: no cover
    """The filter over y (n, D) with alarms and restarts; updates x in place."""
    n, n_det = y.shape
    out = np.empty((64, 4), dtype=np.int64)
    m = 0
    for i in range(n):
        t = t0 + i
        for d in range(n_det):
            v = a[d] * x[d] + (1.0 - a[d]) * y[i, d]
            if keep_trace:
                trace[i, d] = v
            if i == n - 1:
                stat[d] = v
            side = -1
            if v > thr[d]:
                side = 0
            elif absolute and v < -thr[d]:
                side = 1
            if side >= 0:
                out = push_alarm(out, m, t, d, side, -2)
                m += 1
                v = x0
            x[d] = v
    return out[:m].copy()
