"""impact-spectrogram, ar-fit, impact-envelope (figs 7.1-7.3): analysis against oracles, pages."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from scipy import signal

from contactlab.experiments import ar_fit, get, impact_envelope, impact_spectrogram as isp

FS = 2700.0


def damped(n, *, fs, f_hz, decay, amp=1.0, phase=0.3, start=0):
    t = (np.arange(n) - start) / fs
    x = amp * np.exp(-decay * t) * np.cos(2 * math.pi * f_hz * t + phase)
    x[t < 0] = 0.0
    return x


# -- impact-spectrogram -------------------------------------------------------------------------
def test_spectrogram_column_is_a_hamming_windowed_fft():
    rng = np.random.default_rng(0)
    x = rng.standard_normal(400)
    f, t, P = isp.spectrogram(x, fs=FS, band=(0.0, FS / 2))
    assert P.shape[1] == len(x) - isp.NPERSEG + 1          # one FFT per new sample (hop 1)
    j = 123
    seg = x[j:j + 64] - x[j:j + 64].mean()
    w = np.hamming(65)[:-1]                                  # periodic Hamming (scipy's default)
    X = np.fft.rfft(w * seg)
    ref = np.abs(X) ** 2 / (FS * np.sum(w * w))
    ref[1:-1] *= 2
    np.testing.assert_allclose(P[:, j], ref, rtol=1e-10, atol=1e-14)
    assert t[j] == pytest.approx((j + 32) / FS)


def test_spectrogram_peak_of_damped_690hz_is_within_a_bin():
    rng = np.random.default_rng(1)
    x = damped(2000, fs=FS, f_hz=690.0, decay=80.0, start=300) + 1e-3 * rng.standard_normal(2000)
    x[300] += 5.0                                           # an impulse: broad band at the impact
    f, t, P = isp.spectrogram(x, fs=FS)
    assert f[0] >= 200 and f[-1] <= 1350
    peak = isp.spectrogram_peak(f, t, P, t0=(300 + 40) / FS, t1=(300 + 500) / FS)
    assert abs(peak - 690.0) <= FS / 64
    bw = isp.broad_bandwidth(f, P)
    at_impact = np.argmin(np.abs(t - 300 / FS))
    ringing = (t > 340 / FS) & (t < 480 / FS)             # windows after the impulse, above noise
    assert bw[at_impact] > 3 * np.median(bw[ringing])


def test_damped_sinusoid_fit_and_hilbert_recover_frequency_and_decay():
    rng = np.random.default_rng(2)
    x = damped(120, fs=FS, f_hz=734.0, decay=98.0, amp=0.4) + 0.01 + 2e-3 * rng.standard_normal(120)
    fit = isp.fit_damped_sinusoid(x, fs=FS)
    assert fit["f_hz"] == pytest.approx(734.0, abs=1.0)
    assert fit["decay_per_s"] == pytest.approx(98.0, rel=0.03)
    w = 2 * math.pi * 734.0
    assert fit["zeta"] == pytest.approx(98.0 / math.hypot(98.0, w), rel=0.03)
    assert isp.hilbert_decay(x, fs=FS) == pytest.approx(98.0, rel=0.15)
    assert isp.periodogram_peak(x, fs=FS) == pytest.approx(734.0, abs=15.0)


def test_mode_prediction_matches_two_mass_eigenvalues():
    from contactlab.sim import Apparatus

    app = Apparatus()
    K, B, ms, mr = app.sensor_stiffness, app.sensor_damping, app.shell_mass, app.robot_mass
    # state (x_s, x_r, v_s, v_r), free base: both masses move, joined by K and B
    M = np.diag([ms, mr])
    Kq = np.array([[K, -K], [-K, K]])
    Bq = np.array([[B, -B], [-B, B]])
    A = np.block([[np.zeros((2, 2)), np.eye(2)], [-np.linalg.solve(M, Kq), -np.linalg.solve(M, Bq)]])
    lam = np.linalg.eigvals(A)
    osc = lam[np.abs(lam.imag) > 1.0][0]
    pred = isp.mode_prediction(app)
    assert pred["free_base"]["f_damped_hz"] == pytest.approx(abs(osc.imag) / (2 * math.pi), rel=1e-9)
    assert pred["free_base"]["decay_per_s"] == pytest.approx(-osc.real, rel=1e-9)
    lam0 = np.roots([ms, B, K])                               # fixed base: one mass on K, B
    assert pred["fixed_base"]["f_damped_hz"] == pytest.approx(abs(lam0[0].imag) / (2 * math.pi))
    assert pred["fixed_base"]["f_hz"] == pytest.approx(690.0)


def test_free_flights_are_bounded_by_contacts():
    c = np.zeros(40, bool)
    c[5:8] = c[20:22] = c[30:31] = True
    assert isp.free_flights(c, 5, 35) == [(8, 20), (22, 30)]   # the run after 31 is not closed


# -- ar-fit ------------------------------------------------------------------------------------
def _ar4(n, rng):
    # poles 0.9 e^{+-i 0.8}, 0.7 e^{+-i 2.0}
    poles = [0.9 * np.exp(1j * 0.8), 0.9 * np.exp(-1j * 0.8), 0.7 * np.exp(2j), 0.7 * np.exp(-2j)]
    a = np.real(np.poly(poles))                               # 1, -a1, ..., -a4
    e = rng.standard_normal(n + 500)
    return signal.lfilter([1.0], a, e)[500:] + 3.0, -a[1:]


def test_ar_fit_recovers_a_known_ar4_and_its_residuals_are_white():
    rng = np.random.default_rng(3)
    y, coef = _ar4(20000, rng)
    res = ar_fit.analyse(y, fs=1000.0)
    np.testing.assert_allclose(res["coef"][1:], coef, atol=0.03)
    assert res["coef"][0] / (1 - coef.sum()) == pytest.approx(3.0, abs=0.1)   # mu = mean (1 - sum a)
    assert res["variance"] == pytest.approx(1.0, rel=0.05)
    assert res["ljung_box"]["p_value"] > 1e-3
    assert res["acf_outside"] <= 10                          # 50 lags, ~2.5 expected
    assert res["best_bic"] == 4
    table = {r["order"]: r for r in res["order_table"]}
    assert table[3]["ljung_box_p"] < 1e-6                    # too low an order is not white


def test_autocorrelation_matches_direct_sum():
    x = np.random.default_rng(4).standard_normal(300)
    r = ar_fit.autocorrelation(x, max_lag=10)
    d = x - x.mean()
    ref = np.array([np.dot(d[:len(d) - k], d[k:]) for k in range(11)]) / np.dot(d, d)
    np.testing.assert_allclose(r, ref, atol=1e-12)


def test_ljung_box_size_and_power():
    rng = np.random.default_rng(5)
    pv = np.array([ar_fit.ljung_box(rng.standard_normal(500), lags=20)["p_value"] for _ in range(300)])
    assert 0.02 <= np.mean(pv < 0.05) <= 0.09                # chi-square(20) null: ~5 % rejections
    e = signal.lfilter([1.0], [1.0, -0.3], rng.standard_normal(500))
    assert ar_fit.ljung_box(e, lags=20)["p_value"] < 1e-6


# -- impact-envelope -----------------------------------------------------------------------------
def test_log_energy_of_damped_ringing_falls_at_the_damping_rate():
    rng = np.random.default_rng(6)
    fs, decay = 1000.0, 30.0
    x = damped(1200, fs=fs, f_hz=734.0, decay=decay, amp=1.0, start=200)
    x = x + 1e-4 * rng.standard_normal(len(x))
    yd, _, yh = impact_envelope.high_energy(x, floor=1e-5)
    noise = float(np.median(yh[:40]))
    edges = impact_envelope.falling_edges(yh, start=45, noise_level=noise)
    assert len(edges) == 1
    f = impact_envelope.fit_edge(yh, edges[0])
    assert f["n"] >= 40
    assert f["a"] == pytest.approx(impact_envelope.predicted_slope(decay, fs=fs), rel=0.08)


def test_step_and_linear_decay_with_a_second_bounce():
    rng = np.random.default_rng(7)
    y = -6.0 + 0.2 * rng.standard_normal(140)
    y[20:50] = -1.0 - 0.10 * np.arange(30) + 0.2 * rng.standard_normal(30)   # first impact
    y[50:90] = -2.0 - 0.08 * np.arange(40) + 0.2 * rng.standard_normal(40)   # a bounce re-excites
    edges = impact_envelope.falling_edges(y, start=15, noise_level=-6.0)
    assert len(edges) == 2
    (a0, b0), (a1, b1) = edges
    assert a0 in range(19, 23) and b0 in range(44, 51) and a1 in range(49, 53)
    for e, slope in zip(edges, (-0.10, -0.08)):
        f = impact_envelope.fit_edge(y, e)
        assert abs(f["a"] - slope) < 4 * f["a_se"] + 0.01


# -- the pages ----------------------------------------------------------------------------------
def _page(tmp, name):
    for fn in ("index.html", "report.pdf", "results.json"):
        assert (tmp / fn).stat().st_size > 500, (name, fn)
    assert "Where ours differ and why" in (tmp / "index.html").read_text()
    return json.loads((tmp / "results.json").read_text())


def test_impact_spectrogram_run(tmp_path):
    s = get("impact-spectrogram").run(out_dir=tmp_path, seed=0, quiet=True)
    data = _page(tmp_path, "impact-spectrogram")
    assert (tmp_path / "fig-7-1.png").exists() and data["rate_hz"] == 2700.0
    ring, pred = s["ringing"], s["prediction"]
    # the measured ringing is the simulator's free-base mode, within one bin of 690 Hz
    assert ring["fit_f_hz"] == pytest.approx(pred["free_base"]["f_damped_hz"], rel=0.02)
    assert abs(ring["spectrogram_peak_hz"] - ring["fit_f_hz"]) <= s["bin_width_hz"]
    assert ring["fit_decay_per_s"] == pytest.approx(pred["free_base"]["decay_per_s"], rel=0.2)
    assert s["broad_band"]["bandwidth_at_impact_hz"] > 3 * s["broad_band"]["bandwidth_ringing_hz"]


def test_ar_fit_run_on_a_short_trial(tmp_path):
    s = ar_fit.run(out_dir=tmp_path, seed=0, quiet=True, duration_s=3.3)
    data = _page(tmp_path, "ar-fit")
    assert (tmp_path / "fig-7-2.png").exists()
    assert data["order"] == 4 and len(data["order_selection"]) == ar_fit.MAX_ORDER
    assert s["r2"] > 0.3 and s["max_root_modulus"] < 1.0      # a stable model that explains a lot
    assert s["residual_acf"]["outside_band"] < 0.3 * ar_fit.ACF_LAGS


def test_impact_envelope_run(tmp_path):
    s = impact_envelope.run(out_dir=tmp_path, seed=0, quiet=True, n_trials=2)
    _page(tmp_path, "impact-envelope")
    first = s["first_edge"]
    assert s["rate_out_hz"] == 250.0 and s["step_rise_nats"] > 2.0
    assert first["a"] < 0 and first["bounces_inside"] == 0
    assert first["a"] == pytest.approx(s["predicted"]["free_base"], abs=4 * first["a_se"] + 0.02)
    assert s["trials"]["n"] == 2 and s["trials"]["first_edge"][0]["a"] == first["a"]
