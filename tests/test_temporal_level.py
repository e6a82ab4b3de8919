"""The level random effect of the block likelihood (contactlab.temporal.level)."""

from __future__ import annotations

import json

import numpy as np
import pytest
from scipy import integrate
from scipy.signal import lfilter

from contactlab.temporal.features import block_features
from contactlab.temporal.level import level_marginal, level_sd, scaled_features
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


def test_zero_spread_is_the_thesis_likelihood_and_quadrature_matches_an_integral():
    train = block_features(_blocks(40, log_amp_sd=0.3, seed=2, channels=1), order=2)
    model = fit_class("a", train, block=100)
    test = block_features(_blocks(3, log_amp_sd=0.3, seed=3, channels=1), order=2)
    base = loglik_params(test, model.theta_mean, model.theta_cov, model.noise_var)
    assert np.array_equal(level_marginal(
        lambda f: loglik_params(f, model.theta_mean, model.theta_cov, model.noise_var),
        test, np.zeros(1)), base)
    tau = 0.3
    got = loglik_params(test, model.theta_mean, model.theta_cov, model.noise_var,
                        level_sd=np.array([tau]))
    M = test.rows
    for b in range(3):
        one = test.take([b])

        def integrand(u, one=one, ref=base[b, 0]):
            ll = loglik_params(scaled_features(one, np.exp([u])), model.theta_mean,
                               model.theta_cov, model.noise_var)[0, 0]
            return np.exp(ll - M * u - ref) * np.exp(-u * u / (2 * tau ** 2)) / (
                tau * np.sqrt(2 * np.pi))
        val, _ = integrate.quad(integrand, -8 * tau, 8 * tau, limit=200)
        assert got[b, 0] == pytest.approx(base[b, 0] + np.log(val), abs=1e-3)


def test_level_spread_recovered_from_training_blocks():
    for sd in (0.0, 0.3):
        f = block_features(_blocks(400, log_amp_sd=sd, seed=4), order=2)
        assert level_sd(f) == pytest.approx(np.full(2, sd), abs=0.05)


def test_models_file_round_trip_keeps_level_sd(tmp_path):
    f = block_features(_blocks(30, log_amp_sd=0.3, seed=5), order=2)
    m = fit_class("a", f, block=100)
    assert (m.level_sd > 0).all()
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
