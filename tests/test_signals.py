"""contactlab.signals: the one trial -> conditioned signal layer, and truth at its rate.

Oracles: scipy's Butterworth filter applied by hand, brute-force log-energy
blocks and label windows, and a wrench-only recording run through the CLI.
"""

import numpy as np
import pytest
from scipy import signal as sps

from contactlab.archive import create_archive, open_archive
from contactlab.errors import DataError
from contactlab.signals import condition, window_of, default_signal, trial_signals, truth_codes
from conftest import LABEL_NAMES, RATE_HZ, one_json_object, run_cli, synthetic_labels, \
    synthetic_measurements


def _wrench_only(path, n=3000):
    with create_archive(path, title="wrist sensor") as archive:
        for i, tid in enumerate(("w0", "w1")):
            data = synthetic_measurements(n, seed=i)
            rng = np.random.default_rng(i)
            w = data["wrench"] + rng.normal(scale=0.05, size=data["wrench"].shape)
            w[n // 2:] += rng.normal(scale=0.5, size=(n - n // 2, 6))       # a change
            trial = archive.add_trial(tid, rate_hz=RATE_HZ, controller="position",
                                      environment="plane", seed=i, source="import",
                                      description="wrench only")
            trial.append(time=data["time"], wrench=w, position=data["position"])
            labels, segments = synthetic_labels(data["time"])
            trial.set_ground_truth(labels=labels, names=LABEL_NAMES, segments=segments)
            trial.close()
    return path


def test_strain_and_wrench_match_scipy(archive_path):
    with open_archive(archive_path) as arc:
        trial = arc.trial("t01")
        sos = sps.butter(2, RATE_HZ / 8, fs=RATE_HZ, output="sos")
        for name in ("strain", "wrench", "position"):
            raw = np.asarray(getattr(trial, name), float)
            zi = sps.sosfilt_zi(sos)[:, :, None] * raw[0]
            want = sps.sosfilt(sos, raw, axis=0, zi=zi)[0][::4]
            sig = condition(trial, name)
            np.testing.assert_allclose(sig.y, want, rtol=1e-10, atol=1e-12)
            np.testing.assert_array_equal(sig.index, 4 * np.arange(len(want)))
            np.testing.assert_array_equal(sig.times, trial.time[sig.index])
            assert sig.fs == RATE_HZ / 4


def test_hf_floor_is_half_the_converter_step(archive_path):
    with open_archive(archive_path) as arc:
        trial = arc.trial("t01")
        lsb = 1e-3
        q = np.round(np.asarray(trial.strain, float) / lsb) * lsb
        fake = type("T", (), {"rate_hz": RATE_HZ, "time": trial.time, "strain": q, "id": "q"})
        sig = condition(fake, "hf")
        d = np.abs(np.diff(q, axis=0))
        assert (d == 0).any()                               # exact zeros of the difference
        logs = np.log(np.maximum(d, lsb / 2))
        k = np.arange(len(sig.y))
        want = np.stack([logs[4 * j:4 * j + 8].mean(axis=0) for j in k])
        np.testing.assert_allclose(sig.y, want, rtol=1e-9)
        np.testing.assert_array_equal(sig.index, 4 * k + 8)


def test_truth_codes_window_brute_force(archive_path):
    with open_archive(archive_path) as arc:
        trial = arc.trial("t01")
        idx = condition(trial, "hf").index
        got = truth_codes(trial, idx, window=window_of("hf", RATE_HZ))
        raw = trial.labels
        for k, i in enumerate(idx):
            w = raw[max(i - 8, 0):i + 1]
            assert got[k] == (w[0] if (w == w[0]).all() else -1)
        # names reorder the codes; a name the trial lacks gives -1 nowhere
        rev = truth_codes(trial, idx, names=LABEL_NAMES[::-1])
        plain = truth_codes(trial, idx)
        table = {i: LABEL_NAMES[::-1].index(n) for i, n in enumerate(LABEL_NAMES)}
        np.testing.assert_array_equal(rev, [table[c] if c >= 0 else -1 for c in plain])


def test_observer_streams_share_one_time_base(archive_path):
    with open_archive(archive_path) as arc:
        trial = arc.trial("t01")
        data, index, fs = trial_signals(trial, ["hf", "velocity"], reduce="mean")
        assert data["hf"].shape == (len(index), 1) and fs == RATE_HZ / 4
        np.testing.assert_array_equal(data["velocity"], trial.velocity[index])


def test_default_signal_follows_the_trial(tmp_path, archive_path):
    path = _wrench_only(tmp_path / "wrist.h5")
    with open_archive(path) as arc, open_archive(archive_path) as full:
        assert default_signal(arc.trial("w0")) == "wrench"
        assert default_signal(full.trial("t01")) == "strain"
        with pytest.raises(DataError, match="use --signal wrench"):
            condition(arc.trial("w0"), "strain")
    r = run_cli("segment", path, "--json", "--quiet")
    assert r.exit_code == 0, r.output
    assert len(one_json_object(r.stdout)["trials"]["w0"]["boundaries_s"]) >= 1
    with open_archive(path) as arc:
        assert arc.trial("w0").results("segment").attrs["signal"] == "wrench"
    r = run_cli("train", path, "--block", "50", "--out", tmp_path / "m.h5", "--json", "--quiet")
    assert r.exit_code == 0, r.output
    assert one_json_object(r.stdout)["signal"] == "wrench"
    r = run_cli("segment", path, "--signal", "hf")
    assert r.exit_code != 0 and "Traceback" not in r.output
    line = r.output.strip().splitlines()[-1]
    assert "no strain" in line and "--signal wrench" in line and "wrist.h5" in line


@pytest.mark.parametrize("fs, factor, cutoff", [(1000.0, 4, 125.0), (500.0, 2, 125.0),
                                                (2000.0, 8, 125.0), (250.0, 1, None),
                                                (100.0, 1, None), (50.0, 1, None)])
def test_conditioning_reaches_250_hz_at_any_rate(fs, factor, cutoff):
    """The 7.1 decimation aims at 250 Hz: 4:1 at the thesis's 1000 Hz, nothing below 250 Hz;
    the cutoff is the output's Nyquist rate (scipy's Butterworth applied by hand)."""
    from contactlab.signals import condition_array, cutoff_for, factor_for, window_of

    assert factor_for(fs) == factor and cutoff_for(fs) == cutoff
    rng = np.random.default_rng(3)
    x = rng.normal(size=(int(4 * fs), 2))
    low = condition_array(x, "wrench", fs=fs)
    assert low.fs == pytest.approx(fs / factor)
    if cutoff is None:
        np.testing.assert_array_equal(low.y, x)
    else:
        sos = sps.butter(2, cutoff, fs=fs, output="sos")
        zi = sps.sosfilt_zi(sos)[:, :, None] * x[0]
        np.testing.assert_allclose(low.y, sps.sosfilt(sos, x, axis=0, zi=zi)[0][::factor],
                                   atol=1e-12)
    hf = condition_array(x, "hf", fs=fs)
    block = 2 * factor                       # 7.1: blocks of 8 every 4th sample at 1000 Hz
    d = np.abs(np.diff(x, axis=0))
    k = len(hf.y) // 2
    np.testing.assert_allclose(hf.y[k], np.log(d[factor * k:factor * k + block]).mean(axis=0))
    assert hf.index[k] == factor * k + block and window_of("hf", fs) == block + 1


def test_segment_finds_changes_in_a_250_hz_recording(tmp_path):
    """A recording made at 250 Hz is segmented at 250 Hz, not cut to 62.5 Hz: the
    piecewise-AR suite's changes are found in its lowpassed 250 Hz copy."""
    from dataclasses import replace

    from contactlab.synthetic import piecewise_ar_trials, write_archive

    trials = piecewise_ar_trials(3, seed=7)
    low = [replace(t, y=y, fs=fs, boundaries=t.boundaries // 4)
           for t, (y, fs) in zip(trials, (t.lowpassed() for t in trials))]
    assert all(t.fs == 250.0 for t in low)
    path = tmp_path / "rec250.h5"
    write_archive(low, path, title="250 Hz recording")
    res = run_cli("segment", path, "--tolerance", "0.05", "--json", "--quiet")
    assert res.exit_code == 0, res.output
    m = one_json_object(res.stdout)["metrics"]["overall"]
    assert m["f1"] >= 0.9, m


@pytest.mark.parametrize("fs", [1000.0, 100.0])
def test_derived_velocity_at_any_rate(fs):
    """A trial without velocity gets chapter 1's velocity from position: at 1000 Hz the
    conditioning's velocity_from_position (the oracle), at any rate a ramp's speed, with
    the streams of trial_signals on one time base."""
    from types import SimpleNamespace

    from contactlab.conditioning import velocity_from_position
    from contactlab.signals import derived_velocity, factor_for

    n = int(3 * fs)
    t = np.arange(n) / fs
    rng = np.random.default_rng(5)
    p = np.column_stack([0.02 * t, -0.01 * t, 1e-6 * rng.normal(size=n)])
    trial = SimpleNamespace(id="r", rate_hz=fs, time=t, position=p, velocity=None,
                            wrench=rng.normal(size=(n, 6)), strain=None, labels=None)
    v = derived_velocity(trial)
    if fs == 1000.0:
        np.testing.assert_allclose(v, velocity_from_position(p, fs=fs), atol=1e-12)
    np.testing.assert_allclose(np.median(v[len(v) // 2:, :2], axis=0), [0.02, -0.01], rtol=1e-6)
    data, index, fs_out = trial_signals(trial, ["wrench", "velocity"])
    assert fs_out == fs / factor_for(fs) and len(data["velocity"]) == len(data["wrench"])
    np.testing.assert_array_equal(data["velocity"], v[index // factor_for(fs)])


def test_a_graph_reading_strain_on_a_wrist_recording_names_a_graph_that_fits(tmp_path):
    """train/recognize --graph read the graph's streams: the hint names a graph, not --signal
    (which --graph refuses)."""
    path = _wrench_only(tmp_path / "wrist.h5")
    r = run_cli("train", path, "--graph", "guarded-move", "--out", tmp_path / "m.h5")
    assert r.exit_code != 0 and "Traceback" not in r.output
    line = r.output.strip().splitlines()[-1]
    assert "no strain" in line and "free-contact" in line and "--signal" not in line
    assert "wrist.h5" in line and "/measurements/strain" in line
