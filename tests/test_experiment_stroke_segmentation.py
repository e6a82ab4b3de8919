"""stroke-segmentation experiment: truth rule, evaluation, peers' cost, detectability.

Oracles: hand-built label sequences and simulator states with known phases,
AR(2) signals from scipy.signal.lfilter with variance changes placed by
construction, ruptures' own CostAR, and the closed form of the Page-Hinkley
increment (6.14).
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.signal import lfilter

from contactlab.experiments import get
from contactlab.acquire.stroke_phases import PHASES, merge_short_runs, phase_codes, truth_phases
from contactlab.experiments.stroke_segmentation import detectability, evaluate, per_boundary_hits
from contactlab.peers.ruptures_ar import ChannelARCost, FastChannelARCost
from contactlab.segmentation import segment_signal

FS = 250.0


def ar2(n, *, sigma=1.0, seed=0, channels=8, a=(1.2, -0.5)):
    rng = np.random.default_rng(seed)
    e = rng.normal(scale=sigma, size=(n + 200, channels))
    return lfilter([1.0], [1.0, -a[0], -a[1]], e, axis=0)[200:]


def pieces(*specs, seed=0):
    """AR(2) pieces (n samples, sigma), each with its own noise; and the change samples."""
    y = np.concatenate([ar2(n, sigma=s, seed=seed + i) for i, (n, s) in enumerate(specs)])
    return y, np.cumsum([n for n, _ in specs])[:-1]


# -- the truth-merge rule ----------------------------------------------------------------

def test_merge_removes_a_5_ms_flicker_and_keeps_a_1_s_phase():
    rate = 1000
    codes = np.r_[np.zeros(1000), np.ones(5), np.zeros(995), np.full(1000, 2), np.zeros(1000)]
    merged = merge_short_runs(codes.astype(int), min_len=100)
    expected = np.r_[np.zeros(2000), np.full(1000, 2), np.zeros(1000)].astype(int)
    np.testing.assert_array_equal(merged, expected)
    phases = truth_phases(merged, np.arange(len(codes)) / rate)
    assert [p["start_s"] for p in phases] == [0.0, 2.0, 3.0]


def test_merge_puts_a_flickering_transition_where_the_new_phase_lasts():
    # 0 for 1 s, then 0/1 alternating in 10-30 ms runs, then 1 for 1 s: the boundary moves
    # to the start of the first run of 1 that is long enough (t = 1.08 s)
    codes = np.r_[np.zeros(1000), np.ones(20), np.zeros(10), np.ones(30), np.zeros(20),
                  np.ones(1000)].astype(int)
    merged = merge_short_runs(codes, min_len=100)
    np.testing.assert_array_equal(merged, np.r_[np.zeros(1080), np.ones(1000)].astype(int))


def test_merge_keeps_runs_at_least_min_len_and_handles_a_short_first_run():
    codes = np.r_[np.full(3, 5), np.full(200, 1), np.full(200, 2)].astype(int)
    merged = merge_short_runs(codes, min_len=100)
    np.testing.assert_array_equal(merged, np.r_[np.full(203, 1), np.full(200, 2)])
    same = np.r_[np.full(100, 1), np.full(100, 2)].astype(int)
    np.testing.assert_array_equal(merge_short_runs(same, min_len=100), same)


def test_phase_codes_from_a_simulator_like_state():
    rate = 1000.0
    t = np.arange(7000) / rate
    moving = (t >= 1.2) & (t < 5.0)
    texture = np.where(t < 3.0, 0, 1)
    wrench = np.zeros((len(t), 6))
    wrench[:, 0] = np.where(t < 5.5, -0.12, 0.03 - 0.15 * np.exp(-np.maximum(t - 5.5, 0) / 0.005))
    codes = phase_codes(time=t, moving=moving, impact=np.zeros(len(t), bool), texture=texture,
                        wrench=wrench, command_start_s=0.5, command_end_s=5.5)
    name = lambda s: PHASES[codes[int(round(s * rate))]]  # noqa: E731
    assert name(0.2) == "resting" and name(0.7) == "strain build-up"
    assert name(2.0) == "rough texture" and name(4.0) == "smooth texture"
    assert name(5.2) == "stopped, command running" and name(6.0) == "resting after stop"
    # the drop: from 5.5 until the exponential is within 10 % of its step, tau ln 10 = 11.5 ms
    drop = np.flatnonzero(codes == PHASES.index("drop at stop"))
    assert drop[0] == 5500 and drop[-1] + 1 == 5500 + int(np.ceil(5 * np.log(10)))


# -- evaluation --------------------------------------------------------------------------

def _synthetic_trial(y, changes, tid="syn"):
    times = np.arange(len(y)) / FS
    return {"id": tid, "y": y, "times": times, "truth_s": changes / FS,
            "truth_names": [f"piece {i + 1}" for i in range(len(changes))]}


def test_two_known_variance_changes_are_found_with_f1_one():
    y, changes = pieces((600, 1.0), (600, 3.0), (600, 1.0), seed=3)
    trial = _synthetic_trial(y, changes)
    seg = segment_signal(y, fs=FS, threshold=200.0)
    m = evaluate([trial], {"syn": seg.boundaries_s})
    assert (m["n_true"], m["f1"], m["precision"], m["recall"]) == (2, 1.0, 1.0, 1.0)
    hits = per_boundary_hits([trial], {"syn": seg.boundaries_s})
    assert all(h["hit"] == 1 and abs(h["offsets"][0]) < 0.1 for h in hits.values())


def test_evaluation_counts_misses_and_false_alarms():
    y, changes = pieces((600, 1.0), (600, 3.0), (600, 1.0), seed=3)
    trial = _synthetic_trial(y, changes)
    b = changes / FS
    # one truth boundary found (+40 ms), one missed, one false alarm 1 s away
    m = evaluate([trial], {"syn": np.array([b[0] + 0.04, b[1] + 1.0])})
    assert (m["precision"], m["recall"]) == (0.5, 0.5)
    # outside the tolerance (0.1 s) does not count
    assert evaluate([trial], {"syn": np.array([b[0] + 0.12])})["recall"] == 0.0


def test_sweep_boundary_count_does_not_increase_with_threshold():
    y, _ = pieces((500, 1.0), (400, 1.8), (500, 1.0), (400, 0.5), (500, 1.0), seed=11)
    counts = [len(segment_signal(y, fs=FS, threshold=thr))
              for thr in (25, 35, 50, 70, 100, 140, 200, 280, 400)]
    assert counts == sorted(counts, reverse=True)
    assert counts[0] > counts[-1] >= 2


# -- the peers' cost ---------------------------------------------------------------------

def test_fast_cost_equals_ruptures_costar_per_channel():
    from ruptures.costs import CostAR

    y = ar2(700, seed=5, channels=3) + np.array([5.0, -2.0, 0.3])   # offsets: the intercept
    fast, slow = FastChannelARCost().fit(y), ChannelARCost().fit(y)
    per = [CostAR(order=2).fit(y[:, [c]].copy()) for c in range(3)]
    for a, b in ((0, 700), (0, 10), (1, 40), (250, 600), (690, 700)):
        ref = sum(c.error(a, b) for c in per)
        assert slow.error(a, b) == pytest.approx(ref, rel=1e-12)
        assert fast.error(a, b) == pytest.approx(ref, rel=1e-8)


def test_ruptures_costar_misreads_a_multichannel_signal():
    # the reason for ChannelARCost: CostAR's lags come from the flattened array
    from ruptures.costs import CostAR

    y = ar2(700, seed=6, channels=4)
    whole = CostAR(order=2).fit(y.copy()).error(0, 700)
    per = sum(CostAR(order=2).fit(y[:, [c]].copy()).error(0, 700) for c in range(4))
    assert abs(whole - per) > 0.1 * per


# -- detectability (6.14) ----------------------------------------------------------------

def test_detectability_matches_the_closed_form():
    q, m = 2.5, 8
    no_change = detectability(np.ones(m), np.ones(m), q=q, threshold=200.0)
    assert no_change["drift_increase"] < 0 and no_change["drift_decrease"] < 0
    assert no_change["samples_to_threshold"] == float("inf")
    d = detectability(np.full(m, 3.0), np.ones(m), q=q, threshold=200.0)   # variance falls 3x
    expected = 0.5 * (m * np.log(q) + (1 - q) * m / 3.0)
    assert d["drift_decrease"] == pytest.approx(expected)
    assert d["samples_to_threshold"] == pytest.approx(200.0 / expected)
    edge = d["decrease_needs_per_dof_below"]
    assert edge == pytest.approx(np.log(q) / (q - 1))
    at_edge = detectability(np.full(m, 1 / edge), np.ones(m), q=q, threshold=200.0)
    assert at_edge["drift_decrease"] == pytest.approx(0.0, abs=1e-12)


def test_registered():
    assert get("stroke-segmentation").implemented


def test_quick_run_writes_page_and_summary(tmp_path):
    from contactlab.experiments.stroke_segmentation import run

    out = run(out_dir=tmp_path, seed=0, quiet=True, trials_per_spec=1, pelt_timed=0,
              beta_grid=(10.0, 30.0), fa_seconds=20.0)
    assert (tmp_path / "index.html").exists() and (tmp_path / "results.json").exists()
    assert out["trials"] == ["stroke-a-000", "stroke-b-000"]
    for tid, truth in out["truth"].items():
        # the merged truth: build-up, rough, smooth, (drop,) resting (the burst rings without a
        # contact event; the drop at the stop lasts about the 0.1 s merge limit, so it is kept or
        # merged by a millisecond; the constant-velocity command slides to its end); on sample
        # B's wood the friction hold is shorter than the 0.1 s merge and joins the rest
        tail = ["rough texture", "smooth texture", "resting after stop"]
        phases = [p for p in truth["phases"] if p != "drop at stop"]
        assert phases[-3:] == tail, tid
        if tid.startswith("stroke-a"):
            assert phases == ["strain build-up"] + tail
            assert truth["boundaries_s"][0] == pytest.approx(0.5)      # the command start
        assert truth["boundaries_s"] == sorted(truth["boundaries_s"])
    assert out["merged_flicker_runs"]["max_s"] < 0.1
    sweep = out["sweep"]
    counts = [sweep[k]["mean_boundaries"] for k in sweep]
    assert counts == sorted(counts, reverse=True)
    # the per-channel combination: its own sweep, best threshold and side-by-side rows
    ch = out["channel"]
    assert set(ch["sweep"]) == set(sweep)
    best = ch["best_threshold"]
    assert ch["sweep"][f"{best:g}"]["f1"] == max(r["f1"] for r in ch["sweep"].values())
    assert out["side_by_side"][f"contactlab channel @ {best:g} (best F1)"]["f1"] == \
        ch["sweep"][f"{best:g}"]["f1"]
    fa = ch["false_alarms_per_1000_s"]
    assert set(fa["channel"]) == set(fa["sum"]) and len(fa["sum"]) >= 3
    assert f"channel@{best:g}" in out["timing"]["per_trial_s"]
