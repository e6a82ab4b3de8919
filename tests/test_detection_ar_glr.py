"""The two-model AR GLR (contactlab.detection.ar_glr) against brute-force numpy fits."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.signal import lfilter

from contactlab.detection.ar_glr import (
    GLR_DEFAULTS, ARPrefix, glr_segment, glr_window_statistic, segment_glr_statistic)
from contactlab.segmentation import boundary_metrics, pooled_metrics, segment_signal
from contactlab.synthetic import piecewise_ar


def _lstsq_rss(y, start, end, p):
    """RSS of the AR(p)-with-intercept least-squares fit to rows [start, end) (row r is
    sample r + p), one channel, by numpy.linalg.lstsq on the explicit regressors."""
    t = np.arange(start, end) + p
    x = np.column_stack([y[t - i] for i in range(1, p + 1)] + [np.ones(len(t))])
    beta, *_ = np.linalg.lstsq(x, y[t], rcond=None)
    r = y[t] - x @ beta
    return float(r @ r)


def _brute_glr(y, a, t, b, p):
    """Twice the log GLR (*) summed over channels, from lstsq fits."""
    total = 0.0
    for c in range(y.shape[1]):
        def ll(s, e):
            return -0.5 * (e - s) * np.log(_lstsq_rss(y[:, c], s, e, p) / (e - s))
        total += 2 * (ll(a, t) + ll(t, b) - ll(a, b))
    return total


def _ar(n, c, seed, a=(1.2, -0.6)):
    rng = np.random.default_rng(seed)
    return lfilter([1.0], [1.0, -a[0], -a[1]], rng.standard_normal((n, c)), axis=0) + 3.0


def test_prefix_rss_matches_lstsq():
    y = _ar(300, 3, 1)
    for p in (1, 2, 3):
        pre = ARPrefix(y, order=p)
        for start, end in [(0, 40), (17, 120), (100, pre.rows)]:
            got = pre.rss(start, end)
            want = [_lstsq_rss(y[:, c], start, end, p) for c in range(3)]
            assert np.allclose(got, want, rtol=1e-8)


def test_window_statistic_matches_brute_force():
    y = _ar(160, 2, 2)
    y[80:] = _ar(80, 2, 3, a=(0.2, -0.5))[:, :2]      # a coefficient change at sample 80
    p, w = 2, 24
    pre = ARPrefix(y, order=p)
    stat = glr_window_statistic(pre, w)
    half = w // 2
    for t in (half, 40, 78, 100, pre.rows - half):
        a, b = max(t - w, 0), min(t + w, pre.rows)
        assert stat[t] == pytest.approx(_brute_glr(y, a, t, b, p) / pre.dof, rel=1e-7)
    assert np.isnan(stat[:half]).all() and np.isnan(stat[pre.rows - half + 1:]).all()
    # the statistic peaks at the change (row 78 = sample 80)
    assert abs(int(np.nanargmax(stat)) - 78) <= 4


def test_refined_split_is_the_brute_force_maximum():
    y = _ar(200, 2, 4)
    y[120:] = _ar(80, 2, 5, a=(-0.3, 0.2))[:, :2]
    pre = ARPrefix(y, order=2)
    t, d = segment_glr_statistic(pre, 0, pre.rows, 20, 180)
    brute = [_brute_glr(y, 0, s, pre.rows, 2) / pre.dof for s in t]
    assert np.allclose(d, brute, rtol=1e-7)
    found = glr_segment(y, fs=250.0, window_s=0.2, threshold=3.0)["boundaries"]
    assert found.tolist() == [int(t[np.argmax(brute)]) + 2]


def test_no_change_statistic_is_chi_square_per_dof():
    """At a fixed split, twice the log GLR is asymptotically chi-square(C (p + 2))."""
    c, p, w = 4, 2, 150
    vals = []
    for seed in range(300):
        y = _ar(2 * w + p, c, 100 + seed)
        pre = ARPrefix(y, order=p)
        vals.append(float(pre.glr(0, w, 2 * w)))
    dof = c * (p + 2)
    assert np.mean(vals) / dof == pytest.approx(1.0, abs=0.12)
    assert np.var(vals) / (2 * dof) == pytest.approx(1.0, abs=0.35)


def test_stationary_signal_has_no_boundary_at_the_defaults():
    for seed in range(4):
        y = _ar(1500, 8, 200 + seed)             # 6 s at 250 Hz
        assert len(glr_segment(y, fs=250.0)["boundaries"]) == 0


def test_coefficient_only_changes_found_where_the_thesis_test_misses_them():
    """Small case of the benchmark suite: coefficient-only changes, 250 Hz copy."""
    glr, ph = [], []
    for seed in range(3):
        trial = piecewise_ar(seed=seed, kinds=("coefficients",))
        y, fs = trial.lowpassed()
        times = np.arange(len(y)) / fs
        found = glr_segment(y, fs=fs)["boundaries"] / fs
        glr.append(boundary_metrics(trial.boundaries_s, found, times=times, tolerance_s=0.05))
        thesis = segment_signal(y, fs=fs).boundaries_s
        ph.append(boundary_metrics(trial.boundaries_s, thesis, times=times, tolerance_s=0.05))
    assert pooled_metrics(glr, 0.05)["f1"] >= 0.95
    assert pooled_metrics(ph, 0.05)["recall"] < 0.6


def test_defaults_and_bad_parameters():
    assert GLR_DEFAULTS["order"] == 2
    y = _ar(300, 2, 9)
    with pytest.raises(Exception, match="window"):
        glr_segment(y, fs=250.0, window_s=0.0)
    with pytest.raises(Exception, match="threshold"):
        glr_segment(y, fs=250.0, threshold=-1.0)
    # a constant channel does not break the fit (flat windows are solvable)
    y[:, 1] = 2.0
    assert np.isfinite(glr_segment(y[:, :], fs=250.0)["statistic"][50:250]).all()
