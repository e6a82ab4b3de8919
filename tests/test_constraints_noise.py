"""Noise levels from the data (contactlab.constraints.noise) and estimate's summary."""

from __future__ import annotations

import math

import numpy as np
import pytest

from contactlab.conditioning import lowpass_decimate
from contactlab.constraints.noise import conditioned_noise_sd, lowpass_noise_gain, raw_noise_sd
from contactlab.synthetic import contact_trials, write_archive
from tests.conftest import one_json_object, run_cli


def test_raw_noise_of_white_noise_on_a_smooth_motion():
    rng = np.random.default_rng(0)
    t = np.arange(20000) / 1000.0
    motion = 0.004 * np.sin(2 * np.pi * 0.7 * t)[:, None] * np.array([1.0, -0.5, 0.2])
    for sd in (1e-5, 1e-4):
        y = motion + rng.normal(0, sd, motion.shape)
        assert raw_noise_sd(y) == pytest.approx(np.full(3, sd), rel=0.05)


def test_quantised_channel_gets_the_quantisation_error():
    step = 0.03e-3
    ramp = np.round(np.linspace(0, 0.002, 5000) / step) * step      # no noise, only steps
    assert raw_noise_sd(ramp)[0] == pytest.approx(step / math.sqrt(12.0), rel=1e-6)


def test_lowpass_noise_gain_is_the_variance_ratio_of_filtered_white_noise():
    rng = np.random.default_rng(1)
    e = rng.standard_normal((200000, 2))
    low = lowpass_decimate(e, fs=1000.0, cutoff_hz=125.0, factor=4)
    gain = lowpass_noise_gain(fs=1000.0, cutoff_hz=125.0)
    assert np.var(low[100:], axis=0) == pytest.approx(np.full(2, gain), rel=0.03)
    assert conditioned_noise_sd(0.02 * e, fs=1000.0, cutoff_hz=125.0) == pytest.approx(
        np.std(0.02 * low[100:], axis=0), rel=0.03)


def test_estimate_blocks_low_noise_suite_and_summary_per_degree(tmp_path):
    """Small case of the benchmark suite: 2 runs per degree, 0.01 mm / 10 mN."""
    path = tmp_path / "contacts.h5"
    write_archive(contact_trials(2, seed=3, position_sd=1e-5, force_sd=0.01, duration_s=1.0),
                  path)
    res = run_cli("estimate", path, "--block", "25", "--json", "-q")
    assert res.exit_code == 0, res.output
    out = one_json_object(res.stdout)
    s = out["summary"]
    assert s["degree_correct"] >= 0.9
    per = s["per_true_degree"]
    assert set(per) == {"0", "1", "2", "3"}
    for m, entry in per.items():
        assert entry["right"] + entry["wrong"] + entry["undecided"] == entry["pieces"]
        assert ("median_angle_error_deg" in entry) == (m in ("1", "2"))
    # the noise used is the data's: the raw level times the lowpass's noise gain
    noise = next(iter(out["trials"].values()))["noise"]
    gain = math.sqrt(lowpass_noise_gain(fs=1000.0, cutoff_hz=125.0))
    assert noise["position_sd"] == pytest.approx(1e-5 * gain, rel=0.15)
    assert noise["force_sd"] == pytest.approx(0.01 * gain, rel=0.15)


def test_undetermined_pieces_count_as_undecided(tmp_path):
    """Noise levels given 1000x too large leave no direction explored: those pieces are
    undecided, and the accuracy counts them (it is not taken over the decided ones)."""
    path = tmp_path / "contacts.h5"
    write_archive(contact_trials(1, seed=4, position_sd=1e-5, force_sd=0.01, duration_s=0.5),
                  path)
    out = one_json_object(run_cli("estimate", path, "--block", "25", "--position-noise", "0.01",
                                  "--force-noise", "10", "--json", "-q").stdout)
    s = out["summary"]
    assert s["undetermined"] > 0
    undecided = sum(e["undecided"] for e in s["per_true_degree"].values())
    assert undecided == s["undetermined"] + s["too_short"]
    assert s["degree_correct"] <= 1 - undecided / s["pieces"] + 1e-12


def test_sequential_blocks_decide_the_high_noise_suite(tmp_path):
    """Small case of the benchmark suite at 0.1 mm / 20 mN: a 0.1-s block alone often
    lacks motion in some free direction; decided with its segment's samples so far
    (the default) the degree is right far more often (0.93 on the suite's 800 blocks,
    >= 0.8 on these 80), the fit of each block uses every sample of its segment up to
    the block's end, and the reported angle sd covers the error of most blocks."""
    path = tmp_path / "contacts.h5"
    write_archive(contact_trials(1, seed=5, position_sd=1e-4, force_sd=0.02, duration_s=2.0),
                  path)
    seq = one_json_object(run_cli("estimate", path, "--block", "25", "--json", "-q").stdout)
    alone = one_json_object(run_cli("estimate", path, "--block", "25", "--independent",
                                    "--json", "-q").stdout)
    assert seq["summary"]["degree_correct"] >= 0.8
    assert alone["summary"]["degree_correct"] < seq["summary"]["degree_correct"] - 0.1
    rows = next(iter(seq["trials"].values()))["segments"]
    assert [r["n"] for r in rows[:3]] == [25, 25, 25]
    assert [r.get("n_fitted", r["n"]) for r in rows[:3]] == [25, 50, 75]
    for m in ("1", "2"):
        assert seq["summary"]["per_true_degree"][m]["angle_within_2sd"] >= 0.7
