"""Segmentation of 7.2.1 / fig 7.6: AR estimators + chi-square Page-Hinkley with restarts.

The signals are generated here with scipy.signal.lfilter (AR(2) driven by
Gaussian noise), the change points are known by construction, and the
block-wise implementation is checked against a per-sample reference written
in this file from SquareRootRLS.update and VarianceChangeDetector.update.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.signal import lfilter

from contactlab.archive import create_archive, open_archive, validate_archive
from contactlab.detection import VarianceChangeDetector
from contactlab.errors import DataError, UsageError
from contactlab.estimators import SquareRootRLS
from contactlab.segmentation import (boundary_metrics, segment_signal, segment_trial, sweep)
from conftest import one_json_object, run_cli

FS = 250.0
C = 8


def ar2(n, *, a=(1.2, -0.5), sigma=1.0, seed=0, channels=C):
    """n samples of y(n) = a1 y(n-1) + a2 y(n-2) + sigma e(n), after a burn-in."""
    rng = np.random.default_rng(seed)
    e = rng.normal(scale=sigma, size=(n + 200, channels))
    return lfilter([1.0], [1.0, -a[0], -a[1]], e, axis=0)[200:]


def pieces(*specs, seed=0):
    """Concatenate AR(2) pieces (n, a, sigma); each piece gets its own noise."""
    return np.concatenate([ar2(n, a=a, sigma=s, seed=seed + i)
                           for i, (n, a, s) in enumerate(specs)])


# -- reference: one sample at a time, straight from the thesis's description ----------------

def reference_boundaries(y, *, order=2, threshold=200.0, change_size=2.5, warmup=8,
                         variance_samples=8):
    """Per-sample segmentation: returns [(boundary sample, alarm sample, side), ...].

    The detector only sees samples whose chi-square exists (after the variance
    warm-up); its change time counts those samples, -1 meaning "before the
    first", so the first sample of the new regime is the fed sample after it.
    """
    n, c = y.shape
    rls = SquareRootRLS(variance_warmup=warmup)
    det = VarianceChangeDetector(q=change_size, dim=c, threshold=threshold)
    fed = []                           # sample index of each chi2 the detector saw
    out = []
    absorbed = 0                       # samples the estimators absorbed since (re)start
    t = order
    while t < n:
        psi = np.stack([y[t - i] for i in range(1, order + 1)], axis=1)   # (C, p)
        chi2 = rls.update(psi, y[t]).stat.sum()
        # the variance starts after `warmup`; test once it holds variance_samples
        tested = absorbed >= max(warmup, order) + variance_samples
        absorbed += 1
        if tested:
            assert np.isfinite(chi2)
            fed.append(t)
            alarm = det.update(chi2)
            if len(alarm):
                first_new = fed[alarm.change_time[0] + 1]
                out.append((first_new, t, int(alarm.side[0])))
                rls.reset()
                det.reset()
                fed = []
                absorbed = 0
        t += 1
    return out


def as_triples(seg):
    return list(zip(seg.boundaries.tolist(), seg.alarms.tolist(), seg.sides.tolist()))


# -- the algorithm -------------------------------------------------------------------------

def test_variance_increase_found_within_a_few_samples():
    y = pieces((1000, (1.2, -0.5), 1.0), (1000, (1.2, -0.5), 2.0))
    seg = segment_signal(y, fs=FS)
    assert len(seg) == 1
    assert abs(seg.boundaries[0] - 1000) <= 5
    assert seg.side_names == ["increase"]
    assert seg.alarms[0] >= seg.boundaries[0]
    assert seg.boundaries_s[0] == pytest.approx(seg.boundaries[0] / FS)


def test_coefficient_change_found():
    # same driving noise, different dynamics: the old predictor's errors grow
    y = pieces((1500, (1.2, -0.5), 1.0), (1500, (0.2, 0.3), 1.0))
    seg = segment_signal(y, fs=FS)
    assert len(seg) >= 1
    assert abs(seg.boundaries[0] - 1500) <= 15


def test_variance_decrease_named_decrease():
    y = pieces((1000, (1.2, -0.5), 2.0), (1000, (1.2, -0.5), 1.0))
    seg = segment_signal(y, fs=FS)
    assert len(seg) == 1 and seg.side_names == ["decrease"]
    assert abs(seg.boundaries[0] - 1000) <= 10


def test_restart_finds_two_changes():
    y = pieces((800, (1.2, -0.5), 1.0), (800, (1.2, -0.5), 3.0), (800, (1.2, -0.5), 1.0))
    seg = segment_signal(y, fs=FS)
    assert len(seg) == 2
    assert abs(seg.boundaries[0] - 800) <= 5 and abs(seg.boundaries[1] - 1600) <= 10
    assert seg.side_names == ["increase", "decrease"]
    # the estimators restart on the sample after the alarm (its AR history is the
    # signal before it); the variance starts on their ninth measurement and the
    # test once it holds 8 samples: untested for 16 samples, tested from the 17th
    after = seg.alarms[0] + 1
    assert np.isnan(seg.statistic[after:after + 16]).all()
    assert np.isfinite(seg.statistic[after + 16:seg.alarms[1] + 1]).all()


@pytest.mark.parametrize("seed", [11, 12])
def test_no_boundary_on_long_stationary_data(seed):
    y = ar2(40_000, seed=seed)                    # 160 s at 250 Hz
    seg = segment_signal(y, fs=FS, threshold=200.0)
    assert len(seg) == 0
    # under H0 the statistic is chi-square with C degrees of freedom
    assert np.nanmean(seg.statistic) == pytest.approx(C, rel=0.05)


@pytest.mark.parametrize("block", [7, 64, 512])
def test_blockwise_equals_per_sample_reference(block):
    y = pieces((300, (1.2, -0.5), 1.0), (300, (1.2, -0.5), 3.0), (300, (0.3, 0.2), 0.8),
               (300, (1.2, -0.5), 3.0), seed=5)[:, :4]
    ref = reference_boundaries(y, threshold=40.0)
    seg = segment_signal(y, fs=FS, threshold=40.0, block=block)
    assert len(ref) >= 3
    assert as_triples(seg) == ref


def test_order_and_short_signal_errors():
    y = ar2(100)
    with pytest.raises(UsageError, match="order"):
        segment_signal(y, fs=FS, order=0)
    with pytest.raises(UsageError, match="change_size"):
        segment_signal(y, fs=FS, change_size=1.0)
    with pytest.raises(DataError, match="needs at least"):
        segment_signal(y[:18], fs=FS, order=2, warmup=8)
    # the shortest that runs: 2 of history, 8 of warm-up, 8 in the variance, 1 tested
    seg = segment_signal(y[:19], fs=FS, order=2, warmup=8)
    assert np.isfinite(seg.statistic).sum() == 1


def test_constant_channels_are_left_out():
    y = ar2(2000, channels=3)
    y = np.column_stack([y, np.full(len(y), 4.0)])
    y[1000:, :3] *= 2.0
    seg = segment_signal(y, fs=FS)
    assert seg.channels.tolist() == [0, 1, 2]
    assert len(seg) == 1 and abs(seg.boundaries[0] - 1000) <= 5


def test_sweep_lower_threshold_more_boundaries():
    y = pieces((600, (1.2, -0.5), 1.0), (600, (1.2, -0.5), 1.6), (600, (1.2, -0.5), 4.0))
    runs = sweep(y, [20, 100, 400], fs=FS)
    counts = [len(runs[t]) for t in (20.0, 100.0, 400.0)]
    assert counts[0] >= counts[1] >= counts[2] >= 1


def test_boundary_metrics_hand_computed():
    times = np.arange(1000) / FS
    # one found boundary 0.05 s from a true one, one 1 s from the other
    m = boundary_metrics([1.0, 2.0], [1.05, 3.0], times=times, tolerance_s=0.1)
    assert (m["precision"], m["recall"], m["f1"]) == (0.5, 0.5, 0.5)
    m = boundary_metrics([1.0, 2.0], [1.2, 2.0], times=times, tolerance_s=0.1)
    assert m["recall"] == 0.5
    assert boundary_metrics([], [1.0], times=times)["f1"] is None
    assert boundary_metrics([1.0], [], times=times)["precision"] == 0.0


# -- archives and the CLI ------------------------------------------------------------------

def write_changing_archive(path, *, n=8000, wrench=True, truth=True, trials=("a", "b")):
    """1000 Hz, 8 strains: AR noise whose size triples half-way (at 4 s)."""
    with create_archive(path, title="segment test") as archive:
        for i, tid in enumerate(trials):
            time = np.arange(n) / 1000.0
            strain = 0.01 * ar2(n, a=(1.6, -0.8), seed=30 + i)
            strain[n // 2:] *= 3.0
            trial = archive.add_trial(tid, rate_hz=1000.0, source="simulator",
                                      calibration=np.eye(6, 8) if wrench else None)
            kwargs = {"wrench": strain @ np.eye(6, 8).T} if wrench else {}
            trial.append(time=time, strain=strain, **kwargs)
            if truth:
                labels = (np.arange(n) >= n // 2).astype(np.int16)
                trial.set_ground_truth(labels=labels, names=["quiet", "loud"],
                                       segments=[(0.0, time[n // 2], "quiet"),
                                                 (time[n // 2], time[-1], "loud")])
            trial.close()
    return path


def test_segment_trial_boundary_in_trial_seconds(tmp_path):
    path = write_changing_archive(tmp_path / "c.h5")
    with open_archive(path) as archive:
        for signal in ("strain", "wrench"):     # a vibration change: the AR test's job
            seg = segment_trial(archive.trial("a"), signal=signal, method="glr")
            assert len(seg) >= 1
            assert abs(seg.boundaries_s[0] - 4.0) < 0.05


def test_cli_writes_results_validates_and_prints_one_json(tmp_path):
    path = write_changing_archive(tmp_path / "c.h5")
    res = run_cli("segment", path, "--json", "-q")
    assert res.exit_code == 0, res.output
    out = one_json_object(res.stdout)
    assert set(out["trials"]) == {"a", "b"}
    for entry in out["trials"].values():
        assert any(abs(b - 4.0) < 0.05 for b in entry["boundaries_s"])
        assert len(entry["change_s"]) == len(entry["alarm_s"]) == len(entry["sides"])
    assert out["metrics"]["overall"]["recall"] == 1.0
    assert validate_archive(path) == []
    with open_archive(path) as archive:
        r = archive.trial("a").results("segment")
        assert np.allclose(r["boundaries_s"], out["trials"]["a"]["boundaries_s"])
        assert r.attrs["signal"] == "strain"
        assert "threshold" in r.attrs["parameters"]
        assert archive.trial("a").strain.shape == (8000, 8)    # measurements untouched


def test_cli_sweep_prints_per_threshold_and_writes_nothing(tmp_path):
    path = write_changing_archive(tmp_path / "c.h5", trials=("a",))
    res = run_cli("segment", path, "--sweep", "50,200", "--json", "-q")
    assert res.exit_code == 0, res.output
    out = one_json_object(res.stdout)
    assert set(out["trials"]["a"]["sweep"]) == {"50", "200"}
    assert set(out["metrics"]) == {"50", "200"}
    with open_archive(path) as archive:
        assert archive.trial("a").result_stages() == []


def test_cli_without_truth_has_no_metrics(tmp_path):
    path = write_changing_archive(tmp_path / "c.h5", truth=False, trials=("a",))
    out = one_json_object(run_cli("segment", path, "--json", "-q").stdout)
    assert "metrics" not in out


@pytest.mark.parametrize("args, code, words", [
    (["--trial", "zz"], 1, "no such trial"),
    (["--signal", "wrench"], 1, "no wrench"),
    (["--order", "0"], 2, "--order"),
    (["--sweep", "a,b"], 2, "--sweep"),
    (["--threshold", "100", "--sweep", "50,100"], 2, "not both"),
])
def test_cli_bad_inputs_one_line(tmp_path, args, code, words):
    path = write_changing_archive(tmp_path / "c.h5", wrench=False, trials=("a",), n=2000)
    res = run_cli("segment", path, *args, "-q")
    assert res.exit_code == code
    assert len(res.stderr.strip().splitlines()) == 1 and words in res.stderr


def test_cli_trial_too_short_one_line(tmp_path):
    path = write_changing_archive(tmp_path / "s.h5", trials=("a",), n=40, truth=False)
    res = run_cli("segment", path, "-q")
    assert res.exit_code == 1
    assert len(res.stderr.strip().splitlines()) == 1 and "needs at least" in res.stderr


def test_simulated_stroke_trial_boundaries_near_sliding_start_and_end(tmp_path):
    out = tmp_path / "stroke.h5"
    res = run_cli("acquire", "--spec", "stroke-a", "--trials", 1, "--out", out, "-q")
    assert res.exit_code == 0, res.output
    res = run_cli("segment", out, "--json", "-q")
    assert res.exit_code == 0, res.output
    found = np.array(next(iter(one_json_object(res.stdout)["trials"].values()))["boundaries_s"])
    with open_archive(out) as archive:
        trial = next(iter(archive))
        moving = trial.truth("moving")
        onset, offset = trial.time[np.argmax(moving)], trial.time[len(moving) - 1 -
                                                                   np.argmax(moving[::-1])]
    assert np.min(np.abs(found - onset)) < 0.3
    assert np.min(np.abs(found - offset)) < 0.3
