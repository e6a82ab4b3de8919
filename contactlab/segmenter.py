"""A change-point segmenter with the interface of ruptures and scikit-learn.

:class:`Segmenter` wraps the segmenters of :mod:`contactlab.segmentation`
(:func:`~contactlab.segmentation.segment_level`,
:func:`~contactlab.segmentation.segment_glr` and
:func:`~contactlab.segmentation.segment_signal`) behind the estimator
conventions a notebook user knows:

- the constructor only stores its parameters (scikit-learn's convention; they
  are checked when :meth:`Segmenter.fit` runs), and ``get_params`` /
  ``set_params`` / ``clone`` work;
- :meth:`Segmenter.fit` segments a signal and stores the results as attributes
  whose names end in an underscore (``boundaries_``, ``events_``,
  ``segmentation_``, ...);
- :meth:`Segmenter.predict` returns the boundaries in ruptures' convention: a
  list of sample indices, each the end (exclusive) of a segment, the last one
  being the number of samples; so ``signal[a:b]`` for consecutive entries
  ``a, b`` of ``[0] + predict()`` is one segment, and
  ``ruptures.metrics.precision_recall`` or ``ruptures.metrics.hausdorff``
  compare it with a true segmentation directly.

Example
-------
>>> import numpy as np
>>> from contactlab.segmenter import Segmenter
>>> rng = np.random.default_rng(0)
>>> force = np.zeros((1000, 3))
>>> force[400:700, 2] = 1.0                   # a press between 0.8 and 1.4 s
>>> force += rng.normal(0, 0.02, force.shape)
>>> Segmenter(method="level").fit_predict(force, fs=500.0)   # doctest: +SKIP
[400, 700, 1000]

No algorithm lives here: every method calls the function of
:mod:`contactlab.segmentation` that ``contactlab segment`` runs, so the
boundaries are those of the function with the same parameters.
"""

from __future__ import annotations

import numpy as np
from sklearn.base import BaseEstimator

from contactlab import defaults as D
from contactlab.detection.ar_glr import GLR_DEFAULTS
from contactlab.detection.level_shift import LEVEL_DEFAULTS
from contactlab.errors import UsageError
from contactlab.segmentation import (DEFAULT_BLOCK, Segmentation, segment_glr, segment_level,
                                     segment_signal)

__all__ = ["Segmenter", "SEGMENTER_METHODS"]

#: the methods of :class:`Segmenter`: ``level`` (level changes of a wrist force),
#: ``glr`` (the two-model AR likelihood-ratio test for strains) and ``page-hinkley``
#: (the thesis's AR estimators and Page-Hinkley test, 7.2.1)
SEGMENTER_METHODS = ("level", "glr", "page-hinkley")


class Segmenter(BaseEstimator):
    """Segment a signal at its change points, ruptures-style.

    Parameters
    ----------
    method : {"level", "glr", "page-hinkley"}
        ``"level"``: :func:`~contactlab.segmentation.segment_level`, the level
        test for a force (N, 3) or wrench (N, 6), force first; ``"glr"``:
        :func:`~contactlab.segmentation.segment_glr`, the offline two-model AR
        likelihood-ratio test for a vibration such as strains (N,) or (N, C);
        ``"page-hinkley"``: :func:`~contactlab.segmentation.segment_signal`,
        the thesis's sequential test (figure 7.6).
    threshold : float, optional
        The method's decision threshold; None takes its default (``level``:
        the share of the largest level changes a change must reach, in
        (0, 1]; ``glr``: the window statistic per degree of freedom;
        ``page-hinkley``: ``T^2``).
    order : int, optional
        AR order of ``glr`` and ``page-hinkley``; None takes the method's
        default.  Not used by ``level``.
    window_s : float, optional
        Window half width in seconds of ``level`` and ``glr``; None takes the
        method's default.  Not used by ``page-hinkley``.
    change_size : float
        ``page-hinkley`` only: the covariance change ``q`` tested in both
        directions.
    warmup : int
        ``page-hinkley`` only: samples after a (re)start before the variance
        estimate starts.
    combine : {"sum", "channel"}
        ``page-hinkley`` only: one chi-square test over the channels, or one
        test per channel.

    Attributes
    ----------
    segmentation_ : Segmentation
        The full result of the wrapped function (alarms, sides, statistic,
        parameters).
    boundaries_ : numpy.ndarray
        (K,) int64, the first sample of each new segment; equal to the end
        (exclusive) of the segment before it.
    boundaries_s_ : numpy.ndarray
        (K,) the boundaries as times in seconds.
    events_ : numpy.ndarray
        (E,) int64, ``level`` only: the first sample of each excursion inside a
        phase (a dip or bump that returns to its level); empty for the other
        methods.
    event_ends_ : numpy.ndarray
        (E,) int64, the sample at which each excursion ends.
    n_samples_ : int
        Samples of the signal passed to :meth:`fit`.
    fs_ : float
        Its sampling rate in Hz.

    See Also
    --------
    contactlab.segmentation.segment_level, contactlab.segmentation.segment_glr,
    contactlab.segmentation.segment_signal

    Examples
    --------
    >>> seg = Segmenter(method="glr", threshold=5.0)
    >>> seg.get_params()["threshold"]
    5.0
    """

    def __init__(self, method: str = "level", *, threshold: float | None = None,
                 order: int | None = None, window_s: float | None = None,
                 change_size: float = D.CHANGE_SIZE, warmup: int = D.WARMUP,
                 combine: str = "sum"):
        self.method = method
        self.threshold = threshold
        self.order = order
        self.window_s = window_s
        self.change_size = change_size
        self.warmup = warmup
        self.combine = combine

    def _segment(self, signal, fs, times) -> Segmentation:
        if self.method not in SEGMENTER_METHODS:
            raise UsageError(f"method must be one of {', '.join(SEGMENTER_METHODS)}; "
                             f"got {self.method!r}")
        if fs is None or not np.isfinite(fs) or fs <= 0:
            raise UsageError(f"fs (the sampling rate in Hz) must be a number > 0; got {fs!r}")
        kw = {} if self.threshold is None else {"threshold": self.threshold}
        if self.method == "level":
            return segment_level(signal, fs=fs, times=times,
                                 window_s=(LEVEL_DEFAULTS["window_s"] if self.window_s is None
                                           else self.window_s), **kw)
        if self.method == "glr":
            return segment_glr(signal, fs=fs, times=times,
                               order=GLR_DEFAULTS["order"] if self.order is None else self.order,
                               window_s=(GLR_DEFAULTS["window_s"] if self.window_s is None
                                         else self.window_s), **kw)
        return segment_signal(signal, fs=fs, times=times,
                              order=D.SEGMENT_ORDER if self.order is None else self.order,
                              change_size=self.change_size, warmup=self.warmup,
                              combine=self.combine, block=DEFAULT_BLOCK, **kw)

    def fit(self, signal, *, fs: float, times=None) -> "Segmenter":
        """Segment ``signal`` and store the results.

        Parameters
        ----------
        signal : array_like
            (N,) or (N, C), time first.  ``level`` needs C = 3 (a force) or
            C = 6 (a wrench, force first).
        fs : float
            Sampling rate in Hz (the windows are given in seconds).
        times : array_like, optional
            (N,) sample times in seconds for ``boundaries_s_``; default
            ``n / fs``.

        Returns
        -------
        Segmenter
            ``self``.
        """
        seg = self._segment(signal, fs, times)
        self.segmentation_ = seg
        self.boundaries_ = seg.boundaries.copy()
        self.boundaries_s_ = seg.boundaries_s
        self.events_ = seg.events.copy()
        self.event_ends_ = seg.event_ends.copy()
        self.n_samples_ = int(len(seg.times))
        self.fs_ = float(fs)
        return self

    def predict(self) -> list[int]:
        """The boundaries in ruptures' convention.

        Returns
        -------
        list of int
            The end (exclusive) of every segment: ``boundaries_`` followed by
            the number of samples.
        """
        if not hasattr(self, "boundaries_"):
            raise UsageError("this Segmenter is not fitted yet; call fit(signal, fs=...) first")
        return [int(b) for b in self.boundaries_] + [self.n_samples_]

    def fit_predict(self, signal, *, fs: float, times=None) -> list[int]:
        """:meth:`fit` then :meth:`predict`.

        Parameters
        ----------
        signal : array_like
            As for :meth:`fit`.
        fs : float
            Sampling rate in Hz.
        times : array_like, optional
            Sample times in seconds.

        Returns
        -------
        list of int
            As :meth:`predict`.
        """
        return self.fit(signal, fs=fs, times=times).predict()
