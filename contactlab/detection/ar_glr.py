"""Two-model generalized likelihood ratio (GLR) test for changes in AR models.

Why a second test.  The thesis's detector (6.11-6.18) watches the *size* of
the normalised innovations of one adapting estimator.  A change of the AR
coefficients that keeps the signal's level (a resonance moving from 30 to
60 Hz, say) raises the old model's prediction error only until the
estimator -- and the running innovation variance (6.8) -- have absorbed the
new data: on the synthetic suite (:mod:`contactlab.synthetic.piecewise_ar`)
``chi2 / C`` rises to 2-3 for 25-50 conditioned samples after a
coefficient-only change and then falls back to about 1, which at
``T^2 = 200`` accumulates 40-60 of the 200 needed; the change is missed (4 of
21 found) or found late.  The thesis names the alternative (6.2): the GLR
family of Basseville and Benveniste, in which two models are fitted and
compared instead of one model being watched.

The test.  Per channel ``c`` the AR(p) model with an intercept (the model of
7.1),

    y_c(n) = a_1 y_c(n-1) + ... + a_p y_c(n-p) + mu_c + e_c(n),  e_c ~ N(0, s_c^2),

fitted by least squares to rows ``[a, b)`` has the maximised Gaussian
log-likelihood ``-(m/2) (log(2 pi RSS/m) + 1)`` with ``m = b - a`` rows and
residual sum of squares ``RSS``.  The log GLR of "one model on ``[a, b)``"
against "one model on ``[a, t)``, another on ``[t, b)``" is, summed over the
channels (which are independent under both hypotheses),

    D(a, t, b) = sum_c m log(RSS_ab/m) - m1 log(RSS_at/m1) - m2 log(RSS_tb/m2),  (*)

twice the log likelihood ratio, asymptotically chi-square with ``C (p + 2)``
degrees of freedom under no change (p coefficients, the intercept and the
variance per channel).  This is the two-model approach with a sliding
reference window of Appel and v. Brandt (1983), in the form of Basseville
and Nikiforov, *Detection of Abrupt Changes: Theory and Application* (1993),
section 8.3.2 (GLR for a change in the parameters of an AR model, both models
estimated), and the offline likelihood-ratio segmentation of section 8.6;
the thesis cites the same body of work ([Basseville, 1988], [Basseville and
Benveniste, 1986], [Willsky and Jones, 1976]).  We use (*) per channel and
pooled, as the thesis pools its chi-square over channels (6.11).

Algorithm (:func:`glr_segment`; offline, linear in the data):

1. prefix sums of ``z z^T`` with ``z = [y(n-1), ..., y(n-p), 1, y(n)]`` per
   channel, so that any segment's RSS costs one (p+1) x (p+1) solve
   (:class:`ARPrefix`).  Memory: the window statistic is computed one
   channel at a time (that channel's prefix sums, O(N p^2)); afterwards only
   every 16th prefix is kept, and a segment's RSS re-adds at most 15 rows
   from the nearest one -- in the same order, so every number is the same as
   with all prefixes stored;
2. the window statistic ``D(t) = D(t - w, t, t + w)`` at every row ``t``
   (windows shortened at the ends, never below ``w/2``), vectorised over rows
   and channels, divided by its degrees of freedom so that the threshold is
   in units of "times the mean under no change" whatever the number of
   channels and the order;
3. change candidates: local maxima of ``D`` above the threshold at least
   ``w`` apart (:func:`scipy.signal.find_peaks`);
4. refinement: each candidate moves to the split that maximises (*) between
   its neighbours (``[previous, next)``), searched within ``w/2`` of it --
   the maximum-likelihood change time given one change there (8.6);
5. pruning: a boundary whose refined (*) between its neighbours, per degree
   of freedom, falls below the threshold is dropped, and its neighbours are
   refined again.

:func:`glr_window_statistic` and :func:`segment_glr_statistic` expose the
pieces; the oracle tests compare them with ``numpy.linalg.lstsq`` fits of the
explicit windows.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from contactlab import defaults as D
from contactlab.errors import UsageError

__all__ = ["ARPrefix", "glr_window_statistic", "segment_glr_statistic", "glr_segment",
           "glr_sweep", "GLR_DEFAULTS", "CHECKPOINT_ROWS"]

#: defaults of :func:`glr_segment` (:mod:`contactlab.defaults`)
GLR_DEFAULTS = dict(order=D.GLR_ORDER, window_s=D.GLR_WINDOW_S, threshold=D.GLR_THRESHOLD)


#: rows between the prefix sums :class:`ARPrefix` keeps (1: keep them all)
CHECKPOINT_ROWS = 16
#: segments per batch of :meth:`ARPrefix.rss` (bounds the prefix rows held at once)
_QUERY_BATCH = 4096
#: rows per block of :meth:`ARPrefix.logliks`
_BLOCK_ROWS = 4096


class ARPrefix:
    """Prefix sums of per-channel AR(p) regression moments, for O(1) segment fits.

    ``y`` is (N, C); row ``r`` stands for sample ``r + p`` (the first ``p``
    samples are history only).  ``rows`` = N - p.  Every ``checkpoint_rows``-th
    prefix sum is kept (16 by default: 1/16 of the memory of all of them; 1
    keeps all, for callers that query single segments many times); a query
    adds the rows after the nearest kept one in the original order, so results
    do not depend on ``checkpoint_rows``.
    """

    def __init__(self, y, *, order: int = 2, checkpoint_rows: int = CHECKPOINT_ROWS):
        a = np.asarray(y, dtype=np.float64)
        if a.ndim == 1:
            a = a[:, None]
        p = int(order)
        if p < 0:
            raise UsageError(f"order must be >= 0; got {order!r}")
        if not isinstance(checkpoint_rows, (int, np.integer)) or checkpoint_rows < 1:
            raise UsageError(f"checkpoint_rows must be an integer >= 1; got {checkpoint_rows!r}")
        n, c = a.shape
        if n <= p:
            raise UsageError(f"signal of {n} samples is too short for AR({p})")
        # the intercept absorbs the mean; better conditioning
        self._signal = np.ascontiguousarray(a - a.mean(axis=0))
        self.order = p
        self.rows = n - p
        self.channels = c
        self.dof = c * (p + 2)
        self.step = int(checkpoint_rows)
        self._checkpoints = None             # (rows // step + 1, C, p + 2, p + 2), on demand

    def _kept(self) -> np.ndarray:
        if self._checkpoints is None:
            self._checkpoints = _checkpoint_kernel(self._signal, self.order, self.step)
        return self._checkpoints

    def rss(self, start, end) -> np.ndarray:
        """Least-squares residual sums of rows ``[start, end)``, per channel: shape
        ``broadcast(start, end).shape + (C,)``."""
        start, end = np.broadcast_arrays(np.asarray(start, dtype=np.int64),
                                         np.asarray(end, dtype=np.int64))
        out = np.empty(start.shape + (self.channels,))
        flat_s, flat_e = start.reshape(-1), end.reshape(-1)
        flat_out = out.reshape(-1, self.channels)
        for i in range(0, flat_s.size, _QUERY_BATCH):
            flat_out[i:i + _QUERY_BATCH] = self._rss_sets(
                [(flat_s[i:i + _QUERY_BATCH], flat_e[i:i + _QUERY_BATCH])])[0]
        return out

    def _rss_sets(self, segments: list[tuple[np.ndarray, np.ndarray]]) -> list[np.ndarray]:
        """RSS (Q, C) of each set of segments (1-D int64 ``start``, ``end``), from the
        prefix sums at the rows they name, built once for all sets."""
        rows = np.unique(np.concatenate([a for pair in segments for a in pair]))
        if rows.size and (rows[0] < 0 or rows[-1] > self.rows):
            raise UsageError(f"segment rows must lie in [0, {self.rows}]")
        sums = _prefix_rows_kernel(self._signal, self.order, self._kept(), self.step, rows)
        out = []
        for s, e in segments:
            rss = np.empty((s.size, self.channels))
            _rss_kernel(sums, np.searchsorted(rows, s), np.searchsorted(rows, e), rss)
            out.append(rss)
        return out

    def loglik(self, start, end) -> np.ndarray:
        """Maximised log-likelihood of rows ``[start, end)`` summed over channels,
        without the constant ``-(m/2)(log 2 pi + 1)`` (it cancels in (*))."""
        start, end = np.broadcast_arrays(np.asarray(start), np.asarray(end))
        return _loglik(start, end, self.rss(start, end))

    def logliks(self, segments: list[tuple[np.ndarray, np.ndarray]]) -> list[np.ndarray]:
        """:meth:`loglik` of several sets of segments in one pass over the rows.

        Each set is a pair of 1-D ``start``, ``end`` arrays (``start``
        non-decreasing for signals of :data:`_BLOCK_ROWS` rows or more).  The rows
        are swept once in blocks of :data:`_BLOCK_ROWS` (plus the longest
        segment): memory for one block's prefix sums, not the signal's; the kept
        prefix sums are filled on the way (a shorter signal keeps all of its own).
        """
        segs = [(np.asarray(s, dtype=np.int64), np.asarray(e, dtype=np.int64))
                for s, e in segments]
        k = self.order + 2
        if any(s.size and (s.min() < 0 or e.max() > self.rows or np.any(e < s))
               for s, e in segs):
            raise UsageError(f"segments must lie in [0, {self.rows}]")
        rss = [np.empty((s.size, self.channels)) for s, _ in segs]
        if self.rows < _BLOCK_ROWS:        # a short signal: every prefix sum, one block
            sums = _prefix_span_kernel(self._signal, self.order,
                                       np.zeros((self.channels, k, k)), 0, self.rows,
                                       np.empty((0, self.channels, k, k)), 1, False)
            for (s, e), out in zip(segs, rss):
                _rss_kernel(sums, s, e, out)
            if self._checkpoints is None:
                self._checkpoints, self.step = sums, 1
            return [_loglik(s, e, r) for (s, e), r in zip(segs, rss)]
        if any(np.any(np.diff(s) < 0) for s, _ in segs):
            raise UsageError("segments must come with sorted starts")
        longest = max((int(np.max(e - s)) for s, e in segs if s.size), default=0)
        fill = self._checkpoints is None
        kept = np.zeros((self.rows // self.step + 1, self.channels, k, k)) if fill \
            else self._checkpoints
        acc = kept[0].copy()                              # the prefix sum at row 0
        for r0 in range(0, self.rows + 1, _BLOCK_ROWS):
            r1 = min(r0 + _BLOCK_ROWS + longest, self.rows)
            sums = _prefix_span_kernel(self._signal, self.order, acc, r0, r1, kept, self.step,
                                       fill)
            for (s, e), out in zip(segs, rss):
                lo, hi = np.searchsorted(s, [r0, r0 + _BLOCK_ROWS])
                if hi > lo:
                    _rss_kernel(sums, s[lo:hi] - r0, e[lo:hi] - r0, out[lo:hi])
            if r0 + _BLOCK_ROWS <= self.rows:
                acc = sums[_BLOCK_ROWS].copy()
        self._checkpoints = kept
        return [_loglik(s, e, r) for (s, e), r in zip(segs, rss)]

    def glr(self, start, split, end) -> np.ndarray:
        """(*) of the module notes: twice the log GLR of a change at ``split`` in
        ``[start, end)``, summed over channels."""
        return 2.0 * (self.loglik(start, split) + self.loglik(split, end)
                      - self.loglik(start, end))


def _loglik(start, end, rss) -> np.ndarray:
    """``-(m/2) sum_c log(RSS_c / m)``; overwrites ``rss`` (no temporaries of its size)."""
    m = (end - start).astype(np.float64)
    np.divide(rss, m[..., None], out=rss)
    return -0.5 * m * np.sum(np.log(rss, out=rss), axis=-1)


@njit(cache=True, inline="always")
def _add_row(a, p, r, sums, src, dst, z):  # pragma: no cover - compiled
    """``sums[dst] = sums[src] + z(r) z(r)^T`` per channel, ``z(r) = [a(r+p-1) .. a(r),
    1, a(r+p)]`` (``dst`` may be ``src``)."""
    k = p + 2
    for ch in range(a.shape[1]):
        for i in range(p):
            z[i] = a[r + p - 1 - i, ch]
        z[p] = 1.0
        z[p + 1] = a[r + p, ch]
        for i in range(k):
            for j in range(k):
                sums[dst, ch, i, j] = sums[src, ch, i, j] + z[i] * z[j]


@njit(cache=True, nogil=True)
def _checkpoint_kernel(a, p, step):
    """Every ``step``-th prefix sum over rows of ``z z^T``, ``z = [a(n-1) .. a(n-p), 1,
    a(n)]`` per channel: ``prefix[r + 1] = prefix[r] + z(r) z(r)^T`` in row order (every
    kernel here adds in this order, so the sums agree to the last bit)."""
    n, c = a.shape
    k = p + 2
    rows = n - p
    out = np.zeros((rows // step + 1, c, k, k))
    acc = np.zeros((1, c, k, k))
    z = np.empty(k)
    for r in range(rows):
        if r % step == 0:
            out[r // step] = acc[0]
        _add_row(a, p, r, acc, 0, 0, z)
    if rows % step == 0:
        out[rows // step] = acc[0]
    return out


@njit(cache=True, nogil=True)
def _prefix_span_kernel(a, p, acc0, r0, r1, kept, step, fill):
    """The prefix sums at rows ``r0 .. r1`` from ``acc0``, the one at ``r0``, by the
    additions of :func:`_checkpoint_kernel`; with ``fill`` every ``step``-th goes to ``kept``."""
    n, c = a.shape
    k = p + 2
    out = np.empty((r1 - r0 + 1, c, k, k))
    out[0] = acc0
    z = np.empty(k)
    for r in range(r0, r1):
        if fill and r % step == 0:
            kept[r // step] = out[r - r0]
        _add_row(a, p, r, out, r - r0, r + 1 - r0, z)
    if fill and r1 % step == 0:
        kept[r1 // step] = out[r1 - r0]
    return out


@njit(cache=True, nogil=True)
def _prefix_rows_kernel(a, p, kept, step, rows):
    """The prefix sums at the sorted rows ``rows``, each from the nearest kept one
    (or the previous row asked for) by the additions of :func:`_checkpoint_kernel`."""
    n, c = a.shape
    k = p + 2
    out = np.empty((rows.shape[0], c, k, k))
    acc = np.zeros((1, c, k, k))
    z = np.empty(k)
    cur = -1
    for q in range(rows.shape[0]):
        target = rows[q]
        base = (target // step) * step
        if cur < base or cur > target:
            acc[0] = kept[target // step]
            cur = base
        while cur < target:
            _add_row(a, p, cur, acc, 0, 0, z)
            cur += 1
        out[q] = acc[0]
    return out


@njit(cache=True, fastmath=True, nogil=True)
def _rss_kernel(prefix, starts, ends, out):
    """RSS of every (segment, channel): the Schur complement of the regressors' Gram
    block in ``M = prefix[end] - prefix[start]`` by Gaussian elimination (the last
    pivot); pivots below ``1e-12`` of the Gram trace count as zero (flat windows)."""
    k1 = prefix.shape[2]
    if k1 == 4:                        # AR(2), the default: the same steps on scalars
        _rss_kernel_ar2(prefix, starts, ends, out)
        return
    m = np.empty((k1, k1))
    for i in range(starts.shape[0]):
        hi, lo = prefix[ends[i]], prefix[starts[i]]
        for c in range(prefix.shape[1]):
            trace = 0.0
            for r in range(k1):
                for s in range(r, k1):             # symmetric: the upper triangle suffices
                    m[r, s] = hi[c, r, s] - lo[c, r, s]
                if r < k1 - 1:
                    trace += m[r, r]
            tiny = 1e-12 * trace
            for j in range(k1 - 1):
                piv = m[j, j]
                if piv <= tiny:
                    continue
                for r in range(j + 1, k1):
                    f = m[j, r] / piv
                    for s in range(r, k1):
                        m[r, s] -= f * m[j, s]
            yy = prefix[ends[i], c, k1 - 1, k1 - 1] - prefix[starts[i], c, k1 - 1, k1 - 1]
            out[i, c] = max(m[k1 - 1, k1 - 1], 1e-12 * max(yy, 1e-300))


@njit(cache=True, fastmath=True, nogil=True)
def _rss_kernel_ar2(prefix, starts, ends, out):  # pragma: no cover - compiled
    """:func:`_rss_kernel` for 4 x 4 moments (AR(2) with an intercept), the elimination
    written out on scalars in the same order, so the moments stay in registers."""
    for i in range(starts.shape[0]):
        e, b = ends[i], starts[i]
        for c in range(prefix.shape[1]):
            m00 = prefix[e, c, 0, 0] - prefix[b, c, 0, 0]
            m01 = prefix[e, c, 0, 1] - prefix[b, c, 0, 1]
            m02 = prefix[e, c, 0, 2] - prefix[b, c, 0, 2]
            m03 = prefix[e, c, 0, 3] - prefix[b, c, 0, 3]
            m11 = prefix[e, c, 1, 1] - prefix[b, c, 1, 1]
            m12 = prefix[e, c, 1, 2] - prefix[b, c, 1, 2]
            m13 = prefix[e, c, 1, 3] - prefix[b, c, 1, 3]
            m22 = prefix[e, c, 2, 2] - prefix[b, c, 2, 2]
            m23 = prefix[e, c, 2, 3] - prefix[b, c, 2, 3]
            m33 = prefix[e, c, 3, 3] - prefix[b, c, 3, 3]
            yy = m33
            tiny = 1e-12 * (m00 + m11 + m22)
            if m00 > tiny:
                f = m01 / m00
                m11 -= f * m01
                m12 -= f * m02
                m13 -= f * m03
                f = m02 / m00
                m22 -= f * m02
                m23 -= f * m03
                f = m03 / m00
                m33 -= f * m03
            if m11 > tiny:
                f = m12 / m11
                m22 -= f * m12
                m23 -= f * m13
                f = m13 / m11
                m33 -= f * m13
            if m22 > tiny:
                f = m23 / m22
                m33 -= f * m23
            out[i, c] = max(m33, 1e-12 * max(yy, 1e-300))


def _min_rows(order: int) -> int:
    return 2 * (order + 2)


def glr_window_statistic(prefix: ARPrefix, window: int) -> np.ndarray:
    """``D(t - w, t, t + w) / dof`` at every row ``t`` (NaN where a side would have
    fewer than ``max(w // 2, 2 (p + 2))`` rows); windows are cut at the ends."""
    r = prefix.rows
    w = int(window)
    half = max(w // 2, _min_rows(prefix.order))
    out = np.full(r + 1, np.nan)
    t = np.arange(half, r - half + 1)
    if t.size == 0:
        return out
    inner = (t >= w) & (t <= r - w)
    te = t[~inner]                                  # windows cut at the ends
    lo, hi = np.maximum(te - w, 0), np.minimum(te + w, r)
    segments = [(lo, te), (te, hi), (lo, hi)]
    if inner.any():
        # interior windows share their halves: the left half at t is the right one at t - w
        segments += [(np.arange(0, r - w + 1), np.arange(w, r + 1)),           # [s, s + w)
                     (np.arange(0, r - 2 * w + 1), np.arange(2 * w, r + 1))]
    ll = prefix.logliks(segments)
    if inner.any():
        one, two = ll[3], ll[4]
        ti = t[inner]
        out[ti] = 2.0 * (one[ti - w] + one[ti] - two[ti - w]) / prefix.dof
    if te.size:
        out[te] = 2.0 * (ll[0] + ll[1] - ll[2]) / prefix.dof
    return out


def segment_glr_statistic(prefix: ARPrefix, start: int, end: int, lo: int, hi: int):
    """(*) per degree of freedom for every split ``t`` in ``[lo, hi)`` of ``[start, end)``."""
    t = np.arange(lo, hi)
    first, whole = np.full(t.shape, start), np.array([start], dtype=np.int64)
    last = np.full(t.shape, end)
    left, right, both = prefix._rss_sets([(first, t), (t, last),
                                          (whole, np.array([end], dtype=np.int64))])
    both = np.broadcast_to(both, left.shape).copy()          # one segment, the same RSS
    glr = 2.0 * (_loglik(first, t, left) + _loglik(t, last, right)
                 - _loglik(first, last, both))
    return t, glr / prefix.dof


def _refine(prefix: ARPrefix, bounds: list[int], window: int,
            seen: dict | None = None) -> tuple[list[int], list[float]]:
    """Move each boundary to the best split between its neighbours (within w/2).

    ``seen`` remembers each search ``(prev, next, lo, hi) -> (split, score)`` across
    calls: a boundary whose neighbours did not move is not searched again."""
    seen = {} if seen is None else seen
    r = prefix.rows
    min_rows = _min_rows(prefix.order)
    out = list(bounds)
    scores = []
    for k in range(len(out)):
        prev = out[k - 1] if k > 0 else 0
        nxt = out[k + 1] if k + 1 < len(out) else r
        lo = max(prev + min_rows, out[k] - window // 2)
        hi = min(nxt - min_rows, out[k] + window // 2) + 1
        if hi <= lo:
            scores.append(-math.inf)
            continue
        key = (prev, nxt, lo, hi)
        if key not in seen:
            t, d = segment_glr_statistic(prefix, prev, nxt, lo, hi)
            j = int(np.argmax(d))
            seen[key] = (int(t[j]), float(d[j]))
        out[k] = seen[key][0]
        scores.append(seen[key][1])
    return out, scores


def glr_segment(y, *, fs: float, order: int = GLR_DEFAULTS["order"],
                window_s: float = GLR_DEFAULTS["window_s"],
                threshold: float = GLR_DEFAULTS["threshold"], refine: bool = True) -> dict:
    """Offline two-model GLR segmentation of ``y`` (N,) or (N, C) sampled at ``fs``.

    Returns ``dict(boundaries, statistic, score, sides, window, dof)``: boundaries as
    sample indices of the first sample of each new segment (ruptures'
    convention), the window statistic per sample (NaN where undefined; per
    degree of freedom), each boundary's refined (*) per degree of freedom, the
    window in samples and the degrees of freedom.  Constant channels are
    left out by the caller.
    """
    return glr_sweep(y, [threshold], fs=fs, order=order, window_s=window_s,
                     refine=refine)[float(threshold)]


def glr_sweep(y, thresholds, *, fs: float, order: int = GLR_DEFAULTS["order"],
              window_s: float = GLR_DEFAULTS["window_s"], refine: bool = True) -> dict:
    """:func:`glr_segment` at each of ``thresholds``: ``{threshold: result}``.

    The prefix sums and the window statistic do not depend on the threshold:
    they are computed once, and only the peaks, refinement and pruning run
    per threshold (a sweep of T thresholds costs one segmentation plus T
    cheap passes).  Each result is the one :func:`glr_segment` gives.
    """
    if not (isinstance(window_s, (int, float, np.number)) and window_s > 0):
        raise UsageError(f"window must be > 0 s; got {window_s!r}")
    levels = [float(t) if isinstance(t, (int, float, np.number)) else t for t in thresholds]
    for t in levels:
        if not (isinstance(t, float) and math.isfinite(t) and t > 0):
            raise UsageError(f"threshold must be a number > 0; got {t!r}")
    prefix = ARPrefix(y, order=order)
    p = prefix.order
    window = max(int(round(window_s * fs)), 2 * _min_rows(p))
    stat = glr_window_statistic(prefix, window)
    statistic = np.full(prefix.rows + p, np.nan)
    statistic[p:] = stat[:prefix.rows]
    finite = np.where(np.isfinite(stat), stat, -np.inf)
    out = {}
    seen: dict = {}
    for threshold in levels:
        bounds, scores = _boundaries(prefix, stat, finite, window, threshold, refine, seen)
        # per segment the channels' mean log residual variance; a fall across a boundary
        # is side 1 ("decrease"), a rise side 0, as for the covariance tests of 6.14
        edges = np.r_[0, bounds, prefix.rows].astype(np.int64)
        m = np.diff(edges).astype(np.float64)
        logvar = np.mean(np.log(prefix.rss(edges[:-1], edges[1:]) / m[:, None]), axis=1)
        out[threshold] = dict(boundaries=np.asarray(bounds, dtype=np.int64) + p,
                              statistic=statistic if len(levels) == 1 else statistic.copy(),
                              score=np.asarray(scores, dtype=np.float64),
                              sides=(np.diff(logvar) < 0).astype(np.int64), window=window,
                              dof=prefix.dof)
    return out


def _boundaries(prefix: ARPrefix, stat, finite, window: int, threshold: float,
                refine: bool, seen: dict) -> tuple[list[int], list[float]]:
    """Steps 3-5 of the module notes at one threshold: peaks, refinement, pruning
    (``seen``: the refinement searches done, shared by the thresholds of a sweep)."""
    from scipy.signal import find_peaks

    peaks, _ = find_peaks(finite, height=threshold, distance=window)
    bounds = [int(t) for t in peaks]
    scores = [float(stat[t]) for t in bounds]
    if refine and bounds:
        for _ in range(len(bounds) + 1):         # refine, drop the weakest failing, repeat
            bounds, scores = _refine(prefix, bounds, window, seen)
            weak = [k for k, s in enumerate(scores) if s < threshold]
            if not weak:
                break
            del bounds[min(weak, key=lambda k: scores[k])]
            if not bounds:
                scores = []
                break
    return bounds, scores
