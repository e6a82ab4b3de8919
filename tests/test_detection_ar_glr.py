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


# -- memory: kept prefix sums and blocks give the numbers of all prefix sums ------------

class _AllPrefixes:
    """Every prefix sum held at once, (rows + 1, C, p + 2, p + 2), summed by numpy's
    sequential cumsum; segments solved by the same elimination kernel: the layout
    ARPrefix kept before it held only every 16th sum and swept the rows in blocks."""

    def __init__(self, y, *, order=2):
        from contactlab.detection import ar_glr

        a = np.asarray(y, dtype=np.float64).reshape(len(y), -1)
        a = a - a.mean(axis=0)
        p = order
        z = np.stack([a[p - 1 - i:len(a) - 1 - i] for i in range(p)]
                     + [np.ones((len(a) - p, a.shape[1])), a[p:]], axis=-1)
        outer = z[..., :, None] * z[..., None, :]
        self.prefix = np.concatenate([np.zeros((1,) + outer.shape[1:]),
                                      np.cumsum(outer, axis=0)])
        self.order, self.rows, self.channels = p, len(a) - p, a.shape[1]
        self.dof = self.channels * (p + 2)
        self._kernel = ar_glr._rss_kernel

    def rss(self, start, end):
        start, end = np.broadcast_arrays(np.asarray(start, np.int64), np.asarray(end, np.int64))
        out = np.empty(start.shape + (self.channels,))
        self._kernel(self.prefix, start.reshape(-1), end.reshape(-1),
                     out.reshape(-1, self.channels))
        return out

    def loglik(self, start, end):
        start, end = np.broadcast_arrays(np.asarray(start), np.asarray(end))
        m = (end - start).astype(np.float64)
        return -0.5 * m * np.sum(np.log(self.rss(start, end) / m[..., None]), axis=-1)

    def logliks(self, segments):
        return [self.loglik(s, e) for s, e in segments]

    def glr(self, start, split, end):
        return 2.0 * (self.loglik(start, split) + self.loglik(split, end)
                      - self.loglik(start, end))

    def _rss_sets(self, segments):
        return [self.rss(s, e) for s, e in segments]


def _changing(n, c, seed):
    y = _ar(n, c, seed)
    y[n // 3:] *= 2.5
    y[2 * n // 3:] = _ar(n - 2 * n // 3, c, seed + 1, a=(0.3, -0.4))
    return y


@pytest.mark.parametrize("n, c, p", [(9000, 8, 2), (700, 3, 1), (5000, 1, 3)])
def test_kept_prefix_sums_give_every_number_of_all_prefix_sums(n, c, p, monkeypatch):
    """Bit for bit: rss of random segments, the window statistic and the segmentation
    (blocks of 4096 rows cross the 9000-row signal twice)."""
    from contactlab.detection import ar_glr

    y = _changing(n, c, 11)
    rng = np.random.default_rng(3)
    start = rng.integers(0, n - p - 40, 300)
    end = start + rng.integers(2 * (p + 2), 40, 300)
    full = _AllPrefixes(y, order=p)
    for step in (1, 7, ar_glr.CHECKPOINT_ROWS):
        assert np.array_equal(ARPrefix(y, order=p, checkpoint_rows=step).rss(start, end),
                              full.rss(start, end))
    kept = ARPrefix(y, order=p)
    assert np.array_equal(glr_window_statistic(kept, 60), glr_window_statistic(full, 60),
                          equal_nan=True)
    block = ar_glr._BLOCK_ROWS * c * (p + 2) ** 2 * 8      # a short signal keeps its own
    assert kept._checkpoints.nbytes <= max(full.prefix.nbytes / ar_glr.CHECKPOINT_ROWS + 1024,
                                           block)
    new = ar_glr.glr_sweep(y, [1.5, 3.0], fs=250.0, order=p)
    monkeypatch.setattr(ar_glr, "ARPrefix", _AllPrefixes)
    old = ar_glr.glr_sweep(y, [1.5, 3.0], fs=250.0, order=p)
    for t in (1.5, 3.0):
        for key in old[t]:
            assert np.array_equal(np.asarray(new[t][key]), np.asarray(old[t][key]),
                                  equal_nan=True), (t, key)


def test_a_sweep_computes_the_statistic_once_and_equals_single_runs(monkeypatch):
    from contactlab.detection import ar_glr
    from contactlab.segmentation import segment_glr, sweep

    y = _changing(3000, 4, 21)
    calls = []
    original = ar_glr.glr_window_statistic
    monkeypatch.setattr(ar_glr, "glr_window_statistic",
                        lambda *a, **k: calls.append(1) or original(*a, **k))
    levels = [1.5, 2.0, 3.0, 6.0]
    many = sweep(y, levels, fs=250.0, method="glr")
    assert len(calls) == 1
    for t in levels:
        one = segment_glr(y, fs=250.0, threshold=t)
        assert np.array_equal(many[t].boundaries, one.boundaries)
        assert np.array_equal(many[t].statistic, one.statistic, equal_nan=True)
        assert many[t].parameters == one.parameters
        single = glr_segment(y, fs=250.0, threshold=t)
        assert np.array_equal(single["score"], ar_glr.glr_sweep(y, [t], fs=250.0)[t]["score"])
