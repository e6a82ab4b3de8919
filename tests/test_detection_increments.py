"""Increments: (6.14) and its decrease form are log-density differences; (6.11)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.stats import multivariate_normal, norm

from contactlab.detection import (
    chi_square,
    mean_increment,
    mean_increments,
    variance_increment,
    variance_increments,
)


@pytest.fixture
def innovations():
    rng = np.random.default_rng(0)
    m = 3
    a = rng.standard_normal((m, m))
    cov = a @ a.T + m * np.eye(m)
    nu = rng.multivariate_normal(np.zeros(m), cov, size=50) * 1.7
    return nu, cov


def test_chi_square_statistic(innovations):
    nu, cov = innovations
    expected = np.einsum("ni,ij,nj->n", nu, np.linalg.inv(cov), nu)
    np.testing.assert_allclose(chi_square(nu, cov), expected, rtol=1e-10)
    # per-sample covariances broadcast
    covs = np.broadcast_to(cov, (50, 3, 3)) * np.linspace(1, 2, 50)[:, None, None]
    np.testing.assert_allclose(chi_square(nu, covs), expected / np.linspace(1, 2, 50), rtol=1e-10)
    with pytest.raises(ValueError, match="cov"):
        chi_square(nu, np.eye(2))


@pytest.mark.parametrize("q", [2.5, 1.3])
def test_increase_increment_is_log_density_ratio(innovations, q):
    nu, cov = innovations
    m = nu.shape[1]
    h0 = multivariate_normal(np.zeros(m), cov).logpdf(nu)
    h1 = multivariate_normal(np.zeros(m), q * cov).logpdf(nu)
    np.testing.assert_allclose(variance_increment(chi_square(nu, cov), dim=m, q=q), h1 - h0,
                               rtol=1e-10, atol=1e-12)


@pytest.mark.parametrize("q", [2.5, 1.3])
def test_decrease_increment_is_log_density_ratio(innovations, q):
    nu, cov = innovations
    m = nu.shape[1]
    h0 = multivariate_normal(np.zeros(m), cov).logpdf(nu)
    h1 = multivariate_normal(np.zeros(m), cov / q).logpdf(nu)
    chi2 = chi_square(nu, cov)
    np.testing.assert_allclose(variance_increment(chi2, dim=m, q=1 / q), h1 - h0,
                               rtol=1e-10, atol=1e-12)
    both = variance_increments(chi2, dim=m, q=q)
    assert both.shape == (50, 2)
    np.testing.assert_allclose(both[:, 1], h1 - h0, rtol=1e-10, atol=1e-12)


def test_increments_drift_down_under_h0():
    # E chi2 = m under H0, so both sides have negative mean increments
    for q in (1.5, 2.5, 10.0):
        inc = variance_increments(np.array([3.0]), dim=3, q=q)
        assert (inc < 0).all()


def test_mean_increment_is_log_density_ratio():
    y = np.linspace(-3, 4, 29)
    expected = norm(1.5 + 0.8, 2.0).logpdf(y) - norm(1.5, 2.0).logpdf(y)
    np.testing.assert_allclose(mean_increment(y, mu0=1.5, dmu=0.8, sigma=2.0), expected,
                               rtol=1e-12, atol=1e-12)
    down = norm(1.5 - 0.8, 2.0).logpdf(y) - norm(1.5, 2.0).logpdf(y)
    np.testing.assert_allclose(mean_increments(y, mu0=1.5, dmu=0.8, sigma=2.0)[:, 1], down,
                               rtol=1e-12, atol=1e-12)
    # beta = s^2 / 2: mean increment at y = mu0 is -beta, at y = mu0 + dmu it is +beta
    s = 0.8 / 2.0
    assert mean_increment(1.5, mu0=1.5, dmu=0.8, sigma=2.0) == pytest.approx(-s**2 / 2)
    assert mean_increment(2.3, mu0=1.5, dmu=0.8, sigma=2.0) == pytest.approx(s**2 / 2)


def test_bad_arguments():
    with pytest.raises(ValueError, match="q"):
        variance_increment(1.0, dim=2, q=1.0)
    with pytest.raises(ValueError, match="dim"):
        variance_increment(1.0, dim=0, q=2.0)
    with pytest.raises(ValueError, match="sigma"):
        mean_increment(1.0, mu0=0.0, dmu=1.0, sigma=0.0)
