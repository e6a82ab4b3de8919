"""ROC theory (Wald, Siegmund, Hall) and Monte Carlo of section 6.3.1."""

from __future__ import annotations

import numpy as np
import pytest

from contactlab.detection import LowpassThreshold, PageHinkley, mean_increment, roc


def test_wald_reproduces_the_thesis_operating_point():
    # "alarms on average every 6e6 samples and detects after 28" (s = 1, T^2 = 15)
    assert roc.wald_false_alarm_time(15.0, s=1.0) == pytest.approx(6.538e6, rel=1e-3)
    assert roc.wald_detection_delay(15.0, s=1.0) == pytest.approx(28.0, abs=1e-5)
    # Siegmund: T^2 -> T^2 + 2 rho s with rho = 0.5826
    assert roc.RHO == pytest.approx(0.5826, abs=1e-4)
    expected = 2 * (14 + 2 * roc.RHO)
    assert roc.siegmund_detection_delay(15.0, s=1.0) == pytest.approx(expected, rel=1e-6)


def test_lowpass_theory_values():
    # threshold dmu/2 at a = 0.98, s = 1: T^2 = 24.75; Hall one-sided t_F ~ 3.9e6
    assert roc.lowpass_threshold_t2(0.98, s=1.0) == pytest.approx(24.75)
    assert roc.hall_false_alarm_time(0.98, s=1.0) == pytest.approx(3.918e6, rel=1e-3)
    assert roc.hall_false_alarm_time(0.98, s=1.0, one_sided=False) == pytest.approx(1.959e6,
                                                                                    rel=1e-3)
    assert roc.lowpass_rise_time(0.98) == pytest.approx(34.31, abs=0.01)  # thesis: 34.5
    assert np.isnan(roc.hall_false_alarm_rate(0.9, threshold_t2=0.8))  # outside its validity
    # the printed per-step probability has no k and is ~0.94: delay ~1 sample
    assert roc.lowpass_termination_probability_as_printed(0.98, s=1.0) == pytest.approx(0.943,
                                                                                        abs=1e-3)
    d = roc.lowpass_delay_erf(np.array([0.9, 0.95, 0.98]), s=1.0)
    assert np.all(np.diff(d) > 0) and d[2] == pytest.approx(25.13, abs=0.01)


def test_mc_delay_agrees_with_wald_up_to_the_overshoot():
    # Wald's t_D ignores the overshoot: it is low by about 2 rho s / beta samples
    # (2.33 at s = 1). Tolerance: Wald <= MC <= Wald + 2.33 + 0.5, and Siegmund
    # (which adds the overshoot) within 0.5 samples (about 4 standard errors).
    t2 = np.array([6.0, 8.0, 12.0])
    res = roc.ph_delay_mc(s=1.0, threshold=t2, rng=np.random.default_rng(3), n_runs=4000)
    wald = roc.wald_detection_delay(t2, s=1.0)
    assert (res.stderr < 0.15).all() and (res.n_censored == 0).all()
    assert (res.mean > wald).all()
    assert (res.mean < wald + 2 * roc.RHO * 1.0 / 0.5 + 0.5).all()
    np.testing.assert_allclose(res.mean, roc.siegmund_detection_delay(t2, s=1.0), atol=0.5)


def test_mc_false_alarm_time_within_the_overshoot_factor_of_wald():
    # Wald's t_F is low by about exp(2 rho s) = 3.2 at s = 1; allow MC/Wald in
    # [1, 1.25 * 3.2], and MC within 15 % (3 standard errors at 400 alarms) of Siegmund.
    t2 = np.array([4.0, 6.0])
    res = roc.ph_false_alarm_mc(s=1.0, threshold=t2, rng=np.random.default_rng(4),
                                n_runs=128, max_samples=4e6, target_alarms=400)
    assert (res.n_events >= 400).all()
    ratio = res.mean / roc.wald_false_alarm_time(t2, s=1.0)
    assert (ratio > 1).all() and (ratio < 1.25 * np.exp(2 * roc.RHO)).all()
    np.testing.assert_allclose(res.mean, roc.siegmund_false_alarm_time(t2, s=1.0), rtol=0.15)


def test_lowpass_mc_against_hall_and_delay_estimates():
    a = np.array([0.9, 0.95])  # T^2 = 4.75, 9.75 at s = 1
    fa = roc.lowpass_false_alarm_mc(a=a, threshold=0.5, rng=np.random.default_rng(5),
                                    n_runs=128, max_samples=4e6, target_alarms=300)
    assert (fa.n_events >= 300).all()
    assert (fa.mean > roc.hall_false_alarm_time(a, s=1.0)).all()  # Hall bounds t_F from below
    d = roc.lowpass_delay_mc(a=a, s=1.0, rng=np.random.default_rng(6), n_runs=3000,
                             burn_in=np.ceil(5 / (1 - a)).astype(int))
    assert (d.mean > roc.lowpass_delay_erf(a, s=1.0)).all()  # the per-step estimate is low
    np.testing.assert_allclose(d.mean, roc.lowpass_rise_time(a), rtol=0.15)


def test_mc_kernels_count_what_the_public_detectors_do():
    """The Monte Carlo loops use the detectors' arithmetic: same alarms on the same noise."""
    n, runs, chunk = 3000, 4, 1000
    res = roc.ph_false_alarm_mc(s=1.0, threshold=3.0, rng=np.random.default_rng(9),
                                n_runs=runs, max_samples=n * runs, target_alarms=10**9,
                                chunk=chunk)
    z = np.random.default_rng(9).standard_normal((n, runs), dtype=np.float32).astype(float)
    al = PageHinkley(threshold=3.0).run(mean_increment(z, mu0=0.0, dmu=1.0, sigma=1.0))
    assert res.n_events[0] == len(al) > 10 and res.exposure[0] == n * runs
    res = roc.lowpass_false_alarm_mc(a=0.8, threshold=0.9, rng=np.random.default_rng(9),
                                     n_runs=runs, max_samples=n * runs, target_alarms=10**9,
                                     chunk=chunk)
    assert res.n_events[0] == len(LowpassThreshold(a=0.8, threshold=0.9).run(z)) > 10
    # delays: first alarm at or after the change, per run
    burn = 40
    d = roc.ph_delay_mc(s=1.0, threshold=6.0, rng=np.random.default_rng(10), n_runs=runs,
                        burn_in=burn, max_delay=2000, chunk=2040)
    z = np.random.default_rng(10).standard_normal((2040, runs), dtype=np.float32).astype(float)
    z[burn:] += 1.0
    al = PageHinkley(threshold=6.0).run(mean_increment(z, mu0=0.0, dmu=1.0, sigma=1.0))
    t_first, _, _ = al.first(runs)
    ok = t_first >= burn  # runs that alarmed before the change are discarded
    assert d.n_discarded[0] == (~ok).sum()
    if ok.any():
        assert d.mean[0] == pytest.approx(np.mean(t_first[ok] - burn + 1))


def test_siegmund_threshold_inverts_the_false_alarm_time():
    for s in (0.5, 1.0, 2.0):
        for t2 in (2.0, 10.0, 30.0):
            tf = roc.siegmund_false_alarm_time(t2, s=s)
            assert roc.siegmund_threshold_for_false_alarm_time(tf, s=s) == pytest.approx(t2, rel=1e-9)
