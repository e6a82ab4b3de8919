"""Change-detector segmentation of strains and forces (section 7.2.1, fig 7.6).

(One module of about 770 lines: both segmenters -- the thesis's Page-Hinkley
test and the AR GLR -- return one :class:`Segmentation`, share its parameter
checks, sweeps, boundary metrics and the ``segment`` stage; split, each part
would import the others.)

The pipeline of figure 7.6, one box per existing module:

1. conditioning (7.1): strains lowpassed and decimated to 250 Hz
   (:func:`contactlab.conditioning.condition_strains`), or the wrench through
   the same filter, or the high-frequency log-energy signal;
2. per channel a square-root AR(p) estimator
   (:class:`~contactlab.estimators.rls.SquareRootRLS` on
   :class:`~contactlab.estimators.models.ARModel` regressors, the channels as
   the batch axis), whose running innovation variance starts on the ninth
   measurement (``warmup=8``);
3. the sum over the C channels of the squared normalised innovations,
   ``chi2(n) = sum_c nu_c(n)^2 / V_c(n-1)`` (6.11, chi-square with C degrees of
   freedom);
4. the Page-Hinkley test (6.14-6.18) for a change of covariance size
   ``q = change_size`` in both directions (an increase to ``q V`` and a
   decrease to ``V / q``), threshold ``T^2 = threshold``;
5. on an alarm, both the estimators and the detector restart, the estimators
   "using the next measurement" (fig 7.6): the first sample they absorb is the
   one after the alarm.

Boundaries.  The Page-Hinkley test estimates the change time as the last
sample at which the firing statistic was zero (fig 6.4); the new regime starts
one sample later (the maximiser ``r`` of 6.15).  A :class:`Segmentation`
reports **that first sample of the new regime** as the boundary
(``boundaries``, ``boundaries_s``) -- the convention of ruptures, where a
boundary is the end (exclusive) of a regime -- the last zero itself as
``change_s``, and the sample at which the alarm was raised as ``alarms`` /
``alarms_s``.  The estimators restart after
the *alarm*, as in the thesis, so the samples between a boundary and its alarm
were modelled by the old estimator.

While the estimators warm up after a (re)start, ``chi2`` is undefined (NaN in
:attr:`Segmentation.statistic`) and the detector is held at zero.  The thesis
starts the variance estimate on the ninth measurement but does not say when
testing starts.  Testing from the tenth measurement -- a variance from one
sample -- makes each channel's ratio ``nu^2 / V`` F(1, 1)-distributed
(Cauchy-like tails): on stationary 8-channel AR(2) data the test then alarms
within the first 300 samples after 22% of (re)starts (400 runs, T^2 = 200),
and every false alarm restarts the estimators into the same trap.  So the
detector starts once the variance holds ``variance_samples`` samples (default
8, no false alarm in the same 400 runs already at 2); ``variance_samples=1``
is the literal reading.  Channels that are constant over the whole
signal (no innovation variance to estimate) are left out, and the statistic's
degrees of freedom are the channels used (:attr:`Segmentation.channels`).

Efficiency.  :func:`segment_signal` runs the estimators and the detector over
blocks of samples (numba kernels, state carried between blocks) with no
per-sample Python.  On an alarm inside a block both are reset and processing
continues from the sample after the alarm; the rest of that block is simply
recomputed, so the cost is ``O(N + alarms * block)``.

Per-channel combination (``combine="channel"``; beyond the thesis).  Step 3
sums the C channels into one chi-square(C) statistic with equal weights.  When
a change moves the innovation variance of a few channels only, the sum dilutes
it: a 10x fall on 2 of 8 channels lowers the mean chi2/dof to 0.78, above the
ln q / (q - 1) = 0.61 below which the q = 2.5 decrease test drifts up at all,
so the sum's test drifts down and finds the change only by chance.  ``combine="channel"`` instead runs one two-sided
Page-Hinkley variance test per channel -- (6.14) with ``m = 1`` on
``nu_c^2 / V_c``, the same ``q``, both sides, (6.18) -- and declares a change
when any channel's detector fires; the change time is that detector's
estimate (its last zero), and all estimators and all detectors restart as in
the sum mode.  Ties (two channels firing on the same sample) go to the lower
channel index.  The per-channel tests are exactly the sum-mode test applied to
each channel alone, run side by side until the first alarm.

False alarms.  C detectors at one threshold alarm about C times as often as
one of them.  Wald's approximation (6.3.1) gives a detector's mean time to a
false alarm ``t_F ~ e^{T^2} / b`` with ``b = -E[Xi | H0]``, the drift per
sample, which for (6.14) is ``m/2 (log q - 1 + 1/q)``: proportional to the
degrees of freedom ``m``.  The sum test (``m = C``) and the fastest of C
independent one-channel tests (``m = 1``, rate ``C e^{-T^2} b_1``) therefore
have the *same* first-order false-alarm rate at the same ``T^2``; against a
single one-channel test the C detectors need ``T^2 + log C`` for its rate.  The
approximation ignores the overshoot and the estimated variance, which differ
between the modes: measured on 1000-4000 s of stationary 8-channel AR(2) data, the
channel mode alarms 3.6-4.5 times as often as the sum at T^2 = 6, 8, 10 (about
``ln 4 = 1.4`` of threshold, between the two predictions 0 and ``ln 8``), and
neither alarms at all from T^2 = 15 up.  The experiment chooses each mode's
threshold by F1 and reports these rates.

Metrics (:func:`boundary_metrics`) are ruptures' ``precision_recall``
(``ruptures.metrics``), boundaries as sample indices with a margin.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from contactlab import defaults as D
from contactlab.archive.results import TrialResults
from contactlab.detection import PageHinkley, VarianceChangeDetector
from contactlab.detection.ar_glr import GLR_DEFAULTS, glr_sweep
from contactlab.detection.increments import VARIANCE_SIDES, variance_increments
from contactlab.detection.level_shift import LEVEL_DEFAULTS, level_changes
from contactlab.errors import DataError, UsageError
from contactlab.estimators import ARModel, SquareRootRLS
from contactlab.signals import SIGNALS, conditioned_signal, resolve_signal, source_of
from contactlab.stages import Stage, TrialOutcome, run_stage

__all__ = ["SIGNALS", "SIDES", "Segmentation", "segment_signal", "segment_trial",
           "conditioned_signal", "sweep", "boundary_metrics", "truth_boundaries_s",
           "min_samples", "run_archive", "pooled_metrics", "COMBINE", "METHODS",
           "DEFAULT_METHOD", "segment_glr", "segment_glr_sweep", "default_threshold",
           "segment_level", "resolve_method", "AUTO_METHOD", "labelled_only"]

#: side codes of :attr:`Segmentation.sides`: 0 increase, 1 decrease of the covariance
SIDES = VARIANCE_SIDES
#: how the channels' squared normalised innovations reach Page-Hinkley: ``sum`` (the
#: thesis: one chi-square(C) test) or ``channel`` (one chi-square(1) test per channel)
COMBINE = ("sum", "channel")

DEFAULT_BLOCK = 512

#: detectors :func:`segment_trial` and :func:`run_archive` offer: ``glr`` (the two-model
#: AR GLR of :mod:`contactlab.detection.ar_glr`, offline) and ``page-hinkley`` (the
#: thesis's sequential test, :func:`segment_signal`)
METHODS = ("auto", "glr", "page-hinkley", "level")
#: what ``auto`` runs on each signal: the wrench of a wrist sensor changes its level at
#: the events a person marks (contact made and broken, a phase that presses harder), a
#: strain its vibration (7.2.1)
AUTO_METHOD = {"wrench": "level", "strain": "glr", "hf": "glr"}
#: the default: on the synthetic piecewise-AR suite (``make bench``) the GLR finds
#: every change within 50 ms (F1 1.00) where the thesis's test at T^2 = 200 reaches
#: 0.61 and misses most coefficient-only changes (module notes of ``ar_glr``)
DEFAULT_METHOD = D.SEGMENT_METHOD
_DEFAULT_THRESHOLDS = {"glr": GLR_DEFAULTS["threshold"], "page-hinkley": D.SEGMENT_THRESHOLD,
                       "level": LEVEL_DEFAULTS["fraction"]}


def default_threshold(method: str) -> float | None:
    """The default threshold of ``method``: GLR per degree of freedom, Page-Hinkley T^2,
    or the level test's share of the recording's largest level changes (None for
    ``auto``: the chosen method's)."""
    _check_method(method)
    return _DEFAULT_THRESHOLDS.get(method)


def resolve_method(method: str, signal: str) -> str:
    """The detector ``method`` runs on ``signal`` (``auto``: :data:`AUTO_METHOD`)."""
    _check_method(method)
    return AUTO_METHOD.get(signal, "glr") if method == "auto" else method


def _check_method(method) -> None:
    if method not in METHODS:
        raise UsageError(f"method must be one of {', '.join(METHODS)}; got {method!r}")


@dataclass(frozen=True, eq=False)
class Segmentation:
    """Result of :func:`segment_signal` / :func:`segment_trial`.

    Attributes
    ----------
    boundaries : (K,) int64 sample index of the first sample of each new
        segment (page-hinkley: the change-time estimate + 1; glr: the most
        likely split), increasing.
    alarms : (K,) int64 sample index at which each change was detected
        (page-hinkley: the estimators and detector restart at ``alarms + 1``;
        glr, offline: the last sample of the window that first sees it).
    sides : (K,) int64 0 = covariance increase, 1 = decrease (names in
        :data:`SIDES`; page-hinkley: the test that fired).
    times : (N,) time (s) of every sample of the segmented signal.
    statistic : page-hinkley: the chi-square statistic fed to the detector(s),
        NaN where undefined (estimator warm-up after a start or restart), (N,)
        for ``combine="sum"``, (N, len(channels)) for ``combine="channel"``;
        glr: the window likelihood ratio per degree of freedom, (N,).
    channels : indices of the channels used (constant channels are left out).
    parameters : the parameters of the run (order, threshold, change_size,
        warmup, fs, combine, ...).
    alarm_channels : (K,) int64, for ``combine="channel"`` the channel (index
        into the signal's columns) whose detector fired; -1 for ``sum``.
    events, event_ends : (E,) int64, ``level`` only: excursions inside a phase (a dip
        or a bump that returns to its level), their first sample and the sample they
        end; not boundaries (empty for the other methods).
    """

    boundaries: np.ndarray
    alarms: np.ndarray
    sides: np.ndarray
    times: np.ndarray
    statistic: np.ndarray
    channels: np.ndarray
    parameters: dict = field(default_factory=dict)
    alarm_channels: np.ndarray | None = None
    events: np.ndarray | None = None
    event_ends: np.ndarray | None = None

    def __post_init__(self):
        if self.alarm_channels is None:
            object.__setattr__(self, "alarm_channels",
                               np.full(self.boundaries.shape, -1, dtype=np.int64))
        for name in ("events", "event_ends"):
            if getattr(self, name) is None:
                object.__setattr__(self, name, np.zeros(0, dtype=np.int64))

    @property
    def events_s(self) -> np.ndarray:
        """Start times (s) of the excursions inside a phase (``level`` only)."""
        return self.times[self.events]

    def __len__(self) -> int:
        return int(self.boundaries.size)

    @property
    def boundaries_s(self) -> np.ndarray:
        """Boundaries as times (s) of the signal's samples."""
        return self.times[self.boundaries]

    @property
    def change_s(self) -> np.ndarray:
        """The Page-Hinkley change-time estimates (s): the sample before each boundary,
        the last one at which the firing statistic was zero (fig 6.4)."""
        return self.times[self.boundaries - 1]

    @property
    def alarms_s(self) -> np.ndarray:
        """Alarm times (s)."""
        return self.times[self.alarms]

    @property
    def side_names(self) -> list[str]:
        return [SIDES[s] for s in self.sides]

    def as_dict(self) -> dict:
        """JSON-ready summary: boundaries, alarms (samples and seconds), sides."""
        return {"boundaries_s": self.boundaries_s.tolist(),
                "change_s": self.change_s.tolist(),
                "alarm_s": self.alarms_s.tolist(),
                "boundaries": self.boundaries.tolist(),
                "alarms": self.alarms.tolist(),
                "sides": self.side_names,
                **({"alarm_channels": self.alarm_channels.tolist()}
                   if self.parameters.get("combine") == "channel" else {}),
                **({"events_s": self.events_s.tolist(),
                    "event_ends_s": self.times[self.event_ends].tolist()}
                   if self.parameters.get("method") == "level" else {})}


def min_samples(order: int, warmup: int, variance_samples: int = 8) -> int:
    """Fewest samples a signal needs for one tested chi-square value after a start.

    ``order`` samples of history, ``max(warmup, order)`` rows of warm-up,
    ``variance_samples`` rows in the variance, then the row tested.
    """
    return order + max(warmup, order) + variance_samples + 1


def _as_signal(y) -> np.ndarray:
    """``y`` as a finite (N, C) float array (UsageError for the shape, DataError naming
    the field ``signal`` for NaN or infinite values)."""
    a = np.asarray(y, dtype=np.float64)
    if a.ndim == 1:
        a = a[:, None]
    if a.ndim != 2 or a.shape[1] < 1:
        raise UsageError(f"y must be (N,) or (N, C) with time first; got shape {a.shape}")
    if not np.isfinite(a).all():
        raise DataError("signal has NaN or infinite values", field="signal")
    return a


def _sample_times(n: int, *, fs, t0, times) -> np.ndarray:
    """``times`` (checked: one per sample) or ``t0 + k / fs``."""
    if times is None:
        return t0 + np.arange(n) / float(fs)
    times = np.asarray(times, dtype=np.float64)
    if times.shape != (n,):
        raise UsageError(f"times must have one entry per sample ({n}); got {times.shape}")
    return times


def _check_combine(combine) -> None:
    if combine not in COMBINE:
        raise UsageError(f"combine must be one of {', '.join(COMBINE)}; got {combine!r}")


def _check_params(order, threshold, change_size, warmup, block) -> None:
    if not isinstance(order, (int, np.integer)) or isinstance(order, bool) or order < 1:
        raise UsageError(f"order must be an integer >= 1; got {order!r}")
    if not (isinstance(threshold, (int, float, np.number)) and math.isfinite(threshold)
            and threshold > 0):
        raise UsageError(f"threshold must be a number > 0; got {threshold!r}")
    if not (isinstance(change_size, (int, float, np.number)) and math.isfinite(change_size)
            and change_size > 1):
        raise UsageError(f"change_size must be a number > 1; got {change_size!r}")
    if not isinstance(warmup, (int, np.integer)) or isinstance(warmup, bool) or warmup < 0:
        raise UsageError(f"warmup must be an integer >= 0; got {warmup!r}")
    if not isinstance(block, (int, np.integer)) or block < 1:
        raise UsageError(f"block must be an integer >= 1; got {block!r}")


def segment_signal(y, *, fs: float, order: int = D.SEGMENT_ORDER,
                   threshold: float = D.SEGMENT_THRESHOLD, change_size: float = D.CHANGE_SIZE,
                   warmup: int = D.WARMUP, variance_samples: int = 8,
                   t0: float = 0.0, times=None, block: int = DEFAULT_BLOCK,
                   combine: str = "sum") -> Segmentation:
    """Segment ``y`` (N,) or (N, C) sampled at ``fs`` Hz (fig 7.6).

    Parameters
    ----------
    order : AR order p of every channel's estimator (2 in the thesis).
    threshold : Page-Hinkley decision threshold ``T^2`` (200 in the thesis;
        fig 7.5 uses 100).
    change_size : covariance change ``q`` tested in both directions (2.5).
    warmup : samples after a (re)start before the variance estimate starts
        (8: "starts on the ninth measurement").
    variance_samples : samples in the variance estimate before the detector
        tests (>= 1; see the module notes).
    t0, times : sample times: ``times`` (N,) if given, else ``t0 + n / fs``.
    block : samples per block of the batch kernels.
    combine : ``"sum"`` (the thesis: the channels' squared normalised
        innovations summed into one chi-square(C) Page-Hinkley test) or
        ``"channel"`` (one test per channel, a change when any fires; see the
        module notes).

    Raises UsageError for bad parameters and DataError (naming the field
    ``signal``) for a signal too short for the model or not finite.
    """
    _check_params(order, threshold, change_size, warmup, block)
    _check_combine(combine)
    if not isinstance(variance_samples, (int, np.integer)) or variance_samples < 1:
        raise UsageError(f"variance_samples must be an integer >= 1; got {variance_samples!r}")
    a = _as_signal(y)
    n, _ = a.shape
    need = min_samples(int(order), int(warmup), int(variance_samples))
    if n < need:
        raise DataError(f"signal has {n} samples; AR({order}) with a variance warm-up of "
                        f"{warmup} needs at least {need}", field="signal")
    times = _sample_times(n, fs=fs, t0=t0, times=times)
    channels = np.flatnonzero(np.ptp(a, axis=0) > 0)
    parameters = dict(order=int(order), threshold=float(threshold),
                      change_size=float(change_size), warmup=int(warmup),
                      variance_samples=int(variance_samples), fs=float(fs),
                      boundary="first sample of the new segment (PH last zero + 1)",
                      combine=combine)
    if combine == "channel":
        return _segment_channels(a, channels, times, parameters, block=int(block))
    statistic = np.full(n, np.nan)
    empty = np.empty(0, dtype=np.int64)
    if channels.size == 0:
        return Segmentation(empty, empty.copy(), empty.copy(), times, statistic, channels,
                            parameters)

    model = ARModel(order=int(order))
    p = model.order
    psi = np.ascontiguousarray(model.regressors(a[:, channels]))    # rows r <-> samples r + p
    target = np.ascontiguousarray(model.targets(a[:, channels]))
    rows = psi.shape[0]
    first_test = max(int(warmup), p) + int(variance_samples)   # see the module notes
    vcd = VarianceChangeDetector(q=float(change_size), dim=int(channels.size),
                                 threshold=float(threshold), sides="both")
    rls = SquareRootRLS(variance_warmup=int(warmup))
    ph = PageHinkley(threshold=float(threshold), sides=vcd.side_names)

    bounds, alarms, sides = [], [], []
    seg_start = 0                  # row at which estimators and detector (re)started
    pos = 0
    while pos < rows:
        end = min(pos + block, rows)
        res = rls.run(psi[pos:end], target[pos:end])
        chi2 = res.chi2.sum(axis=1)                          # NaN if any channel is
        since = np.arange(pos, end) - seg_start           # samples absorbed before this one
        valid = np.isfinite(chi2) & (since >= first_test)
        chi2[since < first_test] = np.nan
        inc = vcd.increments(np.where(valid, chi2, 0.0))
        inc[~valid] = 0.0          # detector held at 0 (its last zero) until chi2 exists
        found = ph.run(inc)
        if len(found) == 0:
            statistic[pos + p:end + p] = chi2
            pos = end
            continue
        a_row = seg_start + int(found.time[0])               # detector counts from seg_start
        change_row = seg_start + int(found.change_time[0])
        statistic[pos + p:a_row + 1 + p] = chi2[:a_row + 1 - pos]
        bounds.append(change_row + 1 + p)
        alarms.append(a_row + p)
        sides.append(int(found.side[0]))
        rls.reset()
        ph.reset()
        seg_start = pos = a_row + 1
    as_int = lambda v: np.asarray(v, dtype=np.int64)  # noqa: E731
    return Segmentation(as_int(bounds), as_int(alarms), as_int(sides), times, statistic,
                        channels, parameters)


def _segment_channels(a, channels, times, parameters, *, block: int) -> Segmentation:
    """``combine="channel"``: one two-sided (6.14, m = 1) Page-Hinkley test per channel.

    The same blocks, restarts and warm-up as the sum mode; the C detectors run
    as the detector axis of one :class:`PageHinkley` (numba kernel), and the
    first alarm of any of them (earliest sample, then lowest channel) restarts
    every estimator and detector.
    """
    n = a.shape[0]
    c = int(channels.size)
    order, warmup = parameters["order"], parameters["warmup"]
    q, threshold = parameters["change_size"], parameters["threshold"]
    statistic = np.full((n, c), np.nan)
    empty = np.empty(0, dtype=np.int64)
    if c == 0:
        return Segmentation(empty, empty.copy(), empty.copy(), times, statistic, channels,
                            parameters, empty.copy())
    model = ARModel(order=order)
    p = model.order
    psi = np.ascontiguousarray(model.regressors(a[:, channels]))    # rows r <-> samples r + p
    target = np.ascontiguousarray(model.targets(a[:, channels]))
    rows = psi.shape[0]
    first_test = max(warmup, p) + parameters["variance_samples"]
    rls = SquareRootRLS(variance_warmup=warmup)
    ph = PageHinkley(threshold=threshold, sides=VARIANCE_SIDES)

    bounds, alarms, sides, fired = [], [], [], []
    seg_start = 0
    pos = 0
    while pos < rows:
        end = min(pos + block, rows)
        res = rls.run(psi[pos:end], target[pos:end])
        chi2 = np.array(res.chi2, dtype=np.float64).reshape(end - pos, c)   # chi-square(1) each
        since = np.arange(pos, end) - seg_start
        early = since < first_test
        chi2[early] = np.nan
        valid = np.isfinite(chi2)
        inc = variance_increments(np.where(valid, chi2, 0.0), dim=1, q=q)   # (n, C, 2)
        inc[~valid] = 0.0          # each detector held at 0 until its chi2 exists
        found = ph.run(inc)
        if len(found) == 0:
            statistic[pos + p:end + p] = chi2
            pos = end
            continue
        a_row = seg_start + int(found.time[0])      # alarms come in (time, detector) order
        change_row = seg_start + int(found.change_time[0])
        statistic[pos + p:a_row + 1 + p] = chi2[:a_row + 1 - pos]
        bounds.append(change_row + 1 + p)
        alarms.append(a_row + p)
        sides.append(int(found.side[0]))
        fired.append(int(channels[int(found.detector[0])]))
        rls.reset()
        ph.reset()
        seg_start = pos = a_row + 1
    as_int = lambda v: np.asarray(v, dtype=np.int64)  # noqa: E731
    return Segmentation(as_int(bounds), as_int(alarms), as_int(sides), times, statistic,
                        channels, parameters, as_int(fired))


def segment_glr(y, *, fs: float, order: int = GLR_DEFAULTS["order"],
                threshold: float = GLR_DEFAULTS["threshold"],
                window_s: float = GLR_DEFAULTS["window_s"], t0: float = 0.0,
                times=None) -> Segmentation:
    """Segment ``y`` (N,) or (N, C) with the two-model AR GLR (:mod:`~contactlab.detection.ar_glr`).

    Offline: the whole signal is seen at once, so there is no alarm time; a
    boundary's ``alarms`` entry is the sample at which the window statistic
    could first have seen it (``boundary + window``, capped at the end) and
    ``sides`` says whether the channels' summed log residual variance rose (0)
    or fell (1) across it.  ``statistic`` is the window statistic per degree of
    freedom.  Constant channels are left out as in :func:`segment_signal`.
    """
    return segment_glr_sweep(y, [threshold], fs=fs, order=order, window_s=window_s, t0=t0,
                             times=times)[float(threshold)]


def segment_glr_sweep(y, thresholds, *, fs: float, order: int = GLR_DEFAULTS["order"],
                      window_s: float = GLR_DEFAULTS["window_s"], t0: float = 0.0,
                      times=None) -> dict[float, Segmentation]:
    """:func:`segment_glr` at each of ``thresholds``: ``{threshold: Segmentation}``.

    The window statistic is computed once and thresholded many times
    (:func:`contactlab.detection.ar_glr.glr_sweep`); each entry equals
    :func:`segment_glr` at that threshold.
    """
    levels = [float(t) if isinstance(t, (int, float, np.number)) else t for t in thresholds]
    for t in levels:
        _check_params(order, t, 2.0, 0, 1)
    a = _as_signal(y)
    n = a.shape[0]
    times = _sample_times(n, fs=fs, t0=t0, times=times)
    channels = np.flatnonzero(np.ptp(a, axis=0) > 0)
    empty = np.empty(0, dtype=np.int64)
    need = 4 * (int(order) + 2) + int(order)
    if n < need:
        raise DataError(f"signal has {n} samples; the AR({order}) GLR needs at least {need}",
                        field="signal")

    def parameters(threshold):
        return dict(method="glr", order=int(order), threshold=threshold,
                    window_s=float(window_s), fs=float(fs),
                    boundary="first sample of the new segment (maximum-likelihood split)")

    if channels.size == 0:
        return {t: Segmentation(empty, empty.copy(), empty.copy(), times, np.full(n, np.nan),
                                channels, parameters(t)) for t in levels}
    out = {}
    for t, found in glr_sweep(a[:, channels], levels, fs=fs, order=int(order),
                              window_s=float(window_s)).items():
        bounds = found["boundaries"]
        alarms = np.minimum(bounds + found["window"], n - 1)
        out[t] = Segmentation(bounds.astype(np.int64), alarms.astype(np.int64),
                              found["sides"], times, found["statistic"], channels,
                              {**parameters(t), "window": int(found["window"])})
    return out


def segment_level(y, *, fs: float, threshold: float = LEVEL_DEFAULTS["fraction"],
                  window_s: float = LEVEL_DEFAULTS["window_s"], times=None,
                  t0: float = 0.0) -> Segmentation:
    """Segment a wrench ``y`` (N, 3 or 6: force first, N) at its level changes
    (:mod:`contactlab.detection.level_shift`): contact made and broken, phases that
    press harder or less; excursions that return to their level inside a phase come
    back apart as ``events``.  ``threshold`` is the share of the recording's largest
    level changes a change must reach; ``window_s`` the two-window test's half width.

    ``sides`` are 0 (``increase``) where the force level moves away from the free-space
    level (the recording's first ``window_s``), 1 (``decrease``) where it comes back.
    The torques are not used: their size depends on the tool's length.
    """
    a = _as_signal(y)
    if a.shape[1] not in (3, 6):
        raise UsageError(f"the level test reads a force (3 columns) or a wrench (6); got "
                         f"{a.shape[1]} columns")
    if not (math.isfinite(threshold) and 0 < threshold <= 1):
        raise UsageError(f"the level test's threshold (--threshold, each --sweep value) is a "
                         f"share of the largest level changes, in (0, 1]; got {threshold!r}")
    if not (math.isfinite(window_s) and window_s > 0):
        raise UsageError(f"window must be > 0 s; got {window_s!r}")
    tt = _sample_times(len(a), fs=fs, t0=t0, times=times)
    r = level_changes(a[:, :3], fs=fs, fraction=threshold, window_s=window_s)
    return Segmentation(
        boundaries=r.boundaries, alarms=r.peaks,
        sides=np.where(r.away, 0, 1).astype(np.int64), times=tt,
        statistic=r.statistic, channels=np.arange(3),
        parameters={"method": "level", "threshold": float(threshold),
                    "window_s": float(window_s), "fs": float(fs),
                    "level_threshold_n": r.threshold, "noise_sd_n": r.noise_sd,
                    **{k: v for k, v in LEVEL_DEFAULTS.items()
                       if k not in ("fraction", "window_s")}},
        events=r.events, event_ends=r.event_ends)


def _segment_any(y, *, fs, method, threshold, order, change_size, warmup, combine,
                 window_s, times, block=DEFAULT_BLOCK) -> Segmentation:
    """:func:`segment_glr`, :func:`segment_signal` or :func:`segment_level` by
    ``method`` (resolved, not ``auto``); ``threshold=None`` takes the method's default."""
    _check_method(method)
    if threshold is None:
        threshold = _DEFAULT_THRESHOLDS[method]
    if method == "level":
        return segment_level(y, fs=fs, threshold=threshold, times=times,
                             window_s=LEVEL_DEFAULTS["window_s"] if window_s is None
                             else window_s)
    if method == "glr":
        return segment_glr(y, fs=fs, order=order, threshold=threshold,
                           window_s=GLR_DEFAULTS["window_s"] if window_s is None else window_s,
                           times=times)
    seg = segment_signal(y, fs=fs, order=order, threshold=threshold, change_size=change_size,
                         warmup=warmup, times=times, block=block, combine=combine)
    seg.parameters["method"] = "page-hinkley"
    return seg


def segment_trial(trial, *, signal: str | None = None, order: int = D.SEGMENT_ORDER,
                  threshold: float | None = None, change_size: float = D.CHANGE_SIZE,
                  warmup: int = D.WARMUP, block: int = DEFAULT_BLOCK, combine: str = "sum",
                  method: str = DEFAULT_METHOD, window_s: float | None = None) -> Segmentation:
    """Segment one archive trial's conditioned ``signal`` (see
    :func:`contactlab.signals.condition`; default: strain if the trial has strain
    gauges, else wrench).

    ``method`` picks the detector (:data:`METHODS`; default :data:`DEFAULT_METHOD`);
    ``threshold=None`` is that method's default (:func:`default_threshold`);
    ``change_size``, ``warmup``, ``block`` and ``combine`` belong to
    ``page-hinkley``, ``window_s`` to ``glr``.
    Boundaries come back in seconds of the trial's time base.
    """
    signal = resolve_signal(trial, signal)
    method = resolve_method(method, signal)
    y, times, fs = conditioned_signal(trial, signal)
    try:
        seg = _segment_any(y, fs=fs, method=method, threshold=threshold, order=order,
                           change_size=change_size, warmup=warmup, combine=combine,
                           window_s=window_s, times=times, block=block)
    except DataError as err:
        raise DataError(f"{err.message} (after conditioning to "
                        f"{fs:g} Hz)",
                        field=f"/trials/{trial.id}/measurements/{source_of(signal)}") from None
    seg.parameters["signal"] = signal
    return seg


def sweep(y_or_trial, thresholds, *, fs: float | None = None, signal: str | None = None,
          method: str = "page-hinkley", **kwargs) -> dict[float, Segmentation]:
    """Segment at each of ``thresholds`` (fig 7.7): ``{threshold: Segmentation}``.

    The default method is the thesis's test, whose threshold sweep fig 7.7 shows
    (``segment --sweep`` passes the command's ``--method``, glr by default).
    ``y_or_trial`` is an array (then ``fs`` is required) or an archive trial
    (then ``signal`` picks the signal); ``kwargs`` go to :func:`segment_signal`
    (``method="page-hinkley"``) or :func:`segment_glr` (``method="glr"``).
    """
    _check_method(method)
    thresholds = [float(t) for t in thresholds]
    if not thresholds:
        raise UsageError("sweep needs at least one threshold")
    window_s = kwargs.pop("window_s", None)
    if method in ("glr", "level", "auto"):
        kwargs = {k: v for k, v in kwargs.items() if k == "order"}
        if window_s is not None:
            kwargs["window_s"] = window_s

    def run(y, method, **kw):      # glr: one window statistic for every threshold
        if method == "glr":
            return segment_glr_sweep(y, thresholds, **kw, **kwargs)
        if method == "level":
            return {t: segment_level(y, threshold=t, **kw,
                                     **({} if window_s is None else {"window_s": window_s}))
                    for t in thresholds}
        return {t: segment_signal(y, threshold=t, **kw, **kwargs) for t in thresholds}

    if isinstance(y_or_trial, np.ndarray) or np.ndim(y_or_trial) > 0:
        if fs is None:
            raise UsageError("sweep over an array needs fs")
        if method == "auto":
            raise UsageError("method 'auto' needs a trial (its signal decides); give the method")
        return run(y_or_trial, method, fs=fs)
    signal = resolve_signal(y_or_trial, signal)
    y, times, fs_out = conditioned_signal(y_or_trial, signal)
    out = run(y, resolve_method(method, signal), fs=fs_out, times=times)
    for seg in out.values():
        seg.parameters["signal"] = signal
    return out


def truth_boundaries_s(trial, label_map: dict | None = None) -> np.ndarray | None:
    """Ground-truth boundaries (s): every ``segments.start_s`` but the first; None if none.

    With ``label_map`` (a recording's label name -> state, as ``recognize --label-map``)
    the boundaries are where the per-sample labels' *state* changes: labels mapped to
    one state are one segment, and a change into or out of an unmapped or unlabelled
    stretch is no boundary."""
    if label_map:
        states = _mapped_states(trial, label_map)
        if states is None:
            return None
        k = np.flatnonzero(states[1:] != states[:-1]) + 1
        k = k[(states[k] >= 0) & (states[k - 1] >= 0)]
        return np.asarray(trial.time, dtype=np.float64)[k]
    seg = trial.segments
    if seg is None or len(seg) == 0:
        return None
    return np.asarray(seg["start_s"], dtype=np.float64)[1:]


def _mapped_states(trial, label_map: dict) -> np.ndarray | None:
    """Per input sample a state code under ``label_map`` (-1 unmapped or unlabelled);
    None when the trial has no per-sample labels."""
    labels = getattr(trial, "labels", None)
    names = getattr(trial, "label_names", None)
    if labels is None or names is None:
        return None
    targets = sorted(set(label_map.values()))
    code = np.array([targets.index(label_map[str(n)]) if str(n) in label_map else -1
                     for n in names] + [-1], dtype=np.int64)
    raw = np.asarray(labels, dtype=np.int64)
    return code[np.where((raw >= 0) & (raw < len(names)), raw, len(names))]


def labelled_only(trial, found_s, label_map: dict | None) -> np.ndarray:
    """``found_s`` without the boundaries that fall where ``label_map`` leaves the
    recording unlabelled (nothing to score them against); all of them without a map."""
    found_s = np.asarray(found_s, dtype=np.float64)
    if not label_map:
        return found_s
    states = _mapped_states(trial, label_map)
    if states is None:
        return found_s
    t = np.asarray(trial.time, dtype=np.float64)
    k = np.clip(np.searchsorted(t, found_s), 0, len(t) - 1)
    return found_s[states[k] >= 0]


def boundary_metrics(true_s, found_s, *, times, tolerance_s: float = 0.1) -> dict:
    """Boundary precision, recall and F1 within ``tolerance_s`` (ruptures' metric).

    Both sets of boundaries (seconds) are placed on the sample grid ``times``
    (nearest sample; duplicates and boundaries at the first sample or past the
    end dropped) and compared with ``ruptures.metrics.precision_recall`` with a
    margin of ``tolerance_s`` in samples (a found boundary matches a true one
    strictly closer than the margin; each found boundary matches at most one
    true one).  Precision with no boundary found is 0 (ruptures' convention);
    recall with no true boundary is undefined (None).
    """
    from ruptures.metrics import precision_recall

    times = np.asarray(times, dtype=np.float64)
    n = len(times)
    if n < 2:
        raise UsageError("boundary_metrics needs a time base of at least 2 samples")
    dt = float(np.median(np.diff(times)))
    if not tolerance_s > 0:
        raise UsageError(f"tolerance must be > 0 s; got {tolerance_s!r}")

    def to_index(s):
        s = np.asarray(s, dtype=np.float64).reshape(-1)
        idx = np.searchsorted(times, s - dt / 2)
        idx = np.unique(idx[(idx > 0) & (idx < n)])
        return [int(i) for i in idx] + [n]

    true_idx, found_idx = to_index(true_s), to_index(found_s)
    margin = max(tolerance_s / dt, 1e-9)
    out = {"tolerance_s": float(tolerance_s), "n_true": len(true_idx) - 1,
           "n_found": len(found_idx) - 1}
    if len(true_idx) == 1:
        out.update(precision=None, recall=None, f1=None)
        return out
    precision, recall = precision_recall(true_idx, found_idx, margin=margin)
    f1 = 2 * precision * recall / (precision + recall) if precision + recall > 0 else 0.0
    out.update(precision=float(precision), recall=float(recall), f1=float(f1))
    return out


# -- archives ------------------------------------------------------------------------------

def pooled_metrics(per_trial: list[dict], tolerance_s: float) -> dict | None:
    """Precision/recall/F1 over all trials, pooling matched, found and true counts.

    ``per_trial``: :func:`boundary_metrics` results; trials without ground
    truth (recall None) are skipped; None when no trial has any.
    """
    rows = [m for m in per_trial if m.get("recall") is not None]
    if not rows:
        return None
    matched = sum(round(m["recall"] * m["n_true"]) for m in rows)
    n_true = sum(m["n_true"] for m in rows)
    n_found = sum(m["n_found"] for m in rows)
    precision = matched / n_found if n_found else 0.0
    recall = matched / n_true if n_true else 0.0
    f1 = 2 * precision * recall / (precision + recall) if precision + recall > 0 else 0.0
    return {"tolerance_s": float(tolerance_s), "n_true": n_true, "n_found": n_found,
            "precision": precision, "recall": recall, "f1": f1, "trials": len(rows)}


_pooled = pooled_metrics          # the former private name


#: what ``boundaries_s``, ``change_s`` and ``alarm_s`` of results/segment mean, per method
_BOUNDARY_NOTE = {
    "page-hinkley": "boundaries_s: first sample of the new segment; change_s: Page-Hinkley "
                    "last zero (the sample before); alarm_s: detection time",
    "glr": "boundaries_s: first sample of the new segment (most likely split); change_s: "
           "the sample before; alarm_s: end of the window that first sees it (offline)",
    "level": "boundaries_s: where the force leaves (or regains) the level nearer free "
             "space; change_s: the sample before; alarm_s: the peak of the two-window "
             "level difference; events_s / event_ends_s: excursions inside a phase",
}


class SegmentStage(Stage):
    """``contactlab segment`` as a stage: the parameters of :func:`run_archive`."""

    name = "segment"

    def __init__(self, *, signal: str | None = None, order: int = D.SEGMENT_ORDER,
                 threshold: float | None = None, thresholds=None,
                 change_size: float = D.CHANGE_SIZE, warmup: int = D.WARMUP,
                 tolerance_s: float = D.TOLERANCE_S, write: bool = True, combine: str = "sum",
                 method: str = DEFAULT_METHOD, window_s: float | None = None,
                 label_map: dict | None = None):
        if signal is not None and signal not in SIGNALS:
            raise UsageError(f"signal must be one of {', '.join(SIGNALS)}; got {signal!r}")
        _check_method(method)
        threshold = default_threshold(method) if threshold is None else threshold
        _check_params(order, 1.0 if threshold is None else threshold, change_size, warmup,
                      DEFAULT_BLOCK)
        self.label_map = label_map
        _check_combine(combine)
        if method == "glr" and combine != "sum":
            raise UsageError("combine belongs to method page-hinkley (the glr test pools "
                             "its channels' likelihoods)")
        self.method, self.window_s = method, window_s
        self.levels = None if thresholds is None else [float(t) for t in thresholds]
        for t in self.levels or []:
            _check_params(order, t, change_size, warmup, DEFAULT_BLOCK)
        self.signal, self.order = signal, order
        self.threshold = None if threshold is None else float(threshold)
        self.change_size, self.warmup, self.combine = change_size, warmup, combine
        self.tolerance_s = tolerance_s
        self.write = bool(write) and self.levels is None

    def run_trial(self, trial) -> TrialOutcome:
        """Segment one trial (each sweep level); its entry, metrics and results."""
        kw = dict(signal=self.signal, order=self.order, change_size=self.change_size,
                  warmup=self.warmup, combine=self.combine, method=self.method,
                  window_s=self.window_s)
        if self.levels is None:
            by_level = {self.threshold: segment_trial(trial, threshold=self.threshold, **kw)}
        else:
            by_level = sweep(trial, self.levels, **kw)
        truth = truth_boundaries_s(trial, self.label_map)
        entry: dict = {}
        metrics: dict = {}
        for level, seg in by_level.items():
            d = seg.as_dict()
            d["method"] = seg.parameters.get("method", "page-hinkley")
            if truth is not None:
                found = labelled_only(trial, seg.boundaries_s, self.label_map)
                metrics[level] = boundary_metrics(truth, found, times=seg.times,
                                                  tolerance_s=self.tolerance_s)
                if self.levels is not None:
                    d["metrics"] = metrics[level]
            if self.levels is None:
                entry = d
            else:
                entry.setdefault("sweep", {})[f"{level:g}"] = d
        results = None
        if self.levels is None:
            seg = by_level[self.threshold]
            datasets = {"boundaries_s": seg.boundaries_s, "change_s": seg.change_s,
                        "alarm_s": seg.alarms_s,
                        "sides": seg.sides.astype(np.int8), "boundaries": seg.boundaries,
                        "alarms": seg.alarms, "statistic": seg.statistic,
                        "statistic_time_s": seg.times}
            if self.combine == "channel":
                datasets["alarm_channels"] = seg.alarm_channels
            if seg.parameters.get("method") == "level":
                datasets["events_s"] = seg.events_s
                datasets["event_ends_s"] = seg.times[seg.event_ends]
            results = TrialResults(
                datasets,
                attrs={"side_names": list(SIDES), "signal": seg.parameters["signal"],
                       "boundary": _BOUNDARY_NOTE[seg.parameters.get("method",
                                                                      "page-hinkley")]},
                parameters={**seg.parameters, "channels": seg.channels.tolist()})
        from contactlab.observer.kinematics import trial_label_names

        return TrialOutcome(entry, results, {"metrics": metrics,
                                             "label_names": trial_label_names(trial)})

    def summarize(self, path, outcomes: dict[str, TrialOutcome]) -> dict:
        """Per-trial entries and, with ground truth, metrics pooled over trials; ``notes``:
        --label-map entries whose label no trial carries."""
        from contactlab.observer.kinematics import unmatched_map_note

        summary: dict = {"trials": {tid: o.entry for tid, o in outcomes.items()}}
        seen = {n for o in outcomes.values() for n in (o.extra.get("label_names") or [])}
        notes = unmatched_map_note(self.label_map, seen, Path(path).name) if seen else []
        if notes:
            summary["notes"] = notes
        by_level: dict[float, list] = {}
        for o in outcomes.values():
            for level, m in o.extra["metrics"].items():
                by_level.setdefault(level, []).append(m)
        if not by_level:
            return summary
        if self.levels is None:
            pooled = pooled_metrics(by_level[self.threshold], self.tolerance_s)
            if pooled is not None:
                summary["metrics"] = {"overall": pooled, "trials": {
                    tid: o.extra["metrics"][self.threshold] for tid, o in outcomes.items()
                    if self.threshold in o.extra["metrics"]}}
        else:
            pooled = {f"{lv:g}": pooled_metrics(ms, self.tolerance_s)
                      for lv, ms in by_level.items()}
            pooled = {k: v for k, v in pooled.items() if v is not None}
            if pooled:
                summary["metrics"] = pooled
        return summary


def run_archive(path, *, signal: str | None = None, order: int = D.SEGMENT_ORDER,
                threshold: float | None = None, thresholds=None,
                change_size: float = D.CHANGE_SIZE, warmup: int = D.WARMUP,
                tolerance_s: float = D.TOLERANCE_S, trials=None, quiet: bool = True,
                write: bool = True, combine: str = "sum", method: str = DEFAULT_METHOD,
                window_s: float | None = None, workers: int = 1,
                scheduler: str | None = None) -> dict:
    """Segment the trials of the archive ``path`` (``contactlab segment``).

    Without ``thresholds``: every trial (or those named in ``trials``) is
    segmented at ``threshold`` and, if ``write``, its results are stored in
    ``results/segment``: ``boundaries_s``, ``change_s`` (alarm times),
    ``sides`` (0 increase, 1 decrease; names in the ``side_names``
    attribute), ``boundaries`` / ``alarms`` (indices into the conditioned
    signal), ``statistic`` and ``statistic_time_s`` (the detector's input, see
    :class:`Segmentation`; ``combine="channel"`` also stores ``alarm_channels``),
    with the parameters.  With ``thresholds`` (a sweep, fig 7.7) nothing is
    written.  All trials' results are written in one atomic step
    (:func:`contactlab.stages.run_stage`; ``workers`` / ``scheduler`` as there).

    ``method`` picks the detector (:data:`METHODS`, default :data:`DEFAULT_METHOD`),
    ``threshold=None`` its default threshold; ``window_s`` is the GLR's window.

    Returns ``{"trials": {id: {...}}, "metrics": {...}}``; ``metrics`` only
    when some trial has ground-truth segments (pooled over trials, and per
    trial under ``metrics["trials"]``; per threshold for a sweep).
    """
    stage = SegmentStage(signal=signal, order=order, threshold=threshold,
                         thresholds=thresholds, change_size=change_size, warmup=warmup,
                         tolerance_s=tolerance_s, write=write, combine=combine,
                         method=method, window_s=window_s)
    return run_stage(stage, [path], trials=trials, workers=workers, scheduler=scheduler,
                     quiet=quiet)[Path(path)]
