"""Level changes of a wrist wrench: contact made and broken, force phases, excursions.

The AR tests of 7.2.1 look for changes of a strain's *vibration*; on a wrist
force/torque sensor at 80-500 Hz the events a person marks are changes of the
force *level* (contact made or broken, a phase that presses harder), each
reached by a ramp of 0.1-2 s, with the contact's own wander and oscillation
(friction while sliding, a compliant controller's ringing) on top.  This detector
is built for that signal (beyond the thesis; its pieces are the thesis's tools
where they fit):

1. the force (N, 3 channels) through a zero-phase Butterworth lowpass at
   :data:`LEVEL_DEFAULTS` ``cutoff_hz`` (offline, so no delay; it removes a
   controller's ringing and the sensor's noise);
2. at every sample the two-window mean difference
   ``D(t) = || mean x[t, t+W) - mean x[t-W, t) ||``: with a known covariance,
   the generalised likelihood ratio of one mean against two (the mean-change
   test of 6.3.1 with the change size estimated) is monotone in it;
3. changes are the peaks of ``D`` at least ``W`` apart that reach the
   threshold ``max(floor_n, noise_factor * sigma, fraction * D_ref)``: ``floor_n``
   newtons, ``noise_factor`` times the sensor's white-noise level ``sigma`` (the
   robust sd of the first difference over sqrt 2), and ``fraction`` of the
   recording's largest level changes ``D_ref`` (the 99.5th percentile of
   ``D``).  The relative term makes one set of defaults serve a 10 N
   pick-and-place and a 30 N snap fit: a change a person marks is a sizeable
   part of the recording's force excursions;
4. each change's ramp is found by a least-squares fit of constant - linear -
   constant over the stretch where ``D`` stays above ``extent`` of its peak
   (widened by ``W / 2``; :func:`ramp_fit`, every pair of breakpoints from
   cumulative sums);
5. the boundary is placed at the end of the ramp nearer the free-space level
   (the recording's first ``W`` seconds): where the force leaves the level
   nearer free space by more than ``departure`` of the step, or reaches it within
   that share.  Contact is made when the force leaves its free level and broken
   when it is back there, so a person marks a touch-down at the ramp's start and a
   lift-off at its end;
6. two successive changes that leave a level away from free space and return to
   it (within a quarter of the larger step) within ``excursion_s`` seconds are an
   *event* inside a phase (a dip or a bump while in contact), reported apart
   from the boundaries.

Cost: O(N) for the lowpass and ``D``, plus O(L^2) per change for the ramp fit
over its stretch of L samples (capped at ``max_ramp_s`` on each side of the peak).
"""

from __future__ import annotations

import math

import numba
import numpy as np

__all__ = ["LEVEL_DEFAULTS", "level_changes", "ramp_fit", "window_difference", "LevelChanges"]

#: defaults of :func:`level_changes`, chosen on wrist recordings of other groups
#: (wiping and snap-fit assembly: pooled boundary F1 within 0.25 s, module notes)
LEVEL_DEFAULTS = {
    "cutoff_hz": 2.0,        # lowpass of the force before the level test
    "window_s": 0.5,         # W: each side of the two-window mean difference
    "fraction": 0.4,         # of the recording's largest level changes (99.5th pct of D)
    "floor_n": 0.5,          # newtons: no change smaller than this is a level change
    "noise_factor": 10.0,    # times the sensor's white-noise level
    "extent": 0.3,           # a ramp's stretch: where D stays above this share of its peak
    "departure": 0.2,        # a boundary: where the force is this share of the step off its level
    "excursion_s": 2.5,      # a return to the same level within this is an event, not two boundaries
    "max_ramp_s": 3.0,       # the ramp fit looks at most this far on each side of a peak
}


class LevelChanges:
    """Result of :func:`level_changes` (sample indices into the signal).

    Attributes
    ----------
    boundaries : (K,) int64 first sample of each new level (state-change boundaries).
    events : (E,) int64 start of each excursion inside a phase (left out of ``boundaries``).
    event_ends : (E,) int64 the sample each excursion returned to its level.
    peaks : (K,) int64 the peak of ``D`` that found each boundary (its detection).
    statistic : (N,) ``D(t)``, N (newtons); zero within ``W`` of either end.
    threshold : the threshold ``D`` had to reach (N).
    noise_sd : the sensor's white-noise level (N, the channels' norm).
    away : (K,) bool, True where a boundary's new level is farther from free space than
        the old one (contact made, or pressing harder), False where it comes back.
    """

    def __init__(self, boundaries, events, event_ends, peaks, statistic, threshold, noise_sd,
                 away):
        self.away = np.asarray(away, dtype=bool)
        self.boundaries = np.asarray(boundaries, dtype=np.int64)
        self.events = np.asarray(events, dtype=np.int64)
        self.event_ends = np.asarray(event_ends, dtype=np.int64)
        self.peaks = np.asarray(peaks, dtype=np.int64)
        self.statistic = statistic
        self.threshold = float(threshold)
        self.noise_sd = float(noise_sd)


def window_difference(x: np.ndarray, w: int) -> np.ndarray:
    """``D(t) = || mean x[t, t+w) - mean x[t-w, t) ||`` for every t (zero where a window
    would leave the signal); ``x`` (N, C)."""
    n = len(x)
    out = np.zeros(n)
    if n < 2 * w or w < 1:
        return out
    c = np.concatenate([np.zeros((1, x.shape[1])), np.cumsum(x, axis=0)])
    idx = np.arange(w, n - w + 1)
    diff = (c[idx + w] - 2 * c[idx] + c[idx - w]) / w
    out[idx[idx < n]] = np.linalg.norm(diff[idx < n], axis=1)
    return out


@numba.njit(cache=True, nogil=True)
def ramp_fit(y, a, b, minlen):  # pragma: no cover - compiled; tests check it against numpy
    """Breakpoints ``(k1, k2)`` of the least-squares constant - linear - constant fit of
    ``y[a:b]`` (N, C; every channel the same breakpoints): constant on ``[a, k1)``,
    linear on ``[k1, k2)``, constant on ``[k2, b)``, each constant at least ``minlen``
    samples.  Every pair is tried from cumulative sums (O(L^2 C))."""
    n = b - a
    c = y.shape[1]
    S = np.zeros((n + 1, c))
    Q = np.zeros((n + 1, c))
    TY = np.zeros((n + 1, c))
    for i in range(n):
        for j in range(c):
            v = y[a + i, j]
            S[i + 1, j] = S[i, j] + v
            Q[i + 1, j] = Q[i, j] + v * v
            TY[i + 1, j] = TY[i, j] + i * v
    best = np.inf
    bk1, bk2 = a + n // 2, a + n // 2
    for k1 in range(minlen, n - minlen - 1):
        s1 = 0.0
        for j in range(c):
            s1 += Q[k1, j] - S[k1, j] * S[k1, j] / k1
        for k2 in range(k1 + 2, n - minlen + 1):
            L = k2 - k1
            tm = (k1 + k2 - 1) / 2.0
            stt = L * (L * L - 1) / 12.0
            r = n - k2
            tot = s1
            for j in range(c):
                sy = S[k2, j] - S[k1, j]
                cov = TY[k2, j] - TY[k1, j] - tm * sy
                tot += Q[k2, j] - Q[k1, j] - sy * sy / L - cov * cov / stt
                sy3 = S[n, j] - S[k2, j]
                tot += Q[n, j] - Q[k2, j] - sy3 * sy3 / r
            if tot < best:
                best = tot
                bk1, bk2 = a + k1, a + k2
    return bk1, bk2


def _noise_sd(y: np.ndarray) -> float:
    """The white-noise level of ``y`` (N, C): the robust sd of the first difference over
    sqrt 2 per channel, their norm."""
    if len(y) < 3:
        return 0.0
    d = np.diff(y, axis=0)
    mad = np.median(np.abs(d - np.median(d, axis=0)), axis=0)
    return float(np.linalg.norm(1.4826 * mad / math.sqrt(2.0)))


def _stretch(above: np.ndarray, p: int, cap: int) -> tuple[int, int]:
    """``[lo, hi)``: the run of True in ``above`` around ``p``, at most ``cap`` each side."""
    left = above[max(0, p - cap):p + 1][::-1]
    right = above[p:p + cap + 1]
    k_left = int(np.argmin(left)) if not left.all() else len(left)
    k_right = int(np.argmin(right)) if not right.all() else len(right)
    return p - k_left + 1, p + k_right


def level_changes(force, *, fs: float, cutoff_hz: float = LEVEL_DEFAULTS["cutoff_hz"],
                  window_s: float = LEVEL_DEFAULTS["window_s"],
                  fraction: float = LEVEL_DEFAULTS["fraction"],
                  floor_n: float = LEVEL_DEFAULTS["floor_n"],
                  noise_factor: float = LEVEL_DEFAULTS["noise_factor"],
                  extent: float = LEVEL_DEFAULTS["extent"],
                  departure: float = LEVEL_DEFAULTS["departure"],
                  excursion_s: float = LEVEL_DEFAULTS["excursion_s"],
                  max_ramp_s: float = LEVEL_DEFAULTS["max_ramp_s"]) -> LevelChanges:
    """Level changes of ``force`` (N, C) sampled at ``fs`` Hz (module notes, steps 1-6)."""
    from scipy.signal import butter, sosfiltfilt

    y = np.asarray(force, dtype=np.float64)
    if y.ndim == 1:
        y = y[:, None]
    n = len(y)
    w = max(2, int(round(window_s * fs)))
    empty = np.zeros(0, dtype=np.int64)
    sigma = _noise_sd(y)
    if n < 4 * w:
        return LevelChanges(empty, empty, empty, empty, np.zeros(n), math.inf, sigma,
                            np.zeros(0, bool))
    x = y
    if cutoff_hz is not None and cutoff_hz < fs / 2:
        sos = butter(2, cutoff_hz, fs=fs, output="sos")
        x = sosfiltfilt(sos, y, axis=0) if n > 3 * 7 else y
    x = np.ascontiguousarray(x)
    D = window_difference(x, w)
    threshold = max(floor_n, noise_factor * sigma, fraction * float(np.percentile(D, 99.5)))
    from scipy.signal import find_peaks

    peaks, _ = find_peaks(D, height=threshold, distance=w)
    free = x[:w].mean(axis=0)
    cap = max(w, int(max_ramp_s * fs))
    placed, levels, away = [], [], []
    for p in peaks:
        lo, hi = _stretch(D > extent * D[p], p, cap)
        lo, hi = max(0, lo - w // 2), min(n, hi + w // 2)
        k1, k2 = ramp_fit(x, lo, hi, max(2, w // 4))
        before, after = x[lo:k1].mean(axis=0), x[k2:hi].mean(axis=0)
        step = float(np.linalg.norm(after - before))
        mid = (k1 + k2) // 2
        away.append(np.linalg.norm(after - free) >= np.linalg.norm(before - free))
        if not away[-1]:
            near = np.flatnonzero(np.linalg.norm(x[mid:hi] - after, axis=1) < departure * step)
            b = mid + (int(near[0]) if near.size else 0)
        else:
            near = np.flatnonzero(np.linalg.norm(x[lo:mid] - before, axis=1) < departure * step)
            b = lo + (int(near[-1]) + 1 if near.size else mid - lo)
        placed.append(min(max(b, 1), n - 1))
        levels.append((before, after, step))
    order = np.argsort(placed, kind="stable")
    placed = [placed[i] for i in order]
    levels = [levels[i] for i in order]
    away = np.asarray(away, dtype=bool)[order] if len(order) else np.zeros(0, bool)
    peaks = peaks[order]
    keep = np.ones(len(placed), dtype=bool)
    ev, ev_end = [], []
    i = 0
    while i < len(placed) - 1:
        (b0, _, s0), (_, a1, s1) = levels[i], levels[i + 1]
        scale = 0.25 * max(s0, s1)
        if (placed[i + 1] - placed[i] <= excursion_s * fs
                and np.linalg.norm(a1 - b0) < scale and np.linalg.norm(b0 - free) > scale):
            keep[i] = keep[i + 1] = False
            ev.append(placed[i])
            ev_end.append(placed[i + 1])
            i += 2
            continue
        i += 1
    bounds = np.asarray(placed, dtype=np.int64)[keep]
    uniq, first = np.unique(bounds, return_index=True)
    return LevelChanges(uniq, ev, ev_end, peaks[keep][first], D, threshold, sigma,
                        away[keep][first])
