"""Orthogonal-regressor square-root filter (A.40-A.42)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import signal

from contactlab.estimators import (ARModel, OrthogonalKalman, SquareRootKalman, SquareRootRLS,
                                   from_orthogonal, orthogonal_prior, to_orthogonal,
                                   unit_structure)


def _ar(a, n, rng, channels):
    e = rng.normal(size=(n + 500, channels))
    return signal.lfilter([1.0], np.concatenate([[1.0], -np.asarray(a)]), e, axis=0)[500:]


def test_unit_structure_is_the_ldl_factor_of_the_information():
    rng = np.random.default_rng(30)
    S = rng.normal(size=(200, 4)) @ rng.normal(size=(4, 4))
    L = np.linalg.cholesky(S.T @ S)
    R = unit_structure(L)
    np.testing.assert_allclose(np.diag(R), 1.0)
    assert np.all(np.tril(R, -1) == 0)
    D = np.diag(L) ** 2
    np.testing.assert_allclose(R.T @ np.diag(D) @ R, S.T @ S, rtol=1e-10)   # I = R^T D R
    theta = rng.normal(size=4)
    np.testing.assert_allclose(from_orthogonal(to_orthogonal(theta, L), L), theta, rtol=1e-12)
    # invariant to the scale of the information (n samples vs 10 n samples)
    np.testing.assert_allclose(unit_structure(3.0 * L), R, rtol=1e-12)


def test_fixed_structure_filter_estimates_the_training_orthogonal_parameters():
    # With the RLS's structure and a diffuse prior, the filter is exactly least
    # squares in orthogonal coordinates: theta~ = k~ / diag(R) of the RLS.
    rng = np.random.default_rng(31)
    y = _ar([1.2, -0.6], 3000, rng, 2)
    psi, target = ARModel(order=2).design(y)
    rls = SquareRootRLS()
    rls.run(psi, target)
    okf = OrthogonalKalman(theta0=np.zeros(2), theta_sqrt0=1e4, noise_sqrt=1.0,
                           structure="fixed", structure_sqrt0=rls.info_sqrt_)
    okf.filter(psi, target)
    np.testing.assert_allclose(okf.theta_, rls.orthogonal_coef(), rtol=0, atol=1e-8)
    for b in range(2):
        ls = np.linalg.lstsq(psi[:, b], target[:, b], rcond=None)[0]
        np.testing.assert_allclose(okf.coef_[b], ls, rtol=0, atol=1e-8)


def test_tracked_structure_on_stationary_ar_maps_back_to_least_squares():
    rng = np.random.default_rng(32)
    a = np.array([1.2, -0.6])
    y = _ar(a, 20_000, rng, 2)
    psi, target = ARModel(order=2).design(y)
    okf = OrthogonalKalman(theta0=np.zeros(2), theta_sqrt0=1e4, noise_sqrt=1.0)
    okf.filter(psi, target)
    rls = SquareRootRLS()
    rls.run(psi, target)
    for b in range(2):
        X = psi[:, b]
        ls = np.linalg.lstsq(X, target[:, b], rcond=None)[0]
        se = np.sqrt(np.diag(np.linalg.inv(X.T @ X)))        # noise variance 1
        # R(n) converges, so the drift of theta~ = R(n) theta costs a small
        # fraction of the estimation error itself
        assert np.all(np.abs(okf.coef_[b] - ls) < 0.5 * se), (okf.coef_[b] - ls) / se
        assert np.all(np.abs(ls - a) < 4 * se)
    # the tracked structure is the RLS's information factor (delta^2 I aside)
    np.testing.assert_allclose(okf.unit_structure_, unit_structure(rls.info_sqrt_), atol=1e-9)
    np.testing.assert_allclose(okf.theta_, rls.orthogonal_coef(), atol=5e-3)


def test_orthogonal_filter_equals_plain_filter_with_mapped_prior():
    # A reparametrisation theta~ = R theta with a fixed R changes nothing
    # observable: innovations and likelihoods equal those of the plain filter
    # (itself checked against filterpy) with the prior mapped back.
    rng = np.random.default_rng(33)
    N, B, m, p = 150, 2, 2, 3
    psi = rng.normal(size=(N, B, m, p))
    y = np.einsum("nbmp,p->nbm", psi, [0.3, -0.2, 1.0]) + 0.5 * rng.normal(size=(N, B, m))
    Ls = np.linalg.cholesky(np.array([[4.0, 1.0, 0.5], [1.0, 3.0, -0.7], [0.5, -0.7, 2.0]]))
    R = unit_structure(Ls)
    t0 = np.array([0.1, 0.2, 0.3])
    S0 = np.diag([0.5, 0.4, 0.3])
    ortho = OrthogonalKalman(theta0=t0, theta_sqrt0=S0, noise_sqrt=0.5, structure="fixed",
                             structure_sqrt0=Ls)
    r1 = ortho.filter(psi, y)
    G = np.linalg.solve(R, S0)                              # natural-parameter prior factor
    plain = SquareRootKalman(theta0=np.linalg.solve(R, t0),
                             theta_sqrt0=np.linalg.cholesky(G @ G.T), noise_sqrt=0.5)
    r2 = plain.filter(psi, y)
    np.testing.assert_allclose(r1.innovations, r2.innovations, atol=1e-9)
    np.testing.assert_allclose(r1.loglik, r2.loglik, atol=1e-9)
    np.testing.assert_allclose(ortho.coef_, plain.theta_, atol=1e-9)
    P = plain.theta_sqrt_ @ np.swapaxes(plain.theta_sqrt_, 1, 2)
    np.testing.assert_allclose(ortho.coef_cov_, P, atol=1e-9)


def test_tracked_structure_with_vector_measurements_is_the_information_factor():
    # A.41 with m = 2 rows per step: L L^T = delta^2 I + sum_n psi(n)^T psi(n)
    rng = np.random.default_rng(35)
    N, m, p, delta = 60, 2, 3, 0.1
    psi = rng.normal(size=(N, 1, m, p))
    y = rng.normal(size=(N, 1, m))
    okf = OrthogonalKalman(theta0=np.zeros(p), theta_sqrt0=1.0, noise_sqrt=1.0,
                           structure_sqrt0=delta)
    okf.filter(psi, y)
    L = okf.structure_[0]
    info = delta ** 2 * np.eye(p) + np.einsum("nmi,nmj->ij", psi[:, 0], psi[:, 0])
    np.testing.assert_allclose(L @ L.T, info, rtol=1e-12)
    np.testing.assert_allclose(L, np.linalg.cholesky(info), rtol=1e-12)


def test_orthogonal_prior_from_training_blocks():
    rng = np.random.default_rng(34)
    y = _ar([0.9, -0.3], 100 * 60, rng, 1)[:, 0]
    blocks = y.reshape(60, 100).T                           # 60 training blocks as channels
    rls = SquareRootRLS()
    rls.run(*ARModel(order=2).design(blocks))
    samples = rls.orthogonal_coef()
    mean, sqrt_cov = orthogonal_prior(samples)
    np.testing.assert_allclose(mean, samples.mean(axis=0))
    np.testing.assert_allclose(sqrt_cov @ sqrt_cov.T, np.cov(samples, rowvar=False))
    with pytest.raises(ValueError, match="K > p"):
        orthogonal_prior(samples[:2])


def test_bad_parameters_are_named():
    psi, y = np.ones((4, 1, 2)), np.ones((4, 1))
    with pytest.raises(ValueError, match="structure"):
        OrthogonalKalman(theta0=np.zeros(2), theta_sqrt0=1.0, noise_sqrt=1.0,
                         structure="learned").filter(psi, y)
    with pytest.raises(ValueError, match="full-rank"):
        OrthogonalKalman(theta0=np.zeros(2), theta_sqrt0=1.0, noise_sqrt=1.0, structure="fixed",
                         structure_sqrt0=np.diag([1.0, 0.0])).filter(psi, y)
