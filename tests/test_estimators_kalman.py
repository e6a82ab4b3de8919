"""Square-root Kalman filter (A.18-A.39) against filterpy and direct computations."""

from __future__ import annotations

import numpy as np
import pytest
from filterpy.kalman import KalmanFilter
from scipy import stats

from contactlab.estimators import ARModel, SquareRootKalman


def _filterpy_run(psi, y, theta0, P0, V):
    """Covariance-form filter (filterpy) on one model: psi (N, m, p), y (N, m)."""
    N, m, p = psi.shape
    kf = KalmanFilter(dim_x=p, dim_z=m)
    kf.x = np.asarray(theta0, dtype=float).reshape(p, 1).copy()
    kf.P = np.array(P0, dtype=float)
    kf.F = np.eye(p)
    kf.Q = np.zeros((p, p))
    kf.R = np.array(V, dtype=float)
    out = dict(theta=[], nu=[], S=[], ll=[])
    for n in range(N):
        kf.predict()
        kf.update(y[n].reshape(m, 1), H=psi[n])
        out["theta"].append(kf.x[:, 0].copy())
        out["nu"].append(kf.y[:, 0].copy())
        out["S"].append(kf.S.copy())
        out["ll"].append(kf.log_likelihood)
    out = {k: np.array(v) for k, v in out.items()}
    out["P"] = kf.P.copy()
    return out


def _ar2_channels(rng, n, B):
    a = np.array([1.3, -0.7])
    y = np.zeros((n + 2, B))
    e = 0.5 * rng.normal(size=(n + 2, B))
    for t in range(2, n + 2):
        y[t] = a[0] * y[t - 1] + a[1] * y[t - 2] + e[t]
    return y


def test_scalar_ar2_on_channels_matches_filterpy():
    rng = np.random.default_rng(20)
    y = _ar2_channels(rng, 400, 3)
    psi, target = ARModel(order=2).design(y)
    theta0 = np.array([1.0, -0.5])
    P0 = np.array([[0.09, 0.02], [0.02, 0.04]])
    kf = SquareRootKalman(theta0=theta0, theta_sqrt0=np.linalg.cholesky(P0), noise_sqrt=0.5)
    res = kf.filter(psi, target)
    assert res.innovations.shape == (400, 3, 1) and res.theta.shape == (400, 3, 2)
    for b in range(3):
        ref = _filterpy_run(psi[:, b, None, :], target[:, b, None], theta0, P0, [[0.25]])
        np.testing.assert_allclose(res.theta[:, b], ref["theta"], rtol=0, atol=1e-9)
        np.testing.assert_allclose(res.innovations[:, b], ref["nu"], rtol=0, atol=1e-9)
        np.testing.assert_allclose(res.innovation_cov[:, b], ref["S"], rtol=0, atol=1e-9)
        np.testing.assert_allclose(res.loglik[:, b], ref["ll"], rtol=0, atol=1e-9)
        P = kf.theta_sqrt_[b] @ kf.theta_sqrt_[b].T
        np.testing.assert_allclose(P, ref["P"], rtol=0, atol=1e-9)


def test_vector_measurements_match_filterpy():
    rng = np.random.default_rng(21)
    N, B, m, p = 300, 2, 3, 4
    psi = rng.normal(size=(N, B, m, p))
    theta = rng.normal(size=(B, p))
    Lv = np.array([[0.4, 0.0, 0.0], [0.1, 0.3, 0.0], [-0.2, 0.05, 0.5]])
    y = np.einsum("nbmp,bp->nbm", psi, theta) + rng.normal(size=(N, B, m)) @ Lv.T
    A = rng.normal(size=(p, p))
    P0 = A @ A.T + np.eye(p)
    theta0 = rng.normal(size=(B, p))
    kf = SquareRootKalman(theta0=theta0, theta_sqrt0=np.linalg.cholesky(P0), noise_sqrt=Lv)
    res = kf.filter(psi, y)
    for b in range(B):
        ref = _filterpy_run(psi[:, b], y[:, b], theta0[b], P0, Lv @ Lv.T)
        np.testing.assert_allclose(res.theta[:, b], ref["theta"], rtol=0, atol=1e-9)
        np.testing.assert_allclose(res.innovation_cov[:, b], ref["S"], rtol=0, atol=1e-9)
        np.testing.assert_allclose(res.loglik[:, b], ref["ll"], rtol=0, atol=1e-9)
        np.testing.assert_allclose(kf.theta_sqrt_[b] @ kf.theta_sqrt_[b].T, ref["P"], atol=1e-9)
    # the post-array factors are lower-triangular with a positive diagonal (A.33)
    F = res.innovation_sqrt
    assert np.all(np.triu(F, 1) == 0) and np.all(np.diagonal(F, axis1=2, axis2=3) > 0)


def test_summed_loglik_is_the_exact_density_of_the_whole_sequence():
    # Y = Psi theta + noise, theta ~ N(theta0, P0): Y is Gaussian with
    # mean Psi theta0 and covariance Psi P0 Psi^T + I (x) V.  Summing A.39 (with
    # log det F, not 1/2 log det F) must give exactly its log-density.
    rng = np.random.default_rng(22)
    N, m, p = 25, 2, 3
    psi = rng.normal(size=(N, 1, m, p))
    Lv = np.array([[0.7, 0.0], [0.3, 0.4]])
    y = rng.normal(size=(N, 1, m))
    theta0 = np.array([0.2, -1.0, 0.5])
    S0 = np.array([[1.0, 0, 0], [0.5, 0.8, 0], [0.1, -0.2, 0.6]])
    res = SquareRootKalman(theta0=theta0, theta_sqrt0=S0, noise_sqrt=Lv).filter(psi, y)
    Psi = psi[:, 0].reshape(N * m, p)
    cov = Psi @ S0 @ S0.T @ Psi.T + np.kron(np.eye(N), Lv @ Lv.T)
    want = stats.multivariate_normal(mean=Psi @ theta0, cov=cov).logpdf(y[:, 0].ravel())
    assert res.loglik.sum() == pytest.approx(want, rel=1e-10)


def test_change_statistic_is_chi_square_m_under_the_true_model():
    rng = np.random.default_rng(23)
    N, B, m, p = 5000, 4, 2, 3
    S0 = 0.5 * np.eye(p)
    theta = rng.normal(size=(B, p)) @ S0.T                 # drawn from the prior
    Lv = np.array([[1.0, 0.0], [0.6, 0.8]])
    psi = rng.normal(size=(N, B, m, p))
    y = np.einsum("nbmp,bp->nbm", psi, theta) + rng.normal(size=(N, B, m)) @ Lv.T
    res = SquareRootKalman(theta0=np.zeros(p), theta_sqrt0=S0, noise_sqrt=Lv).filter(psi, y)
    chi2 = res.chi2.ravel()
    np.testing.assert_allclose(res.change_stat, -0.5 * np.sum(res.alpha ** 2, axis=-1))
    assert chi2.mean() == pytest.approx(m, abs=0.06)       # sd of the mean ~ 0.014
    assert chi2.var() == pytest.approx(2 * m, rel=0.1)
    assert stats.kstest(chi2, stats.chi2(m).cdf).pvalue > 1e-3
    # negative control: a noise level overstated 2x shrinks the statistic ~4x
    wrong = SquareRootKalman(theta0=np.zeros(p), theta_sqrt0=S0, noise_sqrt=2 * Lv)
    assert wrong.filter(psi, y).chi2.mean() < 0.4 * m


def test_estimated_noise_matches_a_covariance_form_oracle():
    # A.38 in covariance form: V(n+1|n) = (1 - 1/n) V(n|n-1) + (1/n) nu nu^T with
    # n = prior_count + innovations so far; V(n|n-1) is the filter's V_nu.
    rng = np.random.default_rng(24)
    N, m, p, prior_count = 200, 2, 2, 5.0
    psi = rng.normal(size=(N, 1, m, p))
    y = np.einsum("nbmp,p->nbm", psi, [0.5, -1.0]) + 0.3 * rng.normal(size=(N, 1, m))
    V0 = np.array([[1.0, 0.2], [0.2, 0.5]])
    kf = SquareRootKalman(theta0=np.zeros(p), theta_sqrt0=2.0, noise_sqrt=np.linalg.cholesky(V0),
                          estimate_noise=True, noise_prior_count=prior_count)
    res = kf.filter(psi, y)
    x, P, V = np.zeros(p), 4.0 * np.eye(p), V0.copy()
    for n in range(N):
        H = psi[n, 0]
        nu = y[n, 0] - H @ x
        S = H @ P @ H.T + V
        K = P @ H.T @ np.linalg.inv(S)
        x = x + K @ nu
        P = P - K @ S @ K.T
        np.testing.assert_allclose(res.innovation_cov[n, 0], S, atol=1e-9)
        np.testing.assert_allclose(res.theta[n, 0], x, atol=1e-9)
        k = prior_count + n + 1
        V = (1 - 1 / k) * V + np.outer(nu, nu) / k
    np.testing.assert_allclose(kf.noise_sqrt_[0] @ kf.noise_sqrt_[0].T, V, atol=1e-9)
    # literal A.38 (no pseudo-count): the first innovation replaces the initial value
    lit = SquareRootKalman(theta0=np.zeros(p), theta_sqrt0=2.0, noise_sqrt=1.0, estimate_noise=True,
                           noise_prior_count=0)
    r1 = lit.update(psi[0], y[0])
    np.testing.assert_allclose(lit.noise_sqrt_[0] @ lit.noise_sqrt_[0].T,
                               np.outer(r1.innovations[0], r1.innovations[0]), atol=1e-12)


def test_diffuse_prior_converges_to_least_squares():
    rng = np.random.default_rng(25)
    y = _ar2_channels(rng, 3000, 2)
    psi, target = ARModel(order=2).design(y)
    kf = SquareRootKalman(theta0=np.zeros(2), theta_sqrt0=1e4, noise_sqrt=0.5)
    kf.filter(psi, target)
    for b in range(2):
        ls = np.linalg.lstsq(psi[:, b], target[:, b], rcond=None)[0]
        np.testing.assert_allclose(kf.theta_[b], ls, atol=1e-8)


def test_streaming_update_and_chunks_equal_one_batch_call():
    rng = np.random.default_rng(26)
    y = _ar2_channels(rng, 120, 3)
    psi, target = ARModel(order=2).design(y)
    args = dict(theta0=np.zeros(2), theta_sqrt0=[0.5, 0.3], noise_sqrt=0.5, estimate_noise=True)
    whole = SquareRootKalman(**args).filter(psi, target)
    kf = SquareRootKalman(**args)
    steps = [kf.update(psi[n], target[n]) for n in range(len(target))]
    np.testing.assert_array_equal(np.stack([s.theta for s in steps]), whole.theta)
    np.testing.assert_array_equal(np.stack([s.loglik for s in steps]), whole.loglik)
    kf.reset()
    parts = [kf.filter(psi[a:b], target[a:b]) for a, b in [(0, 7), (7, 8), (8, 120)]]
    np.testing.assert_array_equal(np.concatenate([r.alpha for r in parts]), whole.alpha)


def test_bad_parameters_are_named():
    psi, y = np.ones((4, 1, 2)), np.ones((4, 1))
    with pytest.raises(ValueError, match="lower-triangular"):
        SquareRootKalman(theta0=np.zeros(2), theta_sqrt0=np.ones((2, 2)),
                         noise_sqrt=1.0).filter(psi, y)
    with pytest.raises(ValueError, match="noise_sqrt"):
        SquareRootKalman(theta0=np.zeros(2), theta_sqrt0=1.0, noise_sqrt=0.0).filter(psi, y)
    with pytest.raises(ValueError, match="p=3"):
        SquareRootKalman(theta0=np.zeros(3), theta_sqrt0=1.0, noise_sqrt=1.0).filter(psi, y)
    with pytest.raises(ValueError, match="noise_prior_count"):
        SquareRootKalman(theta0=np.zeros(2), theta_sqrt0=1.0, noise_sqrt=1.0,
                         noise_prior_count=-1).filter(psi, y)
