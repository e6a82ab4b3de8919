"""Per-channel combination of the segmenter (``combine="channel"``) and the unchanged default.

Oracles: AR(2) signals from scipy.signal.lfilter with variance changes placed
by construction on chosen channels; a per-sample reference written here from
SquareRootRLS.update and VarianceChangeDetector.update (one detector per
channel, dim 1); the sum mode run on each channel alone with restarts
replayed by hand; false-alarm counts measured on stationary data.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.signal import lfilter

from contactlab.archive import open_archive
from contactlab.detection import VarianceChangeDetector
from contactlab.detection.increments import variance_increment
from contactlab.errors import UsageError
from contactlab.estimators import SquareRootRLS
from contactlab.segmentation import pooled_metrics, run_archive, segment_signal, sweep
from conftest import one_json_object, run_cli
from test_segmentation import write_changing_archive

FS = 250.0


def ar2(n, *, channels=8, seed=0, a=(1.2, -0.5)):
    rng = np.random.default_rng(seed)
    e = rng.normal(size=(n + 200, channels))
    return lfilter([1.0], [1.0, -a[0], -a[1]], e, axis=0)[200:]


def with_change(n_before, n_after, *, channels, factor, seed):
    """8 channels; the innovation variance of ``channels`` multiplied by ``factor`` at
    sample ``n_before`` (fresh noise after the change, same AR dynamics)."""
    rng = np.random.default_rng(seed)
    e = rng.normal(size=(n_before + n_after + 200, 8))
    e[200 + n_before:, list(channels)] *= np.sqrt(factor)
    return lfilter([1.0], [1.0, -1.2, 0.5], e, axis=0)[200:]


def reference(y, *, combine, order=2, threshold=200.0, change_size=2.5, warmup=8,
              variance_samples=8):
    """Per-sample segmentation: [(boundary, alarm, side, channel)] and the statistic trace."""
    n, c = y.shape
    dim = c if combine == "sum" else 1
    rls = SquareRootRLS(variance_warmup=warmup)
    det = VarianceChangeDetector(q=change_size, dim=dim, threshold=threshold)
    trace = np.full((n,) if combine == "sum" else (n, c), np.nan)
    fed, out, absorbed = [], [], 0
    for t in range(order, n):
        psi = np.stack([y[t - i] for i in range(1, order + 1)], axis=1)
        stat = rls.update(psi, y[t]).stat
        chi2 = stat.sum() if combine == "sum" else stat
        tested = absorbed >= max(warmup, order) + variance_samples
        absorbed += 1
        if not tested:
            continue
        trace[t] = chi2
        fed.append(t)
        alarm = det.update(chi2)
        if len(alarm):                      # ordered by detector: the lowest channel first
            ch = -1 if combine == "sum" else int(alarm.detector[0])
            out.append((fed[alarm.change_time[0] + 1], t, int(alarm.side[0]), ch))
            rls.reset()
            det.reset()
            fed, absorbed = [], 0
    return out, trace


def quads(seg):
    return list(zip(seg.boundaries.tolist(), seg.alarms.tolist(), seg.sides.tolist(),
                    seg.alarm_channels.tolist()))


def changing_signal():
    parts = [ar2(400, seed=1), ar2(400, seed=2), ar2(400, seed=3), ar2(400, seed=4)]
    parts[1][:, [2, 5]] *= 3.0             # an increase on two channels
    parts[2][:, 0] *= 0.3                  # a decrease on one
    parts[3] *= 1.8                        # all channels
    return np.concatenate(parts)[:, :5]


# -- the default is the thesis's sum, unchanged --------------------------------------------

@pytest.mark.parametrize("block", [13, 512])
def test_sum_mode_bit_identical_to_per_sample_reference(block):
    y = changing_signal()
    ref, trace = reference(y, combine="sum", threshold=30.0)
    default = segment_signal(y, fs=FS, threshold=30.0, block=block)
    explicit = segment_signal(y, fs=FS, threshold=30.0, block=block, combine="sum")
    assert len(ref) >= 2                   # the one-channel fall is too diluted for the sum
    assert quads(default) == ref == quads(explicit)
    np.testing.assert_array_equal(default.statistic, trace)      # bit for bit, NaNs included
    np.testing.assert_array_equal(explicit.statistic, trace)
    assert default.parameters["combine"] == "sum"
    assert "alarm_channels" not in default.as_dict()


# -- channel mode against its oracles ------------------------------------------------------

@pytest.mark.parametrize("block", [13, 512])
def test_channel_mode_equals_per_sample_reference(block):
    y = changing_signal()
    ref, trace = reference(y, combine="channel", threshold=30.0)
    seg = segment_signal(y, fs=FS, threshold=30.0, block=block, combine="channel")
    assert len(ref) >= 3
    assert quads(seg) == ref
    np.testing.assert_array_equal(seg.statistic, trace)
    assert seg.statistic.shape == (len(y), 5)
    assert seg.as_dict()["alarm_channels"] == [r[3] for r in ref]


def test_channel_mode_equals_sum_mode_on_each_channel_alone():
    """Each channel's detector is the sum-mode test on that channel alone; the
    earliest alarm wins and everything restarts at the sample after it."""
    y = changing_signal()
    kw = dict(fs=FS, threshold=30.0)
    seg = segment_signal(y, combine="channel", **kw)
    p, start, expected = 2, 0, []
    while True:
        # restarted estimators first absorb sample `start + p`, with the p before as history
        firsts = []
        for c in range(y.shape[1]):
            alone = segment_signal(y[start:, [c]], **kw)
            if len(alone):
                firsts.append((int(alone.alarms[0]), c, int(alone.boundaries[0]),
                               int(alone.sides[0]), alone.statistic))
        if not firsts:
            break
        a, c, b, side, _ = min(firsts, key=lambda f: (f[0], f[1]))
        expected.append((start + b, start + a, side, c))
        # the channel-mode statistic of every channel matches its lone run up to the alarm
        for f in firsts:
            # (the slice's first p samples are history: they belong to the previous segment)
            np.testing.assert_array_equal(seg.statistic[start + p:start + a + 1, f[1]],
                                          f[4][p:a + 1])
        start = start + a + 1 - p
    assert len(expected) >= 3
    assert quads(seg) == expected


def _found(kind, thr, chans, factor, seeds, change=3000):
    """Trials (of ``seeds``) with a boundary within 25 samples (0.1 s) of the change,
    and the median alarm delay (samples) over those."""
    hits, delays = 0, []
    for seed in seeds:
        y = with_change(change, 600, channels=chans, factor=factor, seed=seed)
        seg = segment_signal(y, fs=FS, threshold=thr, combine=kind)
        k = np.flatnonzero(np.abs(seg.boundaries - change) <= 25)
        if k.size:
            hits += 1
            delays.append(int(seg.alarms[k[0]]) - change)
    return hits, (float(np.median(delays)) if delays else None)


def test_two_of_eight_channels_fall_tenfold_found_by_channel_not_by_sum():
    """A 10x fall of the innovation variance on 2 of 8 channels: the sum's mean
    chi2/dof is (6 + 2/10)/8 = 0.775, above ln q/(q - 1) = 0.611 below which the
    q = 2.5 decrease test drifts up, so the sum's test drifts down; one channel's
    test drifts up by (ln q - (q - 1)/10)/2 = 0.383 per sample."""
    q = 2.5
    assert (6 + 0.2) / 8 > np.log(q) / (q - 1)
    assert variance_increment(0.1, dim=1, q=1 / q) == pytest.approx(0.383, abs=1e-3)
    # the comparison favours the sum: on stationary data the sum at T^2 = 8 alarms more
    # often than the channel mode at T^2 = 12
    still = ar2(60_000, seed=21)
    fa_sum = len(segment_signal(still, fs=FS, threshold=8.0))
    fa_channel = len(segment_signal(still, fs=FS, threshold=12.0, combine="channel"))
    assert fa_sum > fa_channel
    seeds = range(100, 112)
    hits_ch, delay_ch = _found("channel", 12.0, (2, 6), 0.1, seeds)
    hits_sum, _ = _found("sum", 8.0, (2, 6), 0.1, seeds)
    assert hits_ch >= 9 and delay_ch < 100
    assert hits_sum <= 2


def test_large_change_on_two_channels_the_sum_is_as_fast():
    """The other side, honestly: a 10x *rise* on 2 of 8 channels drifts the sum's
    increase test by (-8 ln q + (1 - 1/q) 26)/2 = 4.13 per sample, one channel's by
    (-ln q + (1 - 1/q) 10)/2 = 2.54: both find it, the sum no later."""
    assert variance_increment(26.0, dim=8, q=2.5) > variance_increment(10.0, dim=1, q=2.5)
    seeds = range(200, 208)
    hits_ch, delay_ch = _found("channel", 12.0, (2, 6), 10.0, seeds)
    hits_sum, delay_sum = _found("sum", 8.0, (2, 6), 10.0, seeds)
    assert hits_ch == hits_sum == len(seeds)
    assert delay_sum <= delay_ch


def test_channel_mode_quiet_on_stationary_data_and_statistic_is_chi2_1():
    y = ar2(20_000, seed=12)
    seg = segment_signal(y, fs=FS, threshold=25.0, combine="channel")
    assert len(seg) == 0
    assert np.nanmean(seg.statistic, axis=0) == pytest.approx(np.ones(8), abs=0.06)


def test_constant_channels_left_out_and_alarm_channel_is_the_signal_column():
    y = ar2(2000, channels=3, seed=5)
    y = np.column_stack([np.full(len(y), 2.0), y])           # column 0 constant
    y[1000:, 2] *= 4.0
    seg = segment_signal(y, fs=FS, combine="channel")
    assert seg.channels.tolist() == [1, 2, 3]
    assert seg.statistic.shape == (2000, 3)
    assert len(seg) == 1 and seg.alarm_channels.tolist() == [2]
    assert abs(seg.boundaries[0] - 1000) <= 5


def test_bad_combine_and_sweep_passes_it_on():
    y = ar2(600, seed=3)
    with pytest.raises(UsageError, match="combine"):
        segment_signal(y, fs=FS, combine="mean")
    runs = sweep(y, [20, 200], fs=FS, combine="channel")
    assert all(s.parameters["combine"] == "channel" for s in runs.values())
    assert pooled_metrics([], 0.1) is None


# -- archive and CLI -----------------------------------------------------------------------

def test_run_archive_channel_writes_alarm_channels(tmp_path):
    path = write_changing_archive(tmp_path / "c.h5", trials=("a",))
    out = run_archive(path, combine="channel", method="page-hinkley")
    entry = out["trials"]["a"]
    assert any(abs(b - 4.0) < 0.05 for b in entry["boundaries_s"])
    assert len(entry["alarm_channels"]) == len(entry["boundaries_s"])
    with open_archive(path) as archive:
        r = archive.trial("a").results("segment")
        assert r["statistic"].shape[1] == 8
        np.testing.assert_array_equal(r["alarm_channels"], entry["alarm_channels"])
        assert r.parameters["combine"] == "channel"


def test_cli_combine_channel_json_and_bad_value(tmp_path):
    path = write_changing_archive(tmp_path / "c.h5", trials=("a",))
    res = run_cli("segment", path, "--method", "page-hinkley", "--combine", "channel", "--sweep",
                  "25,200", "--json", "-q")
    assert res.exit_code == 0, res.output
    out = one_json_object(res.stdout)
    assert out["metrics"]["200"]["recall"] == 1.0
    assert "alarm_channels" in out["trials"]["a"]["sweep"]["200"]
    res = run_cli("segment", path, "--combine", "max", "-q")
    assert res.exit_code == 2 and "--combine" in res.stderr
