"""Block features, the 7.4-7.5 likelihood and the log-energy normal-fit error,
each against an independent oracle (numpy QR/lstsq, scipy's multivariate
normal, Monte Carlo, closed forms)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.signal import lfilter
from scipy.stats import multivariate_normal, norm

from contactlab.estimators import ARModel
from contactlab.temporal.energy import (classify_1d, normal_confusion_1d, normal_confusion_mc,
                                        normal_error_1d)
from contactlab.temporal.features import block_features
from contactlab.temporal.likelihood import block_loglik, block_loglik_kalman
from contactlab.temporal.model import TemporalModel, fit_class


def ar_signal(rng, a, sd, n, channels=1, mu=0.0):
    e = rng.normal(scale=sd, size=(n + 200, channels)) + mu
    return lfilter([1.0], np.r_[1.0, -np.asarray(a, dtype=float)], e, axis=0)[200:]


@pytest.mark.parametrize("mean", [False, True])
def test_block_features_match_numpy_qr(mean):
    rng = np.random.default_rng(1)
    y = ar_signal(rng, [0.9, -0.4], 0.5, 700, channels=3, mu=0.3)
    starts = np.array([0, 150, 333, 580])
    block, p = 120, 2
    f = block_features(y, order=p, mean=mean, block=block, starts=starts)
    model = ARModel(order=p, mean=mean)
    for k, s in enumerate(starts):
        for c in range(3):
            A, Y = model.design(y[s:s + block, c])
            A, Y = A[:, 0, :], Y[:, 0]
            Q, R = np.linalg.qr(A)
            sign = np.sign(np.diag(R))
            d = np.abs(np.diag(R))
            ktil = sign * (Q.T @ Y)
            coef, res, *_ = np.linalg.lstsq(A, Y, rcond=None)
            np.testing.assert_allclose(f.coef[k, c], coef, rtol=1e-9, atol=1e-12)
            np.testing.assert_allclose(f.scale[k, c], d, rtol=1e-10)
            np.testing.assert_allclose(f.orthogonal[k, c], ktil / d, rtol=1e-9, atol=1e-12)
            # the orthogonal parameters are R theta with R = D^-1/2 (QR factor), unit upper
            np.testing.assert_allclose(f.orthogonal[k, c], (R / np.diag(R)[:, None]) @ coef,
                                       rtol=1e-8, atol=1e-12)
            np.testing.assert_allclose(f.residual_energy[k, c], res[0], rtol=1e-8)
            assert f.noise_var[k, c] == pytest.approx(res[0] / (block - p - A.shape[1]),
                                                      rel=1e-8)


def test_training_recovers_known_ar_coefficients():
    """AR(2) with known a: per block k_1 estimates rho_1 = a1 / (1 - a2) (the
    coefficient on y(n-1) alone) and k_2 estimates a2 (last orthogonal = last
    natural parameter); the noise variance estimates sd^2."""
    rng = np.random.default_rng(7)
    a1, a2, sd = 1.1, -0.5, 0.7
    block, K = 400, 120
    y = ar_signal(rng, [a1, a2], sd, block * K, channels=2)
    f = block_features(y, order=2, block=block)
    m = fit_class("x", f, block=block)
    truth = np.array([a1 / (1 - a2), a2])
    se = np.sqrt(np.diagonal(m.theta_cov, axis1=1, axis2=2) / K)       # (C, 2)
    bias_allowance = 3.0 / block                                         # O(1/M) LS bias
    assert np.all(np.abs(m.theta_mean - truth) < 4 * se + bias_allowance), (m.theta_mean, se)
    se_v = f.noise_var.std(axis=0, ddof=1) / np.sqrt(K)
    assert np.all(np.abs(m.noise_var - sd ** 2) < 4 * se_v)
    # natural coefficients, for good measure
    assert np.all(np.abs(f.coef.mean(axis=0) - [a1, a2]) < 0.02)


def random_model(rng, C, q, label="m"):
    B = rng.normal(size=(C, q, q)) * 0.3
    cov = B @ np.swapaxes(B, 1, 2) + 0.05 * np.eye(q)
    return TemporalModel(label=label, order=2, mean=q == 3, theta_mean=rng.normal(size=(C, q)) * .3,
                         theta_cov=cov, structure_sqrt=np.tile(np.eye(q), (C, 1, 1)),
                         noise_var=rng.uniform(0.2, 2.0, size=C), n_blocks=10, block=12)


@pytest.mark.parametrize("mean", [False, True])
def test_block_likelihood_equals_dense_normal_and_kalman(mean):
    """log p(Y) with E[Y] = Q S^1/2 E[k], V[Y] = Q S^1/2 V[k] (Q S^1/2)^T + V_nu I
    (7.4-7.5), evaluated densely by scipy on small blocks."""
    rng = np.random.default_rng(3)
    C, p, block = 2, 2, 12
    q = p + int(mean)
    y = ar_signal(rng, [0.5, 0.2], 1.0, 80, channels=C, mu=0.5)
    starts = np.array([0, 20, 47, 68])
    f = block_features(y, order=p, mean=mean, block=block, starts=starts)
    model = random_model(rng, C, q)
    model = TemporalModel(**{**model.__dict__, "mean": mean})
    fast = block_loglik(f, model, per_channel=True)
    kalman = block_loglik_kalman(y, starts, f, model, per_channel=True)
    design = ARModel(order=p, mean=mean)
    for k, s in enumerate(starts):
        for c in range(C):
            A, Y = design.design(y[s:s + block, c])
            A, Y = A[:, 0, :], Y[:, 0]
            Q, R = np.linalg.qr(A)
            QS = Q * np.diag(R)                      # Q S^1/2 (sign-free product)
            mean_y = QS @ model.theta_mean[c]
            cov_y = QS @ model.theta_cov[c] @ QS.T + model.noise_var[c] * np.eye(len(Y))
            oracle = multivariate_normal(mean_y, cov_y).logpdf(Y)
            assert fast[k, c] == pytest.approx(oracle, rel=1e-9, abs=1e-9)
            assert kalman[k, c] == pytest.approx(oracle, rel=1e-8, abs=1e-8)
    np.testing.assert_allclose(block_loglik(f, model), fast.sum(axis=1))


def test_normal_error_equal_variances_closed_form():
    # two classes, equal sd and priors: error = Phi(-|mu1 - mu2| / (2 sd))
    for delta in (0.1, 1.0, 3.0, 7.3):
        err = normal_error_1d([0.0, delta], [1.3, 1.3])
        assert err == pytest.approx(norm.cdf(-delta / 2.6), rel=1e-9)


def test_normal_confusion_matches_monte_carlo():
    rng = np.random.default_rng(11)
    mu, sd = np.array([-5.6, -5.25, -5.46]), np.array([0.08, 0.2, 0.05])
    conf = normal_confusion_1d(mu, sd)
    np.testing.assert_allclose(conf.sum(axis=1), 1.0, atol=1e-12)
    n = 200_000
    for i in range(3):
        x = rng.normal(mu[i], sd[i], size=n)
        freq = np.bincount(classify_1d(x, mu, sd), minlength=3) / n
        np.testing.assert_allclose(conf[i], freq, atol=4 * np.sqrt(0.25 / n))
    # the multivariate Monte Carlo in one dimension agrees with the exact regions
    mc = normal_confusion_mc(mu[:, None], (sd ** 2)[:, None, None], n=100_000, seed=2)
    np.testing.assert_allclose(mc, conf, atol=0.01)


def test_normal_error_keeps_precision_in_the_tail():
    err = normal_error_1d([0.0, 20.0], [1.0, 1.0])
    assert err == pytest.approx(norm.sf(10.0), rel=1e-6)
