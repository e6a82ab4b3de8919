"""Gaussian phase models: the per-sample weight of the lowpassed phase stream, and Page's
test against the known successors (``rival``).

Oracles: the weight against the variance of block means of filtered white noise; the
weighted log-likelihood and the rival margin against scipy's densities; the compiled
core against the general form to the bit; and a change into a narrow phase inside the
current phase's spread, which the covariance tests cannot see, found by the rival test.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.signal import lfilter
from scipy.stats import multivariate_normal

from contactlab.observer import Observer, observe
from contactlab.observer.graph import parse_graph
from contactlab.observer.models.gaussian import GaussianFeature, gaussian_step, rate_weighted
from contactlab.signals import (HF_SAMPLE_WEIGHT, phase_filter, phase_sample_weight,
                                sample_weight)
from tests.conftest import assert_same_observer_results


@pytest.mark.parametrize("fs", [100.0, 200.0, 500.0])
def test_weight_is_the_inverse_autocorrelation_time_of_filtered_white_noise(fs):
    # block means of long filtered white noise: their variance times the block length
    # over the filtered variance is the integrated autocorrelation time 1 / w
    rng = np.random.default_rng(3)
    b, a = phase_filter(fs)
    y = lfilter(b, a, rng.standard_normal(4_000_000))[1000:]
    block = int(40 * fs / 5.0)
    m = y[:len(y) // block * block].reshape(-1, block).mean(axis=1)
    tau = m.var() * block / y.var()
    assert phase_sample_weight(fs) == pytest.approx(1.0 / tau, rel=0.06)


def test_weight_falls_with_the_rate_and_is_one_off_the_phase_stream():
    assert 0.10 < phase_sample_weight(100.0) < 0.12          # 5 Hz at 100 Hz
    assert phase_sample_weight(200.0) == pytest.approx(phase_sample_weight(100.0) / 2,
                                                       rel=0.03)
    assert sample_weight("phase", None) == 1.0 and sample_weight("wrench", 250.0) == 1.0


def test_the_y_h_weight_is_its_inverse_autocorrelation_time_on_independent_differences():
    # y_h of 7.1 (blocks of 8 differences every 4) over independent differences: block
    # means of y_h give its integrated autocorrelation time, 2 from the half overlap
    from contactlab.conditioning import log_energy

    y = np.asarray(log_energy(np.random.default_rng(0).standard_normal(2_000_000),
                              block=8, factor=4)).ravel()
    block = 400
    m = y[:len(y) // block * block].reshape(-1, block).mean(axis=1)
    tau = m.var() * block / y.var()
    assert sample_weight("hf", 250.0) == HF_SAMPLE_WEIGHT == pytest.approx(1.0 / tau,
                                                                           rel=0.05)


def _gauss(name, mean, cov, **kw):
    return GaussianFeature(name=name, mean=mean, cov=cov, **kw)


def test_weighted_log_likelihood_rival_margin_and_compiled_step_against_scipy():
    rng = np.random.default_rng(0)
    covs = []
    for _ in range(3):
        A = rng.standard_normal((3, 3))
        covs.append(A @ A.T + np.eye(3))
    means = rng.standard_normal((3, 3))
    r1 = _gauss("r1", means[1], covs[1], weight=0.3)
    r2 = _gauss("r2", means[2], covs[2], weight=0.3)
    m = _gauss("m", means[0], covs[0], weight=0.3, rivals=[r1, r2])
    x = rng.standard_normal((40, 3)) * 2
    d = [0.3 * multivariate_normal(means[k], covs[k]).logpdf(x) for k in range(3)]
    ll, chi = m.score(x)
    np.testing.assert_allclose(ll, d[0], rtol=1e-10)
    plain = _gauss("p", means[0], covs[0])
    np.testing.assert_allclose(chi, plain.score(x)[1])       # the chi-square unweighted
    np.testing.assert_allclose(m.rival_margin(x), np.maximum(d[1], d[2]) - d[0], rtol=1e-9,
                               atol=1e-9)
    assert m.tests == ("increase", "rival") and plain.tests == ("increase",)
    for i in range(5):
        a, b, z = gaussian_step(m._p, x[i])
        assert a == pytest.approx(ll[i], rel=1e-12) and b == pytest.approx(chi[i])
        assert z == pytest.approx(max(d[1][i], d[2][i]) - d[0][i], rel=1e-9, abs=1e-9)
    with pytest.raises(ValueError, match="weight"):
        _gauss("w", means[0], covs[0], weight=0.0)
    with pytest.raises(ValueError, match="rival"):
        _gauss("w", means[0], covs[0], rivals=[_gauss("two", [0.0], [[1.0]])])


def test_the_weight_follows_the_rate_of_the_data_scored():
    m = _gauss("a", [0.0], [[1.0]], signal="phase")
    other = _gauss("b", [0.0], [[1.0]], signal="wrench")
    out = rate_weighted({"a": m, "b": other}, 200.0)
    assert out["a"].weight == pytest.approx(phase_sample_weight(200.0))
    assert out["b"] is other and m.weight == 1.0
    # the observer given the recording's rate weighs its models the same way
    g = _chain(["a", "b"], ["a -> b"])
    obs = Observer(g, {"a": m, "b": _gauss("b", [1.0], [[1.0]], signal="phase")},
                   rate_hz=200.0)
    assert obs.models["a"].weight == pytest.approx(phase_sample_weight(200.0))
    plain = Observer(g, {"a": m, "b": _gauss("b", [1.0], [[1.0]], signal="phase")})
    assert plain.models["a"].weight == 1.0


def _chain(names, edges):
    return parse_graph({"name": "g", "models": {k: {"kind": "gaussian"} for k in names},
                        "nodes": [{"name": k, "models": k, "initial": float(k == names[0])}
                                  for k in names], "edges": edges})


def test_each_model_rivals_the_gaussians_of_the_nodes_that_may_follow():
    g = _chain(["A", "B", "C"], ["A -> B", "A -> C", "B -> C"])
    ms = {k: _gauss(k, [float(i)], [[1.0]]) for i, k in enumerate("ABC")}
    obs = Observer(g, ms)
    assert [r.name for r in obs.models["A"].rivals] == ["B", "C"]
    assert [r.name for r in obs.models["B"].rivals] == ["C"]
    assert obs.models["C"].rivals == () and obs.tests_[-1] == "rival"
    assert ms["A"].rivals == ()                       # the caller's models are untouched


class GeneralGaussian(GaussianFeature):
    def core_spec(self, channels):
        return None


def _broad_then_narrow(seed, n0=400, n1=400):
    """Phase A: a broad Gaussian over two levels (+-3); then phase B, narrow, at 1 --
    inside A's spread, so B's samples give A's chi-square less than its mean."""
    rng = np.random.default_rng(seed)
    a = np.where(rng.random(n0) < 0.5, -3.0, 3.0) + rng.normal(0, 0.5, n0)
    b = 1.0 + rng.normal(0, 0.3, n1)
    return np.r_[a, b][:, None], n0


@pytest.mark.parametrize("weight", [1.0, 0.2])
def test_a_change_into_a_phase_inside_the_current_ones_spread_is_found(weight):
    y, n0 = _broad_then_narrow(1)
    A = GaussianFeature(name="A", signal="x").fit([y[:n0]])
    B = GaussianFeature(name="B", signal="x").fit([y[n0:]])
    ms = {"A": A.with_weight(weight), "B": B.with_weight(weight)}
    assert np.mean(A.score(y[n0:])[1]) < 1.0           # B lies inside A's spread
    res = observe(Observer(_chain(["A", "B"], ["A -> B"]), ms), y)
    starts = dict((n, s) for n, s in res.map_path)
    assert "B" in starts and n0 <= starts["B"] <= n0 + 20 / weight
    assert np.mean(res.labels[n0 + int(40 / weight):] == 1) == 1.0


def test_the_compiled_core_gives_the_general_forms_results_with_rivals():
    y, n0 = _broad_then_narrow(2, 500, 300)
    y = np.r_[y, _broad_then_narrow(3, 300, 0)[0]]
    segs = {"A": [y[:n0]], "B": [y[n0:n0 + 300]]}

    def models(cls):
        return {k: cls(name=k, signal="x").fit(v).with_weight(0.5)
                for k, v in segs.items()}

    g = _chain(["A", "B"], ["A -> B", "B -> A"])
    core, general = Observer(g, models(GaussianFeature)), Observer(g, models(GeneralGaussian))
    fast, slow = observe(core, y, chunk=97), observe(general, y, chunk=97)
    assert core._core is not None and general._core is None
    assert len([e for e in slow.events if e.model]) >= 2
    assert_same_observer_results(fast, slow)


def test_the_test_against_r_rivals_alarms_at_t_plus_log_r():
    """Page's test against the best of R known successors alarms when the cumulative
    margin (6.18 on max_r ll_r - ll) reaches T + log R: the maximum of R tests would
    otherwise alarm about R times as often.  Oracle: the margins from scipy's densities,
    the cumulative sum reset at zero, its first crossing of T + log 3."""
    from scipy.stats import norm

    y, n0 = _broad_then_narrow(4)
    A = GaussianFeature(name="A", signal="x").fit([y[:n0]])
    rivals = {"B": (1.0, 0.3), "C": (1.2, 0.3), "D": (0.8, 0.3)}
    ms = {"A": A, **{k: _gauss(k, [m], [[s * s]], signal="x") for k, (m, s) in rivals.items()}}
    g = _chain(["A", "B", "C", "D"], ["A -> B", "A -> C", "A -> D"])
    T = 8.0
    obs = Observer(g, ms, threshold=T)
    res = observe(obs, y)
    alarms = [e for e in res.events if e.model]
    assert alarms[0].model == "A"
    first = alarms[0].time
    x = y[:, 0]
    ll_a = multivariate_normal(A.mean, A.cov).logpdf(y)
    z = np.max([norm(m, s).logpdf(x) for m, s in rivals.values()], axis=0) - ll_a
    stat, cross = 0.0, None
    for t, zt in enumerate(z):
        stat = max(0.0, stat + zt)
        if stat > T + np.log(3):
            cross = t
            break
    assert cross is not None and n0 <= cross and first == cross
    k = obs.tests_.index("rival")
    assert obs._side_b[obs._model_names.index("A"), k] == pytest.approx(T / (T + np.log(3)))
