"""Measurement noise levels estimated from the data (the accuracies of 8.7-8.9).

The constraint estimators work in units normalised by measurement accuracy
(8.7-8.9): a residual of one unit is one standard deviation of the
instrument's noise.  The likelihoods of the degrees of constraint (8.18, 8.2)
and the frame's standard error compare residuals *in those units*, so a wrong
accuracy biases both: with the position noise taken as 8.7 um while the
instrument has 0.1 mm, every block's motion noise along a normal looks like 11
standard deviations of motion, and a plane is taken for an edge; with it
taken as 8.7 um while the instrument has 10 um and force noise 10 mN for 5 mN
after lowpassing, the exploration test (9.1.2) misses real pushing.

Estimate.  Contact signals are smooth on the scale of a raw sample: the
second difference of a motion of 0.2 m/s^2 at 1000 Hz is 0.2 um, far below
any position noise of interest, and likewise for forces.  For white noise of
standard deviation ``s``, the second difference ``y(n+1) - 2 y(n) + y(n-1)``
has standard deviation ``sqrt(6) s``; its median absolute deviation
(``0.6745`` standard deviations for a normal) makes the estimate robust to
the few samples at impacts or stick-slip:

    s_raw = MAD(d2 y) / (0.6745 sqrt(6))                                      (1)

A quantised channel (an encoder) whose noise is below one step has second
differences that are mostly zero; its accuracy is then the quantisation
error ``step / sqrt(12)`` (a uniform error), with ``step`` the smallest
non-zero change of the channel, and the estimate is the larger of the two.

The estimators see the signals after the 7.1 conditioning (lowpass, 4:1
decimation); white noise of ``s_raw`` leaves it with

    s = s_raw sqrt(sum_j h_j^2)                                               (2)

with ``h`` the impulse response of the lowpass (its noise gain; 0.264 for the
second-order Butterworth at fs/8, a little above the quarter of Nyquist it
passes, so ``s = 0.51 s_raw``).  Both steps are checked against white noise
of known level in the tests.
"""

from __future__ import annotations

import math

import numba
import numpy as np

__all__ = ["raw_noise_sd", "lowpass_noise_gain", "conditioned_noise_sd"]

_MAD_NORMAL = 0.6744897501960817


def raw_noise_sd(y) -> np.ndarray:
    """Per-column white-noise standard deviation of ``y`` (N,) or (N, k), by (1) of
    the module notes, never below the quantisation error ``step / sqrt(12)``."""
    a = np.asarray(y, dtype=np.float64)
    a = a[:, None] if a.ndim == 1 else a
    if len(a) < 5:
        return np.full(a.shape[1], np.nan)
    mad, quant = _mad_and_step(np.ascontiguousarray(a.T))
    return np.maximum(mad / (_MAD_NORMAL * math.sqrt(6.0)), quant / math.sqrt(12.0))


@numba.njit(cache=True)
def _mad_and_step(cols):  # pragma: no cover - compiled
    """Per row of ``cols`` (k, N): the median absolute deviation of its second
    difference (taken as numpy's ``diff(n=2)``, a difference of differences) and its
    smallest non-zero step (0 for a constant row)."""
    k, n = cols.shape
    mad = np.empty(k)
    quant = np.empty(k)
    d1 = np.empty(n - 1)
    d2 = np.empty(n - 2)
    for j in range(k):
        step = np.inf
        for i in range(n - 1):
            d1[i] = cols[j, i + 1] - cols[j, i]
            s = abs(d1[i])
            if 0.0 < s < step:
                step = s
        for i in range(n - 2):
            d2[i] = d1[i + 1] - d1[i]
        m = np.median(d2)
        for i in range(n - 2):
            d2[i] = abs(d2[i] - m)
        mad[j] = np.median(d2)
        quant[j] = step if np.isfinite(step) else 0.0
    return mad, quant


def lowpass_noise_gain(*, fs: float, cutoff_hz: float | None, order: int = 2) -> float:
    """``sum_j h_j^2`` of the 7.1 Butterworth lowpass (the variance ratio of white noise);
    1 when ``cutoff_hz`` is None (a rate the conditioning does not filter,
    :func:`contactlab.signals.cutoff_for`)."""
    from contactlab.conditioning import butter_sos

    if cutoff_hz is None:
        return 1.0

    sos = butter_sos(fs=fs, cutoff_hz=cutoff_hz, order=order)
    impulse = np.zeros(int(20 * fs / cutoff_hz) + 64)
    impulse[0] = 1.0
    from scipy import signal

    h = signal.sosfilt(sos, impulse)
    return float(h @ h)


def conditioned_noise_sd(y, *, fs: float, cutoff_hz: float | None, order: int = 2) -> np.ndarray:
    """Per-column noise standard deviation of ``y`` after the 7.1 lowpass, (1) and (2)."""
    return raw_noise_sd(y) * math.sqrt(lowpass_noise_gain(fs=fs, cutoff_hz=cutoff_hz,
                                                          order=order))
