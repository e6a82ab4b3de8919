"""Change detection on innovations: section 6.3.1 of the thesis.

- :mod:`~contactlab.detection.increments` -- log-likelihood-ratio increments:
  change in covariance size (6.14) on ``nu^T V^-1 nu`` (6.11), both directions;
  change in mean of a scalar Gaussian signal.
- :mod:`~contactlab.detection.page_hinkley` -- the Page-Hinkley / CUSUM
  decision function (6.15)-(6.18) with threshold ``T^2`` (6.16), change-time
  estimate (last zero, fig 6.4) and reset, for many detectors at once;
  streaming (:meth:`PageHinkley.update`) and batch (:meth:`PageHinkley.run`).
- :mod:`~contactlab.detection.cusum` -- the compiled recursion (6.18) itself,
  :func:`cusum_step`, shared by the detector, the observer and the ROC Monte Carlo.
- :mod:`~contactlab.detection.lowpass` -- the lowpass + threshold detector the
  thesis compares against (fig 6.6).
- :mod:`~contactlab.detection.roc` -- Wald / Siegmund / Hall approximations of
  the false-alarm time and detection delay, and Monte Carlo estimates.
"""

from contactlab.detection.alarms import Alarms
from contactlab.detection.increments import (
    MEAN_SIDES,
    VARIANCE_SIDES,
    chi_square,
    mean_increment,
    mean_increments,
    variance_increment,
    variance_increments,
)
from contactlab.detection.lowpass import LowpassThreshold, stationary_variance
from contactlab.detection.page_hinkley import (
    MeanChangeDetector,
    PageHinkley,
    VarianceChangeDetector,
)
from contactlab.detection.cusum import cusum_step

__all__ = [
    "Alarms",
    "LowpassThreshold",
    "MEAN_SIDES",
    "MeanChangeDetector",
    "PageHinkley",
    "VARIANCE_SIDES",
    "VarianceChangeDetector",
    "chi_square",
    "cusum_step",
    "mean_increment",
    "mean_increments",
    "stationary_variance",
    "variance_increment",
    "variance_increments",
]
