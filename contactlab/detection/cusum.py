"""The compiled Page-Hinkley (CUSUM) recursion 6.17-6.18, in one place.

:func:`cusum_step` is the recursion of one sample, ``DF(n) = max(0, DF(n-1) +
xi(n))``; the batch kernel of :class:`~contactlab.detection.PageHinkley`, the
observer's detector rows (6.4) and the ROC Monte Carlo of :mod:`.roc` all call
it, and numba inlines it into their loops.  :func:`_cusum_run` is the batch
form over ``(n, detectors, sides)`` increments with alarms, resets and the
change-time estimates of fig 6.4; :func:`_cusum_numpy` is the same result from
the closed form 6.17 (cumulative sum minus its running minimum) in numpy.
"""

from __future__ import annotations

import numpy as np
from numba import njit

__all__ = ["cusum_step"]


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
def all_finite(x) -> bool:  # pragma: no cover - compiled
    """Whether every value of the 1-D array ``x`` is finite (stops at the first that
    is not; one compiled pass, cheaper than numpy's on the short blocks of a stream)."""
    for i in range(x.shape[0]):
        if not np.isfinite(x[i]):
            return False
    return True


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
    out = np.empty((cap, 4), dtype=np.int64)
    m, d, i = _cusum_kernel(x, thr, df, last_zero, t0, trace, keep_trace, stat, out, 0, 0)
    table = out[:m]
    if d < n_det:                                   # the table filled up: continue
        parts = [table]
        while d < n_det:
            cap *= 2
            out = np.empty((cap, 4), dtype=np.int64)
            m, d, i = _cusum_kernel(x, thr, df, last_zero, t0, trace, keep_trace, stat, out,
                                    d, i)
            parts.append(out[:m])
        table = np.concatenate(parts)
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
