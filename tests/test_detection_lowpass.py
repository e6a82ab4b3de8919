"""Lowpass + threshold (fig 6.6): equals a direct loop; batch = streaming."""

from __future__ import annotations

import numpy as np
import pytest

from contactlab.detection import Alarms, LowpassThreshold, stationary_variance


def _direct(y, a, thr, absolute=False, x0=0.0):
    x, xs, alarms = x0, [], []
    for n, v in enumerate(y):
        x = a * x + (1 - a) * v
        xs.append(x)
        if x > thr or (absolute and x < -thr):
            alarms.append((n, 0 if x > thr else 1))
            x = x0
    return np.array(xs), alarms


@pytest.mark.parametrize("absolute", [False, True])
def test_equals_a_direct_loop(absolute):
    rng = np.random.default_rng(4)
    y = rng.normal(0, 1, 300)
    y[100:180] += 1.5
    y[220:] -= 1.5
    xs, alarms = _direct(y, 0.9, 0.5, absolute)
    al = LowpassThreshold(a=0.9, threshold=0.5, absolute=absolute).run(y, trace=True)
    np.testing.assert_allclose(al.trace[:, 0, 0], xs, rtol=0, atol=1e-14)
    assert list(zip(al.time.tolist(), al.side.tolist(), strict=True)) == alarms
    assert al.change_time is None
    assert len(alarms) >= 3 and (absolute == (1 in {s for _, s in alarms}))


def test_batch_equals_streaming_and_chunks():
    rng = np.random.default_rng(8)
    y = rng.normal(0.1, 1, size=(2000, 5))
    kw = dict(a=[0.5, 0.8, 0.9, 0.95, 0.98], threshold=[1.0, 0.6, 0.4, 0.3, 0.2], absolute=True)
    det = LowpassThreshold(**kw)
    parts, stats = [], []
    for row in y:
        parts.append(det.update(row))
        stats.append(det.statistic_.copy())
    stream = Alarms.concat(parts)
    batch = LowpassThreshold(**kw).run(y, trace=True)
    assert len(batch) > 50
    for f in ("time", "detector", "side"):
        np.testing.assert_array_equal(getattr(batch, f), getattr(stream, f))
    np.testing.assert_array_equal(batch.trace[:, :, 0], np.array(stats))
    chunked = LowpassThreshold(**kw)
    c = Alarms.concat([chunked.run(y[:777]), chunked.run(y[777:])])
    np.testing.assert_array_equal(c.time, batch.time)
    np.testing.assert_array_equal(chunked.x_, det.x_)


def test_stationary_variance_matches_simulation():
    rng = np.random.default_rng(1)
    y = rng.standard_normal((20000, 20))
    al = LowpassThreshold(a=0.9, threshold=1e6).run(y, trace=True)
    assert np.var(al.trace[1000:]) == pytest.approx(stationary_variance(0.9), rel=0.03)


def test_bad_parameters():
    with pytest.raises(ValueError, match="a"):
        LowpassThreshold(a=1.0, threshold=0.5).run(np.zeros(3))
    with pytest.raises(ValueError, match="threshold"):
        LowpassThreshold(a=0.5, threshold=0.0).run(np.zeros(3))
