"""The level random effect of the block likelihood (contactlab.temporal.level)."""

from __future__ import annotations

import json

import numpy as np
import pytest
from scipy import integrate
from scipy.signal import lfilter

from contactlab.temporal.features import block_features
from scipy.special import logsumexp

from contactlab.temporal.level import (conditional_prior, level_marginal, level_model, level_sd,
                                       nodes, scaled_features)
from contactlab.temporal.likelihood import block_loglik, loglik_params
from contactlab.temporal.model import ModelSet, fit_class


def _blocks(k, *, log_amp_sd=0.0, seed=0, channels=2, block=100, offset=0.0):
    rng = np.random.default_rng(seed)
    e = rng.standard_normal((k * block, channels))
    y = lfilter([1.0], [1.0, -1.2, 0.6], e, axis=0)
    amp = np.exp(rng.normal(0, log_amp_sd, (k, 1, channels)))
    return (y.reshape(k, block, channels) * amp).reshape(k * block, channels) + offset


@pytest.mark.parametrize("mean", [False, True])
def test_scaled_features_are_the_features_of_the_scaled_block(mean):
    y = _blocks(5, seed=1, offset=2.0 if mean else 0.0)
    s = np.array([1.7, 0.6])
    got = scaled_features(block_features(y, order=2, mean=mean), s)
    want = block_features(y / s, order=2, mean=mean)
    for name in ("reflection", "scale", "residual_energy"):
        assert np.allclose(getattr(got, name), getattr(want, name), rtol=1e-9, atol=1e-12)


def _class(seed, *, mean=False, channels=1, k=40):
    train = block_features(_blocks(k, log_amp_sd=0.3, seed=seed, channels=channels,
                                   offset=1.0 if mean else 0.0), order=2, mean=mean)
    return fit_class("a", train, block=100)


def _per_node_reference(test, model, tau, u0, slope, cov):
    """(2) node by node with the per-node features of the scaled block: the
    implementation before the nodes were vectorised, with the same grid."""
    x, logw = nodes(tau, test.rows)
    terms = []
    for xi, lw in zip(x, logw):
        du = tau * xi
        u = u0 + du
        terms.append(loglik_params(scaled_features(test, np.exp(u)),
                                   model.theta_mean + du[:, None] * slope, cov,
                                   model.noise_var) - test.rows * u + lw)
    return logsumexp(np.stack(terms), axis=0)


@pytest.mark.parametrize("mean", [False, True])
def test_vectorised_nodes_equal_the_node_by_node_sum_and_an_adaptive_integral(mean):
    model = _class(2, mean=mean, channels=2)
    test = block_features(_blocks(4, log_amp_sd=0.3, seed=3, channels=2,
                                  offset=1.0 if mean else 0.0), order=2, mean=mean)
    base = loglik_params(test, model.theta_mean, model.theta_cov, model.noise_var)
    assert np.array_equal(level_marginal(test, model.theta_mean, model.theta_cov,
                                         model.noise_var, np.zeros(2)), base)
    tau, u0 = np.array([0.3, 0.2]), np.array([-0.05, 0.1])
    q = model.n_params
    c = 0.5 * np.sqrt(np.diagonal(model.theta_cov, axis1=1, axis2=2)) * tau[:, None]
    c[1, -1] *= -1.0
    got = level_marginal(test, model.theta_mean, model.theta_cov, model.noise_var, tau,
                         level_mean=u0, level_cov=c)
    m, slope, cov = conditional_prior(model.theta_mean, model.theta_cov, tau, c)
    assert np.allclose(slope, c / tau[:, None] ** 2)            # no shrinking needed here
    ref = _per_node_reference(test, model, tau, u0, slope, cov)
    assert np.allclose(got, ref, rtol=0, atol=1e-8)
    M = test.rows
    for b in range(2):
        for ch in range(2):
            one = test.take([b])

            def integrand(u, one=one, ch=ch, ref=base[b, ch]):
                du = u - u0[ch]
                ll = loglik_params(scaled_features(one, np.exp(np.full(2, u))),
                                   m + du * slope, cov, model.noise_var)[0, ch]
                return np.exp(ll - M * u - ref) * np.exp(-du * du / (2 * tau[ch] ** 2)) / (
                    tau[ch] * np.sqrt(2 * np.pi))
            val, _ = integrate.quad(integrand, u0[ch] - 8 * tau[ch], u0[ch] + 8 * tau[ch],
                                    limit=200)
            assert got[b, ch] == pytest.approx(base[b, ch] + np.log(val), abs=1e-3)
    assert q == 2 + mean


def test_conditional_prior_is_the_normal_conditional_and_stays_positive_definite():
    rng = np.random.default_rng(6)
    J = rng.normal(size=(3, 3))
    joint = J @ J.T                                   # (k1, k2, u)
    V, c, t2 = joint[:2, :2], joint[:2, 2], joint[2, 2]
    m, slope, Vc = conditional_prior(np.zeros((1, 2)), V[None], np.sqrt([t2]), c[None])
    assert np.allclose(slope[0], c / t2)
    assert np.allclose(Vc[0], V - np.outer(c, c) / t2)
    # a sample covariance claiming correlation 1: shrunk, still positive definite
    _, _, Vc = conditional_prior(np.zeros((1, 2)), V[None], np.array([1.0]),
                                 (V @ np.array([1.0, 0.0]))[None] / np.sqrt(V[0, 0]))
    assert (np.linalg.eigvalsh(Vc[0]) > 0).all()


def test_level_moves_with_the_spectrum_when_the_resonance_varies():
    """Blocks of one level whose resonance varies: a lower resonance needs a weaker
    drive for the same level, so the drive's log amplitude and the first AR
    parameter move together (a1 = 2 r cos(w) rises as the resonance falls)."""
    from contactlab.synthetic import ar2_coefficients, ar2_variance
    rng = np.random.default_rng(7)
    parts = []
    for _ in range(300):
        a1, a2 = ar2_coefficients(30.0 * np.exp(rng.normal(0, 0.15)), 0.95, 250.0)
        e = rng.standard_normal(300) / np.sqrt(ar2_variance(a1, a2))
        parts.append(lfilter([1.0], [1.0, -a1, -a2], e)[200:])
    f = block_features(np.concatenate(parts), order=2, block=100)
    u0, tau, c = level_model(f)
    assert tau[0] > 0.05
    k = f.orthogonal[:, 0, :]
    u = 0.5 * np.log(f.noise_var[:, 0] / f.noise_var[:, 0].mean())
    assert u0[0] == pytest.approx(u.mean())
    assert np.allclose(c[0], np.cov(np.column_stack([k, u]), rowvar=False)[:2, 2])
    corr = c[0, 0] / (tau[0] * np.sqrt(np.cov(k[:, 0])))
    assert corr < -0.5          # k_1 (a1 plus a multiple of the fixed a2) against the drive


def test_level_spread_recovered_from_training_blocks():
    for sd in (0.0, 0.3):
        f = block_features(_blocks(400, log_amp_sd=sd, seed=4), order=2)
        assert level_sd(f) == pytest.approx(np.full(2, sd), abs=0.05)


def test_models_file_round_trip_keeps_the_level_model(tmp_path):
    f = block_features(_blocks(30, log_amp_sd=0.3, seed=5), order=2)
    m = fit_class("a", f, block=100)
    assert (m.level_sd > 0).all() and (m.level_cov != 0).any()
    ms = ModelSet(models={"a": m}, signal="strain", fs=250.0, provenance={"x": 1},
                  channels=None)
    ms.save(tmp_path / "m.h5")
    back = ModelSet.load(tmp_path / "m.h5")
    assert back.same_as(ms)
    assert np.allclose(block_loglik(f, back.models["a"]), block_loglik(f, m))


def test_texture_suite_small_case_matches_a_linear_discriminant(tmp_path):
    """Small case of the benchmark suite: classes differing only in frequency or
    only in level, with level varying between trials; ours >= LDA on the same blocks."""
    from sklearn.discriminant_analysis import LinearDiscriminantAnalysis

    from contactlab.synthetic import texture_trials, write_archive
    from contactlab.temporal.train import collect_blocks
    from tests.conftest import one_json_object, run_cli

    kw = dict(trial_level_sd=0.4, segment_level_sd=0.3, duration_s=6.0)
    write_archive(texture_trials(8, seed=11, **kw), tmp_path / "train.h5")
    write_archive(texture_trials(6, seed=12, **kw), tmp_path / "test.h5")
    res = run_cli("train", tmp_path / "train.h5", "--labels", "truth", "--out",
                  tmp_path / "m.h5", "-q")
    assert res.exit_code == 0, res.output
    out = one_json_object(run_cli("label", tmp_path / "test.h5", "--models", tmp_path / "m.h5",
                                  "--json", "-q").stdout)

    def lda_features(path):
        b = collect_blocks(str(path), labels="truth", block=100)
        f = b.features
        return np.concatenate([np.log(f.noise_var), f.coef.reshape(len(b), -1)], axis=1), b.label
    xtr, ytr = lda_features(tmp_path / "train.h5")
    xte, yte = lda_features(tmp_path / "test.h5")
    lda = LinearDiscriminantAnalysis().fit(xtr, ytr).score(xte, yte)
    assert out["n_blocks"] == len(yte)
    assert out["accuracy"] >= lda - 0.02
    assert json.dumps(out)      # one JSON object
