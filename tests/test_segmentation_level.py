"""The level test for wrist wrenches (contactlab.detection.level_shift) and ``segment``'s
choice of detector by signal."""

from __future__ import annotations

import numpy as np
import pytest

from contactlab.archive import create_archive, open_archive
from contactlab.detection.level_shift import level_changes, ramp_fit, window_difference
from contactlab.segmentation import (boundary_metrics, labelled_only, resolve_method,
                                     segment_level, segment_trial, truth_boundaries_s)
from contactlab.synthetic.free_contact import free_contact_recording

FS = 100.0


def _ramp(n, a, b):
    return np.linspace(a, b, n, endpoint=False)


def _wiping_like(seed=0, fs=FS):
    """Free 3 s, a 0.75 s ramp to -20 N, 6 s of sliding (slow wander, 2 Hz ringing), a
    1 s dip to -8 N and back, then a 0.75 s ramp back to free and 3 s free (the boundary
    is placed where the force is 20 % of the step off its free level: within 0.25 s of
    the ramp's start or end for ramps up to about 0.8 s).  Returns the
    force (n, 3), the touch-down's first sample, the lift-off's last ramp sample, and the
    dip's first sample."""
    rng = np.random.default_rng(seed)
    parts = [np.zeros(int(3 * fs)), _ramp(int(0.75 * fs), 0, -20), np.full(int(3 * fs), -20.0),
             _ramp(int(0.3 * fs), -20, -8), np.full(int(0.7 * fs), -8.0),
             _ramp(int(0.3 * fs), -8, -20), np.full(int(3 * fs), -20.0),
             _ramp(int(0.75 * fs), -20, 0), np.zeros(int(3 * fs))]
    fz = np.concatenate(parts)
    n = len(fz)
    t = np.arange(n) / fs
    touch = int(3 * fs)
    inside = fz < -1
    fz = fz + inside * (1.5 * np.sin(2 * np.pi * 2.0 * t) + np.cumsum(rng.normal(0, 0.05, n)))
    lift_end = touch + int(0.75 * fs) + int(3 * fs) + int(1.3 * fs) + int(3 * fs) + int(0.75 * fs)
    dip = touch + int(0.75 * fs) + int(3 * fs)
    f = np.stack([0.3 * rng.normal(size=n).cumsum() * 0.01 + 2.0, np.full(n, -0.9), fz], axis=1)
    return f + rng.normal(0, 0.03, (n, 3)), touch, lift_end, dip


def test_ramp_fit_is_the_least_squares_optimum():
    rng = np.random.default_rng(3)
    y = np.concatenate([np.zeros(12), _ramp(9, 0, 5), np.full(14, 5.0)])
    y = np.stack([y, -0.5 * y], axis=1) + rng.normal(0, 0.05, (35, 2))
    k1, k2 = ramp_fit(y, 0, len(y), 3)

    def sse(a, b):          # oracle: numpy least squares of each piece
        out = ((y[:a] - y[:a].mean(0)) ** 2).sum() + ((y[b:] - y[b:].mean(0)) ** 2).sum()
        t = np.arange(a, b)
        A = np.stack([np.ones_like(t), t], axis=1).astype(float)
        res = y[a:b] - A @ np.linalg.lstsq(A, y[a:b], rcond=None)[0]
        return out + (res ** 2).sum()

    best = min((sse(a, b), a, b) for a in range(3, 35 - 4) for b in range(a + 2, 35 - 3 + 1))
    assert (k1, k2) == best[1:]
    assert abs(k1 - 12) <= 1 and abs(k2 - 21) <= 1


def test_window_difference_is_the_mean_difference():
    rng = np.random.default_rng(1)
    x = rng.normal(size=(50, 3))
    D = window_difference(x, 5)
    for t in (5, 17, 45):
        want = np.linalg.norm(x[t:t + 5].mean(0) - x[t - 5:t].mean(0))
        assert D[t] == pytest.approx(want)
    assert D[:5].max() == 0 and D[46:].max() == 0


def test_touch_down_at_the_ramp_start_lift_off_at_its_end_and_a_dip_is_an_event():
    f, touch, lift_end, dip = _wiping_like()
    r = level_changes(f, fs=FS)
    assert len(r.boundaries) == 2, r.boundaries / FS
    assert abs(r.boundaries[0] - touch) <= 0.25 * FS
    assert abs(r.boundaries[1] - lift_end) <= 0.25 * FS
    assert list(r.away) == [True, False]
    # the dip is marked where it holds the level nearest free space: from the end of its
    # 0.3 s fall to the start of its rise
    assert len(r.events) == 1
    assert abs(r.events[0] - (dip + 0.3 * FS)) <= 0.25 * FS
    assert abs(r.event_ends[0] - (dip + 1.0 * FS)) <= 0.25 * FS


def test_quiet_free_space_has_no_boundary():
    rng = np.random.default_rng(2)
    f = rng.normal(0, 0.05, (3000, 3)) + np.array([2.0, -1.0, 0.3])
    r = level_changes(f, fs=FS)
    assert len(r.boundaries) == 0 and len(r.events) == 0


def test_scale_free_one_default_for_a_weak_and_a_strong_sensor():
    f, touch, lift_end, _ = _wiping_like(seed=4)
    for scale in (0.1, 1.0, 10.0):     # 2 N to 200 N contacts: the same two boundaries
        r = level_changes(f * scale, fs=FS)
        assert len(r.boundaries) == 2
        assert abs(r.boundaries[0] - touch) <= 0.25 * FS


def test_hand_held_tool_recordings_made_without_the_simulator():
    # light touches (0.1-1.5 N) against the inertia of a hand-held tool: a hard case
    f1 = []
    for seed in (1, 2, 4):
        rec = free_contact_recording(seed=seed, fs=FS, cycles=6)
        st = (rec.labels == 2).astype(int)
        k = np.flatnonzero(np.diff(st)) + 1
        seg = segment_level(rec.force, fs=FS, times=rec.times)
        f1.append(boundary_metrics(rec.times[k], seg.boundaries_s, times=rec.times,
                                   tolerance_s=0.25)["f1"])
    assert np.mean(f1) >= 0.6, f1


def _wrist_archive(path, f, labels=None, names=None):
    n = len(f)
    with create_archive(path, title="wrist") as archive:
        tr = archive.add_trial("w", rate_hz=FS, source="import")
        tr.append(time=np.arange(n) / FS, wrench=np.concatenate([f, 0.01 * f], axis=1),
                  position=np.zeros((n, 3)))
        if labels is not None:
            tr.set_ground_truth(labels=labels, names=names)
        tr.close()
    return path


def test_auto_runs_the_level_test_on_a_wrench_and_scores_mapped_states(tmp_path):
    f, touch, lift_end, dip = _wiping_like()
    n = len(f)
    labels = np.zeros(n, np.int16)            # 0 unlabelled at the end
    labels[:touch] = 1
    labels[touch:lift_end] = 2
    labels[dip:dip + int(1.3 * FS)] = 4       # a labelled dip, still in contact
    labels[lift_end:n - 100] = 3
    path = _wrist_archive(tmp_path / "w.h5", f, labels, ["0", "1", "2", "3", "4"])
    assert resolve_method("auto", "wrench") == "level"
    assert resolve_method("auto", "strain") == "glr"
    with open_archive(path) as archive:
        trial = archive.trial("w")
        seg = segment_trial(trial)
        assert seg.parameters["method"] == "level"
        lmap = {"1": "free", "2": "contact", "3": "free", "4": "contact"}
        truth = truth_boundaries_s(trial, lmap)
        # the dip is inside contact and the unlabelled end is no boundary
        np.testing.assert_allclose(truth, [touch / FS, lift_end / FS])
        assert truth_boundaries_s(trial, None) is None     # no segment table written
        late = np.array([seg.times[-5]])
        assert labelled_only(trial, late, lmap).size == 0
        m = boundary_metrics(truth, seg.boundaries_s, times=seg.times, tolerance_s=0.25)
        assert m["f1"] == 1.0


def test_cli_segment_names_the_method_and_lists_events(tmp_path):
    import json

    from click.testing import CliRunner

    from contactlab.cli import main

    f, *_ = _wiping_like()
    path = _wrist_archive(tmp_path / "w.h5", f)
    r = CliRunner().invoke(main, ["segment", str(path), "-q"])
    assert r.exit_code == 0, r.output
    assert "2 boundaries" in r.output and "(level)" in r.output and "1 event inside" in r.output
    r = CliRunner().invoke(main, ["segment", str(path), "-q", "--json"])
    entry = json.loads(r.output)["trials"]["w"]
    assert entry["method"] == "level" and len(entry["events_s"]) == 1
    r = CliRunner().invoke(main, ["segment", str(path), "-q", "--method", "level",
                                  "--threshold", "3"])
    assert r.exit_code == 2 and "(0, 1]" in r.output
