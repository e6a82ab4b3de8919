"""Receiver operating characteristics of the two detectors of section 6.3.1.

Both detectors watch a Gaussian signal ``y ~ N(mu, sigma^2)`` whose mean steps by
``dmu``; the signal-to-noise ratio is ``s = dmu / sigma``. All functions here
use ``sigma = 1`` (so ``dmu = s``) without loss of generality.

Two quantities trade off against each other as the threshold moves:

- ``t_F``, the mean time to a false alarm (samples up to and including the
  alarm, started from a reset detector, in the absence of a change);
- ``t_D``, the mean delay to detection: the number of samples from the first
  changed sample up to and including the alarm (the run length, as counted by
  Wald's and Siegmund's formulas).

Theory (as printed in the thesis, and where it is not coherent, our reading):

- Page-Hinkley, Wald's approximations: ``t_F ~ |e^{T^2} - T^2 - 1| / beta0``,
  ``t_D ~ (e^{-T^2} + T^2 - 1) / beta1`` with ``beta = s^2/2`` for a change in
  mean. Wald ignores the overshoot of the random walk over the threshold (and
  its undershoot at the reflecting zero); Siegmund's corrected approximation
  replaces ``T^2`` by ``T^2 + 2 rho s`` with ``rho = -zeta(1/2)/sqrt(2 pi)
  ~ 0.5826`` (Siegmund 1985, the standard CUSUM ARL approximation with
  ``b = h + 1.166`` in units of the increment's standard deviation ``s``).
- Lowpass filter ``x(n+1) = a x(n) + (1-a) y(n+1)`` with the threshold at
  ``dmu/2`` (the thesis's "optimal threshold"): Hall's asymptotic bound for the
  false-alarm rate, a per-step Gaussian termination probability for the delay
  (a lower estimate), and the rise time of the mean (an upper estimate). See
  the individual functions for the places where the printed text had to be
  interpreted.

Monte Carlo: seeded, vectorised over many independent runs (columns) and over a
grid of detector settings that share one noise stream (common random numbers);
compiled loops over chunks of samples. The increments and filter updates use
exactly the arithmetic of :class:`~contactlab.detection.page_hinkley.PageHinkley`
and :class:`~contactlab.detection.lowpass.LowpassThreshold` (tested).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit
from scipy.optimize import brentq
from scipy.special import erfc

from contactlab.detection.cusum import cusum_step
from contactlab.progress import bar

#: Siegmund's overshoot constant rho = -zeta(1/2) / sqrt(2 pi).
RHO = 1.4603545088095868 / math.sqrt(2.0 * math.pi)


# -- Page-Hinkley theory ---------------------------------------------------------------
def beta(s):
    """``beta_i = 1/2 (dmu/sigma)^2 = s^2/2``: |mean increment| before and after the change."""
    return 0.5 * np.asarray(s, dtype=float) ** 2


def wald_false_alarm_time(threshold, *, s):
    """Wald's ``t_F ~ |e^{T^2} - T^2 - 1| / beta0`` (section 6.3.1); ``threshold = T^2``."""
    t2 = np.asarray(threshold, dtype=float)
    with np.errstate(over="ignore"):  # inf beyond ~T^2 = 709 is the right answer
        return np.abs(np.expm1(t2) - t2) / beta(s)


def wald_detection_delay(threshold, *, s):
    """Wald's ``t_D ~ (e^{-T^2} + T^2 - 1) / beta1`` (section 6.3.1)."""
    t2 = np.asarray(threshold, dtype=float)
    return (np.expm1(-t2) + t2) / beta(s)


def siegmund_false_alarm_time(threshold, *, s):
    """Wald's ``t_F`` with ``T^2 -> T^2 + 2 rho s`` (Siegmund's overshoot correction)."""
    return wald_false_alarm_time(np.asarray(threshold, dtype=float) + 2 * RHO * np.asarray(s), s=s)


def siegmund_detection_delay(threshold, *, s):
    """Wald's ``t_D`` with ``T^2 -> T^2 + 2 rho s`` (Siegmund's overshoot correction)."""
    return wald_detection_delay(np.asarray(threshold, dtype=float) + 2 * RHO * np.asarray(s), s=s)


def siegmund_threshold_for_false_alarm_time(false_alarm_time: float, *, s: float) -> float:
    """The Page-Hinkley threshold ``T^2`` whose :func:`siegmund_false_alarm_time` equals
    ``false_alarm_time`` (samples), for a change of size ``s``: the approximation inverted
    (Brent's method on its logarithm over ``T^2`` in [1e-3, 200])."""
    return brentq(lambda t2: np.log(siegmund_false_alarm_time(t2, s=s)) - np.log(false_alarm_time),
                  1e-3, 200.0)


# -- lowpass theory --------------------------------------------------------------------
def lowpass_threshold_t2(a, *, s):
    """``T^2`` of the lowpass test with its threshold at ``dmu/2``.

    The thesis states the threshold as ``dmu^2 / (4 S)`` with
    ``S = (1-a)/(1+a) sigma^2`` and then prints ``T^2 = (s/2)^2 (1-a)/(1+a)``;
    the two disagree (the printed ratio is inverted). We use the first,
    ``T^2 = (dmu/2)^2 / S = (s/2)^2 (1+a)/(1-a)``: it is what a threshold of
    0.50 on ``x`` with ``dmu = 1`` means (fig 6.6), and only it gives false-alarm
    times near the thesis's 6e6 at ``a = 0.98``.
    """
    a = np.asarray(a, dtype=float)
    return (np.asarray(s, dtype=float) / 2) ** 2 * (1 + a) / (1 - a)


def hall_false_alarm_rate(a, *, threshold_t2, one_sided: bool = True):
    """Hall's asymptotic bound on the false-alarm rate of a first-order lag filter.

    ``f0 <= 1 - exp(sqrt(pi/2) ln(a) T exp(-T^2/2) (1 - 1/T^2))`` for
    ``x^2/S > T^2`` (both tails); the one-sided test ``x/S^{1/2} > T`` has
    ``f0/2`` (section 6.3.1). Implemented as printed; NaN for ``T^2 <= 1``,
    where the asymptotic formula turns negative. Note: the thesis's general
    ``p``-dimensional form, ``ln(det A) T^p / Gamma(p/2 + 1)``, gives
    ``2/sqrt(pi)`` rather than ``sqrt(pi/2)`` for ``p = 1``, and the continuous
    Ornstein-Uhlenbeck asymptotics (:func:`ou_false_alarm_time`) give
    ``sqrt(2/pi)``; the printed constant is the largest of the three, i.e. the
    most pessimistic bound.
    """
    a = np.asarray(a, dtype=float)
    t2 = np.asarray(threshold_t2, dtype=float)
    t = np.sqrt(t2)
    with np.errstate(divide="ignore", invalid="ignore"):
        f0 = -np.expm1(np.sqrt(np.pi / 2) * np.log(a) * t * np.exp(-t2 / 2) * (1 - 1 / t2))
    # an asymptotic (large-T) result: for T^2 <= 1 the factor (1 - 1/T^2) makes it
    # meaningless (negative), so there is no value
    f0 = np.where(t2 > 1, f0, np.nan)
    return f0 / 2 if one_sided else f0


def hall_false_alarm_time(a, *, s, one_sided: bool = True):
    """``t_F = 1/f`` from Hall's bound with the threshold at ``dmu/2`` (a lower bound on t_F)."""
    rate = hall_false_alarm_rate(a, threshold_t2=lowpass_threshold_t2(a, s=s),
                                 one_sided=one_sided)
    with np.errstate(divide="ignore", over="ignore"):  # a rate that underflows: t_F = inf
        return 1.0 / rate


def ou_false_alarm_time(a, *, s):
    """Mean first-passage time of the continuous-time approximation (our addition).

    Treating ``x`` as an Ornstein-Uhlenbeck process with rate ``lambda = -ln a``
    per sample, the mean time to first reach ``T`` standard deviations is, for
    large ``T``, ``sqrt(2 pi) e^{T^2/2} / (lambda T)`` (one-sided). Sampling can
    only miss crossings, so the discrete filter alarms less often than this.
    """
    a = np.asarray(a, dtype=float)
    t2 = lowpass_threshold_t2(a, s=s)
    with np.errstate(over="ignore"):
        return np.sqrt(2 * np.pi) * np.exp(t2 / 2) / (-np.log(a) * np.sqrt(t2))


def lowpass_rise_time(a):
    """Samples for the mean ``xbar(k) = dmu (1 - a^k)`` to reach ``dmu/2``: ``ln 2 / -ln a``.

    The thesis's upper estimate of ``t_D`` (34.5 at ``a = 0.98``; this gives 34.3,
    and the continuous ``ln 2/(1-a)`` gives 34.7).
    """
    return np.log(2.0) / -np.log(np.asarray(a, dtype=float))


def lowpass_termination_probability_as_printed(a, *, s):
    """The per-step termination probability as printed: ``1 - erf(s/2 sqrt((1-a)/(1+a)))``.

    It does not depend on the step ``k`` (0.943 per step at ``s = 1, a = 0.98``,
    i.e. detection after about one sample), so it cannot give the thesis's
    ``t_D = 29.5``; see :func:`lowpass_delay_erf` for the reading we use.
    """
    from scipy.special import erf
    a = np.asarray(a, dtype=float)
    return 1 - erf(np.asarray(s) / 2 * np.sqrt((1 - a) / (1 + a)))


def lowpass_delay_erf(a, *, s, k_max: int = 100_000):
    """Mean delay from a per-step Gaussian termination probability (a lower estimate).

    Our coherent reading of section 6.3.1: after ``k`` changed samples the
    filter output is Gaussian with mean ``xbar(k) = dmu (1 - a^k)`` and the
    stationary variance ``S``; the probability that it exceeds ``dmu/2`` is
    ``F(k) = 1/2 erfc((dmu/2 - xbar(k)) / sqrt(2 S))``. Treating the steps as
    independent, the test terminates at ``k`` with probability
    ``F(k) prod_{j<k} (1 - F(j))`` (the printed recursion
    ``P_D(k) = F(k)(1 - P_D(k-1))`` uses the previous step's termination
    probability where the survival probability belongs, and its ``F`` has no
    ``k``). Returns ``sum_k k P_D(k)``, ``k >= 1``. Independence ignores the
    strong correlation of ``x`` between steps, so this underestimates ``t_D``.
    """
    a_arr = np.atleast_1d(np.asarray(a, dtype=float))
    s_arr = np.broadcast_to(np.asarray(s, dtype=float), a_arr.shape)
    out = np.empty(a_arr.shape)
    for i, (ai, si) in enumerate(zip(a_arr.ravel(), s_arr.ravel(), strict=True)):
        # enough steps for xbar to pass dmu/2 by many standard deviations
        k_end = int(min(k_max, max(200, 60 * lowpass_rise_time(ai))))
        k = np.arange(1, k_end + 1)
        xbar = si * -np.expm1(k * np.log(ai))
        sd = np.sqrt((1 - ai) / (1 + ai))
        f = 0.5 * erfc((si / 2 - xbar) / (np.sqrt(2) * sd))
        survive = np.concatenate([[1.0], np.cumprod(1 - f)[:-1]])
        out.ravel()[i] = np.sum(k * f * survive)
    return out.reshape(np.shape(a)) if np.ndim(a) else float(out[0])


# -- Monte Carlo -----------------------------------------------------------------------
@dataclass(frozen=True)
class MCResult:
    """Monte Carlo estimates, one entry per detector setting.

    ``mean`` is ``t_F`` (exposure / alarms) or ``t_D`` (mean of the delays);
    ``stderr`` its standard error (``t_F/sqrt(alarms)`` for geometric run
    lengths; ``sd/sqrt(n)`` for delays); ``n_events`` the alarms or completed
    delay runs; ``exposure`` the samples simulated per setting; for delays,
    ``n_discarded`` counts runs that false-alarmed before the change and
    ``n_censored`` runs with no alarm within the simulated length.
    ``quantiles`` (delays only): the 5, 25, 50, 75, 95 % points.
    """

    mean: np.ndarray
    stderr: np.ndarray
    n_events: np.ndarray
    exposure: np.ndarray
    n_discarded: np.ndarray | None = None
    n_censored: np.ndarray | None = None
    quantiles: np.ndarray | None = None


QUANTILES = (0.05, 0.25, 0.5, 0.75, 0.95)


#: the detectors the Monte Carlo kernels step: Page-Hinkley on the increments
#: (``p1`` the gain, ``p2`` the half-shift) and the lowpass (``p1`` the pole ``a``)
_PH, _LP = 0, 1


@njit(cache=True, inline="always")
def _detector_step(kind, p1, p2, v, y):  # pragma: no cover - numba
    """One sample ``y`` into a detector whose statistic is ``v``: the new statistic."""
    if kind == _PH:
        return cusum_step(v, p1 * (y - p2))
    return p1 * v + (1.0 - p1) * y


@njit(cache=True)
def _renewal(z, kind, p1, p2, thr, active, state, count):  # pragma: no cover - numba
    """The active settings over ``z`` (n, runs); an alarm counts and restarts from 0."""
    n, n_runs = z.shape
    for i in range(n):
        for r in range(n_runs):
            y = np.float64(z[i, r])
            for jj in range(active.size):
                j = active[jj]
                v = _detector_step(kind, p1[j], p2[j], state[r, j], y)
                if v > thr[j]:
                    count[j] += 1
                    v = 0.0
                state[r, j] = v


@njit(cache=True)
def _first_passage(z, t0, change_at, shift, kind, p1, p2, thr, state, result):  # pragma: no cover
    """Every setting over ``z`` (n, runs) from sample ``t0``, the mean stepping by ``shift``
    at ``change_at``: ``result`` gets the delay of a run's first alarm (-2 before the
    change; -1 while none)."""
    n, n_runs = z.shape
    n_cfg = thr.size
    for i in range(n):
        t = t0 + i
        for r in range(n_runs):
            for j in range(n_cfg):
                if result[r, j] != -1:
                    continue
                after = t >= change_at[j]
                y = np.float64(z[i, r])
                if after:
                    y = y + shift[j]
                v = _detector_step(kind, p1[j], p2[j], state[r, j], y)
                state[r, j] = v
                if v > thr[j]:
                    result[r, j] = t - change_at[j] + 1 if after else -2


def _configs(**arrays) -> dict[str, np.ndarray]:
    b = np.broadcast_arrays(*[np.atleast_1d(np.asarray(v, dtype=float)) for v in arrays.values()])
    return {k: np.ascontiguousarray(v.ravel()) for k, v in zip(arrays, b, strict=True)}


def _renewal_mc(step, n_cfg, *, n_runs, max_samples, target_alarms, chunk, rng, quiet, desc):
    count = np.zeros(n_cfg, dtype=np.int64)
    exposure = np.zeros(n_cfg, dtype=np.int64)
    active = np.arange(n_cfg, dtype=np.int64)
    total_steps = max(1, int(max_samples) // n_runs)
    z = np.empty((min(chunk, total_steps), n_runs), dtype=np.float32)
    done = 0
    with bar(total=total_steps * n_runs, desc=desc, quiet=quiet, unit="sample") as pbar:
        while active.size and done < total_steps:
            m = min(z.shape[0], total_steps - done)
            zc = z[:m]
            rng.standard_normal(dtype=np.float32, out=zc)
            step(zc, active, count)
            exposure[active] += m * n_runs
            done += m
            pbar.update(m * n_runs)
            active = active[count[active] < target_alarms]
    with np.errstate(divide="ignore", invalid="ignore"):
        mean = np.where(count > 0, exposure / np.maximum(count, 1), np.nan)
        stderr = mean / np.sqrt(count)
    return MCResult(mean, stderr, count, exposure)


def ph_false_alarm_mc(*, s, threshold, rng: np.random.Generator, n_runs: int = 256,
                      max_samples: float = 1e8, target_alarms: int = 400,
                      chunk: int = 2048, quiet: bool = True) -> MCResult:
    """Mean time to false alarm of Page-Hinkley on the change-in-mean increments.

    Every setting (``s`` and ``threshold`` broadcast together) runs on the same
    ``N(0, 1)`` stream, ``n_runs`` columns at a time; after an alarm the detector
    resets, so run lengths are independent and ``t_F = exposure / alarms`` (the
    renewal-reward estimate, which counts the censored last run). A setting
    stops once it has ``target_alarms`` alarms; the stream stops at
    ``max_samples`` samples per setting. Settings with no alarm get NaN.
    """
    c = _configs(s=s, threshold=threshold)
    gain, half, thr = c["s"], 0.5 * c["s"], c["threshold"]
    df = np.zeros((n_runs, thr.size))

    def step(z, active, count):
        _renewal(z, _PH, gain, half, thr, active, df, count)

    return _renewal_mc(step, thr.size, n_runs=n_runs, max_samples=max_samples,
                       target_alarms=target_alarms, chunk=chunk, rng=rng, quiet=quiet,
                       desc="PH false alarms")


def lowpass_false_alarm_mc(*, a, threshold, rng: np.random.Generator, n_runs: int = 256,
                           max_samples: float = 1e8, target_alarms: int = 400,
                           chunk: int = 2048, quiet: bool = True) -> MCResult:
    """Mean time to false alarm of the lowpass detector (``x > threshold``, sigma 1).

    As :func:`ph_false_alarm_mc`; the filter restarts from ``x = 0`` after an
    alarm (so each run starts with a short warm-up of about ``1/(1-a)``
    samples, small against ``t_F``).
    """
    c = _configs(a=a, threshold=threshold)
    x = np.zeros((n_runs, c["a"].size))

    def step(z, active, count):
        _renewal(z, _LP, c["a"], c["a"], c["threshold"], active, x, count)

    return _renewal_mc(step, c["a"].size, n_runs=n_runs, max_samples=max_samples,
                       target_alarms=target_alarms, chunk=chunk, rng=rng, quiet=quiet,
                       desc="lowpass false alarms")


def _first_passage_mc(step, n_cfg, *, n_runs, burn_in, max_delay, chunk, rng):
    result = np.full((n_runs, n_cfg), -1, dtype=np.int64)
    t = 0
    end = int(burn_in.max()) + max_delay
    while t < end and (result == -1).any():
        m = min(chunk, end - t)
        z = rng.standard_normal((m, n_runs), dtype=np.float32)
        step(z, t, result)
        t += m
    mean = np.full(n_cfg, np.nan)
    stderr = np.full(n_cfg, np.nan)
    quant = np.full((n_cfg, len(QUANTILES)), np.nan)
    n_ok = (result > 0).sum(axis=0)
    for j in range(n_cfg):
        d = result[result[:, j] > 0, j]
        if d.size:
            mean[j] = d.mean()
            stderr[j] = d.std(ddof=1) / np.sqrt(d.size) if d.size > 1 else np.nan
            quant[j] = np.quantile(d, QUANTILES)
    return MCResult(mean, stderr, n_ok, np.full(n_cfg, t * n_runs),
                    n_discarded=(result == -2).sum(axis=0), n_censored=(result == -1).sum(axis=0),
                    quantiles=quant)


def ph_delay_mc(*, s, threshold, rng: np.random.Generator, n_runs: int = 4000,
                burn_in=0, max_delay: int = 100_000, chunk: int = 512) -> MCResult:
    """Mean delay to detection of Page-Hinkley for a change in mean ``0 -> s``.

    Each run starts with ``DF = 0`` at sample 0; the mean steps at sample
    ``burn_in`` (scalar or one per setting, broadcast with ``s`` and
    ``threshold``). ``burn_in = 0`` is Wald's assumption (and Lorden's worst case);
    a long ``burn_in`` starts the change from the detector's steady state under
    H0. Runs that alarm before the change are discarded (counted).
    """
    c = _configs(s=s, threshold=threshold, burn_in=burn_in)
    gain, half, shift, thr = c["s"], 0.5 * c["s"], c["s"], c["threshold"]
    change_at = c["burn_in"].astype(np.int64)
    df = np.zeros((n_runs, thr.size))

    def step(z, t0, result):
        _first_passage(z, t0, change_at, shift, _PH, gain, half, thr, df, result)

    return _first_passage_mc(step, thr.size, n_runs=n_runs, burn_in=change_at,
                             max_delay=max_delay, chunk=chunk, rng=rng)


def lowpass_delay_mc(*, a, s, rng: np.random.Generator, threshold=None, n_runs: int = 4000,
                     burn_in=0, max_delay: int = 100_000, chunk: int = 512) -> MCResult:
    """Mean delay to detection of the lowpass detector for a change in mean ``0 -> s``.

    The threshold defaults to ``s/2`` (the thesis's choice). The filter starts
    at ``x = 0`` at sample 0 and the mean steps at ``burn_in`` (scalar or one
    per setting); a ``burn_in`` of
    several ``1/(1-a)`` starts the change from the stationary ``N(0, S)`` the
    thesis's delay estimates assume.
    """
    c = _configs(a=a, s=s, threshold=np.asarray(s, dtype=float) / 2 if threshold is None
                 else threshold, burn_in=burn_in)
    change_at = c["burn_in"].astype(np.int64)
    x = np.zeros((n_runs, c["a"].size))

    def step(z, t0, result):
        _first_passage(z, t0, change_at, c["s"], _LP, c["a"], c["a"], c["threshold"], x,
                       result)

    return _first_passage_mc(step, c["a"].size, n_runs=n_runs, burn_in=change_at,
                             max_delay=max_delay, chunk=chunk, rng=rng)
