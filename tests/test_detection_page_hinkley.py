"""Page-Hinkley (6.15)-(6.18): batch = streaming = (6.17), brute-force oracle, resets."""

from __future__ import annotations

import numpy as np
import pytest

from contactlab.detection import (
    Alarms,
    MeanChangeDetector,
    PageHinkley,
    VarianceChangeDetector,
    mean_increment,
)


def _stream(ph: PageHinkley, x: np.ndarray) -> tuple[Alarms, np.ndarray]:
    parts, stats = [], []
    for row in x:
        parts.append(ph.update(row))
        stats.append(ph.statistic_.copy())
    return Alarms.concat(parts), np.array(stats)


def _same(a: Alarms, b: Alarms) -> None:
    assert len(a) == len(b)
    np.testing.assert_array_equal(a.time, b.time)
    np.testing.assert_array_equal(a.detector, b.detector)
    np.testing.assert_array_equal(a.side, b.side)
    np.testing.assert_array_equal(a.change_time, b.change_time)


@pytest.fixture
def increments():
    # drift slightly negative (H0-like) with a mean change in the middle, 2 sides
    rng = np.random.default_rng(7)
    x = rng.normal(-0.3, 1.0, size=(3000, 6, 2))
    x[1500:, :, 0] += 0.8
    return x


THRESHOLDS = np.array([2.0, 4.0, 6.0, 9.0, 14.0, 1e9])


def test_batch_streaming_chunked_and_cumsum_forms_agree(increments):
    stream, stats = _stream(PageHinkley(threshold=THRESHOLDS, sides=("a", "b")), increments)
    assert len(stream) > 100 and set(stream.side) == {0, 1}
    # one batch call (numba): bit-identical
    ph = PageHinkley(threshold=THRESHOLDS, sides=("a", "b"))
    batch = ph.run(increments, trace=True)
    _same(batch, stream)
    np.testing.assert_array_equal(batch.trace, stats)
    # chunks of uneven size carry the state across calls
    ph2 = PageHinkley(threshold=THRESHOLDS, sides=("a", "b"))
    chunks = [ph2.run(increments[i:j]) for i, j in [(0, 1), (1, 700), (700, 701), (701, 3000)]]
    _same(Alarms.concat(chunks), stream)
    np.testing.assert_array_equal(ph2.df_, ph.df_)
    np.testing.assert_array_equal(ph2.last_zero_, ph.last_zero_)
    assert ph2.n_seen_ == 3000
    # the cumulative-sum form (6.17), looping over alarms only, in chunks too
    ph3 = PageHinkley(threshold=THRESHOLDS, sides=("a", "b"), engine="numpy")
    parts = [ph3.run(increments[:1234], trace=True), ph3.run(increments[1234:], trace=True)]
    _same(Alarms.concat(parts), stream)
    np.testing.assert_allclose(np.concatenate([p.trace for p in parts]), stats, atol=1e-9)
    np.testing.assert_array_equal(ph3.last_zero_, ph.last_zero_)
    np.testing.assert_allclose(ph3.statistic_, ph.statistic_, atol=1e-9)


def _oracle(x: np.ndarray, threshold: float) -> tuple[np.ndarray, list[tuple[int, int]]]:
    """DF(n) = max(0, max_{start <= r <= n} sum_{t=r}^n Xi(t)) by brute force (6.15),
    restarting at the sample after each alarm; alarm when DF > threshold; the change
    estimate is the last n with DF(n) = 0 (or the reset point)."""
    df = np.empty(x.size)
    alarms = []
    start, last_zero = 0, -1
    for n in range(x.size):
        sums = [x[r:n + 1].sum() for r in range(start, n + 1)]
        df[n] = max(0.0, max(sums))
        if df[n] == 0.0:
            last_zero = n
        if df[n] > threshold:
            alarms.append((n, last_zero))
            start, last_zero = n + 1, n
    return df, alarms


@pytest.mark.parametrize("threshold", [np.inf, 5.0])
def test_decision_function_equals_brute_force_definition(threshold):
    rng = np.random.default_rng(3)
    x = rng.normal(-0.2, 1.0, size=400)
    x[200:] += 0.9
    df_oracle, alarms_oracle = _oracle(x, threshold)
    al = PageHinkley(threshold=threshold).run(x, trace=True)
    np.testing.assert_allclose(al.trace[:, 0, 0], df_oracle, atol=1e-9)
    assert [(int(t), int(c)) for t, c in zip(al.time, al.change_time, strict=True)] == alarms_oracle
    if np.isfinite(threshold):
        assert len(alarms_oracle) >= 3


def test_change_time_is_the_last_zero_before_the_alarm():
    rng = np.random.default_rng(11)
    x = rng.normal(-0.5, 1.0, size=2000)
    x[600:] += 1.0
    al = PageHinkley(threshold=8.0).run(x, trace=True)
    tr = al.trace[:, 0, 0]
    assert len(al) > 5
    prev = -1
    for t, c in zip(al.time, al.change_time, strict=True):
        zeros = np.flatnonzero(tr[prev + 1:t] == 0.0) + prev + 1
        expected = zeros[-1] if zeros.size else prev  # the reset point counts as a zero
        assert c == expected and tr[c + 1:t + 1].min() > 0  # positive from onset to alarm
        assert tr[t] > 8.0
        prev = t
    np.testing.assert_array_equal(al.onset, al.change_time + 1)


def test_mean_change_estimate_near_true_change():
    rng = np.random.default_rng(5)
    y = rng.standard_normal((500, 200))
    y[300:] += 2.0  # s = 2
    det = MeanChangeDetector(mu0=0.0, dmu=2.0, sigma=1.0, threshold=12.0)
    t, ct, _ = det.run(y).first(200, at_or_after=300)
    assert (t >= 300).all() and (t < 330).all()
    assert np.median(ct + 1) == 300  # onset = last zero + 1 estimates the change sample
    assert np.mean(np.abs(ct + 1 - 300) <= 2) > 0.8


def test_two_sided_mean_detector_names_the_side():
    rng = np.random.default_rng(2)
    y = rng.standard_normal(1000)
    y[500:] -= 1.5
    al = MeanChangeDetector(dmu=1.5, threshold=12.0, two_sided=True).run(y)
    assert len(al) >= 1 and al.time[0] >= 500
    assert al.side_name[0] == "down"
    assert MeanChangeDetector(dmu=1.5, threshold=12.0).run(y).time.size == 0


def _chi2(rng, n, m, scale):
    nu = rng.standard_normal((n, m)) * np.sqrt(scale)[:, None]
    return (nu**2).sum(axis=1)  # V = I


@pytest.mark.parametrize("direction", ["decrease", "increase"])
def test_variance_detector_fires_on_its_side_only(direction):
    rng = np.random.default_rng(17)
    m, n, change = 3, 3000, 1500
    scale = np.ones(n)
    scale[change:] = 0.25 if direction == "decrease" else 4.0
    chi2 = _chi2(rng, n, m, scale)
    det = VarianceChangeDetector(q=2.5, dim=m, threshold=20.0)
    al = det.run(chi2)
    assert len(al) >= 1
    first = al.time[0]
    assert change <= first < change + 150
    assert set(al.side_name) == {direction}
    # the one-sided test for the other direction never fires
    other = {"decrease": "increase", "increase": "decrease"}[direction]
    assert len(VarianceChangeDetector(q=2.5, dim=m, threshold=20.0, sides=other).run(chi2)) == 0


def test_streaming_variance_detector_equals_batch():
    rng = np.random.default_rng(23)
    chi2 = _chi2(rng, 800, 2, np.r_[np.ones(400), np.full(400, 0.2)])[:, None] * [1.0, 1.5]
    batch = VarianceChangeDetector(q=2.0, dim=2, threshold=[6.0, 9.0]).run(chi2)
    det = VarianceChangeDetector(q=2.0, dim=2, threshold=[6.0, 9.0])
    _same(Alarms.concat([det.update(row) for row in chi2]), batch)
    assert len(batch) > 0


def test_no_alarm_on_h0_data_at_a_high_threshold():
    # s = 1, T^2 = 25: Siegmund's t_F ~ 4e11, so P(any alarm in 1e6 samples) ~ 3e-6
    rng = np.random.default_rng(99)
    y = rng.standard_normal((250_000, 4))
    al = PageHinkley(threshold=25.0).run(mean_increment(y, mu0=0.0, dmu=1.0, sigma=1.0))
    assert len(al) == 0
    chi2 = rng.chisquare(3, size=(250_000, 4))
    assert len(VarianceChangeDetector(q=2.5, dim=3, threshold=30.0).run(chi2)) == 0


def test_bad_parameters_and_shapes_are_refused():
    with pytest.raises(ValueError, match="threshold"):
        PageHinkley(threshold=-1.0).run(np.zeros(3))
    with pytest.raises(ValueError, match="engine"):
        PageHinkley(threshold=1.0, engine="cuda").run(np.zeros(3))
    with pytest.raises(ValueError, match="finite"):
        PageHinkley(threshold=1.0).run(np.array([0.0, np.nan]))
    ph = PageHinkley(threshold=1.0)
    ph.run(np.zeros((5, 3)))
    with pytest.raises(ValueError, match="reset"):
        ph.run(np.zeros((5, 4)))
    assert ph.reset().run(np.zeros((5, 4))).time.size == 0
    with pytest.raises(ValueError, match=r"\(n, 2\)"):
        PageHinkley(threshold=1.0, sides=("a", "b")).run(np.zeros((5, 3)))
    with pytest.raises(ValueError, match="q"):
        VarianceChangeDetector(q=0.5, dim=2, threshold=5.0).run(np.ones(3))


def test_single_detector_streaming_fast_path_equals_batch():
    rng = np.random.default_rng(31)
    x = rng.normal(-0.3, 1.0, 4000)
    x[2000:] += 0.8
    ph = PageHinkley(threshold=7.0)
    stream, stats = _stream(ph, x)  # scalars: the Python-float path
    batch = PageHinkley(threshold=7.0).run(x, trace=True)
    assert len(batch) > 20
    _same(stream, batch)
    np.testing.assert_array_equal(stats[:, 0, 0], batch.trace[:, 0, 0])
    with pytest.raises(ValueError, match="finite"):
        ph.update(float("nan"))
