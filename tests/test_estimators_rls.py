"""Square-root RLS (A.10-A.17) against numpy.linalg.lstsq and direct computations."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import signal, stats

from contactlab.estimators import (ARModel, LinearDecayModel, SquareRootRLS, estimate,
                                   estimate_ar, exact_sequence_loglik)
from contactlab.estimators.householder import tri_append


def _regression(rng, N=240, B=3, p=5, noise=0.3):
    psi = rng.normal(size=(N, B, p)) + 0.5 * rng.normal(size=(N, B, 1))   # correlated columns
    theta = rng.normal(size=(B, p))
    y = np.einsum("nbp,bp->nb", psi, theta) + noise * rng.normal(size=(N, B))
    return psi, y


def _lstsq(X, y):
    return np.linalg.lstsq(X, y, rcond=None)[0]


def _simulate_ar(a, n, rng, channels=1, mean=0.0):
    """AR(p) by scipy.signal.lfilter: y(n) = sum a_i y(n-i) + mean + e(n)."""
    e = rng.normal(size=(n + 500, channels)) + mean
    y = signal.lfilter([1.0], np.concatenate([[1.0], -np.asarray(a)]), e, axis=0)
    return y[500:]


def _ljung_box_p(x, lags=20, fitted=0):
    x = x - x.mean()
    n = len(x)
    acf = np.array([np.dot(x[:-k], x[k:]) for k in range(1, lags + 1)]) / np.dot(x, x)
    q = n * (n + 2) * np.sum(acf ** 2 / (n - np.arange(1, lags + 1)))
    return stats.chi2.sf(q, lags - fitted)


def test_householder_update_matches_cholesky():
    rng = np.random.default_rng(0)
    q, k = 6, 3
    A = rng.normal(size=(q, q + 4))
    L = np.linalg.cholesky(A @ A.T)
    Z = rng.normal(size=(q, k))
    want = np.linalg.cholesky(L @ L.T + Z @ Z.T)
    L2, Z2 = L.copy(), Z.copy()
    tri_append(L2, Z2)
    np.testing.assert_allclose(L2, want, atol=1e-12)
    assert np.all(Z2 == 0) and np.all(np.triu(L2, 1) == 0)
    # starting from zero (and from a negative diagonal) still gives the unique factor
    L0 = np.zeros((q, q))
    Zf = rng.normal(size=(q, q + 2))
    tri_append(L0, Zf.copy())
    np.testing.assert_allclose(L0, np.linalg.cholesky(Zf @ Zf.T), atol=1e-12)
    Ln = -L.copy()
    tri_append(Ln, np.zeros((q, 1)))
    np.testing.assert_allclose(Ln, L, atol=0)


def test_rls_matches_lstsq_at_every_sampled_n_for_all_orders():
    rng = np.random.default_rng(1)
    psi, y = _regression(rng)
    N, B, p = psi.shape
    rls = SquareRootRLS()
    done = 0
    for n in (5, 6, 9, 17, 40, 111, 240):          # n >= p
        rls.run(psi[done:n], y[done:n])
        done = n
        assert np.all(rls.n_samples_ == n)
        for m in range(1, p + 1):
            got = rls.coef(m)
            for b in range(B):
                want = _lstsq(psi[:n, b, :m], y[:n, b])
                np.testing.assert_allclose(got[b], want, rtol=1e-9, atol=1e-9,
                                           err_msg=f"n={n} m={m} b={b}")


def test_residuals_a_priori_and_a_posteriori_for_every_order():
    rng = np.random.default_rng(2)
    psi, y = _regression(rng, N=80, B=2, p=4)
    res = SquareRootRLS().run(psi, y)
    for n in (4, 10, 33, 79):
        for b in range(2):
            np.testing.assert_allclose(res.prior_errors[n, b, 0], y[n, b])
            for m in range(1, 5):
                post = y[n, b] - psi[n, b, :m] @ _lstsq(psi[:n + 1, b, :m], y[:n + 1, b])
                prior = y[n, b] - psi[n, b, :m] @ _lstsq(psi[:n, b, :m], y[:n, b])
                np.testing.assert_allclose(res.posterior_errors[n, b, m], post, atol=1e-9)
                np.testing.assert_allclose(res.prior_errors[n, b, m], prior, atol=1e-9)
    np.testing.assert_array_equal(res.innovations, res.prior_errors[..., -1])
    # before n = p samples the order-p prediction does not exist
    assert np.all(np.isnan(res.prior_errors[:4, :, 4]))


def test_reflection_and_orthogonal_coefficients_are_gram_schmidt_quantities():
    rng = np.random.default_rng(3)
    psi, y = _regression(rng, N=120, B=2, p=4)
    rls = SquareRootRLS()
    rls.run(psi, y)
    for b in range(2):
        S = psi[:, b, :]
        Q, Rq = np.linalg.qr(S)
        sign = np.sign(np.diag(Rq))
        Q, Rq = Q * sign, Rq * sign[:, None]
        np.testing.assert_allclose(rls.info_sqrt_[b], Rq.T, atol=1e-10)      # S = Q R^T
        np.testing.assert_allclose(rls.reflection_[b], Q.T @ y[:, b], atol=1e-10)
        # orthogonal parameter j: coefficient of y on column j, earlier columns projected out
        for j in range(4):
            col = S[:, j]
            if j:
                col = col - S[:, :j] @ _lstsq(S[:, :j], col)
            np.testing.assert_allclose(rls.orthogonal_coef()[b, j],
                                       col @ y[:, b] / (col @ col), rtol=1e-9)
        np.testing.assert_allclose(rls.energy_[b], y[:, b] @ y[:, b], rtol=1e-12)


def test_exact_sequence_loglik_matches_direct_gaussian_computation():
    rng = np.random.default_rng(4)
    psi, y = _regression(rng, N=150, B=3, p=4)
    rls = SquareRootRLS()
    rls.run(psi, y)
    for m in range(1, 5):
        got = rls.sequence_loglik(m)
        for b in range(3):
            r = y[:, b] - psi[:, b, :m] @ _lstsq(psi[:, b, :m], y[:, b])
            sigma = np.sqrt(r @ r / len(r))
            want = stats.norm.logpdf(r, scale=sigma).sum()
            assert got[b] == pytest.approx(want, rel=1e-10)
            # the residual energy E0 - k~^T k~ of footnote 3
            assert rls.order_residual_energy(m)[b] == pytest.approx(r @ r, rel=1e-9)
    # "+ m" read as the model order would be wrong for m > 1
    e, n = rls.order_residual_energy(3)[0], 150
    literal = -n / 2 * (np.log(e / n) + 3) - n / 2 * np.log(2 * np.pi)
    assert abs(literal - rls.sequence_loglik(3)[0]) > 100
    assert exact_sequence_loglik(e, n) == pytest.approx(rls.sequence_loglik(3)[0])


def test_ill_conditioned_regressors_where_normal_equations_fail():
    rng = np.random.default_rng(5)
    n = 400
    x = rng.normal(size=n)
    S = np.stack([x, x + 1e-10 * rng.normal(size=n), rng.normal(size=n)], axis=1)
    assert np.linalg.cond(S) > 1e9
    theta = np.array([1.0, 2.0, -0.5])
    y = S @ theta
    ref = _lstsq(S, y)
    normal = np.linalg.solve(S.T @ S, S.T @ y)
    rls = SquareRootRLS()
    rls.run(S, y)
    got = rls.coef()[0]
    err_normal = np.linalg.norm(normal - ref) / np.linalg.norm(ref)
    err_sqrt = np.linalg.norm(got - ref) / np.linalg.norm(ref)
    assert err_normal > 1e-2            # squared conditioning: the normal equations are lost
    assert err_sqrt < 1e-4              # the square-root update stays with lstsq
    np.testing.assert_allclose(S @ got, y, atol=1e-7)


@pytest.mark.parametrize("a", [[1.2, -0.6], [0.5, 0.2, -0.3, 0.25]])
def test_ar_residuals_are_white_and_coefficients_recovered(a):
    rng = np.random.default_rng(6 + len(a))
    p = len(a)
    y = _simulate_ar(a, 6000, rng, channels=2)
    model = ARModel(order=p)
    psi, target = model.design(y)
    res = SquareRootRLS().run(psi, target)
    fitted = estimate_ar(y, order=p)
    for b in range(2):
        innov = res.innovations[50:, b]
        assert _ljung_box_p(innov) > 1e-3
        # residual autocorrelation within +-3/sqrt(n) at lags 1..20
        r = innov - innov.mean()
        acf = np.array([r[:-k] @ r[k:] for k in range(1, 21)]) / (r @ r)
        assert np.all(np.abs(acf) < 3 / np.sqrt(len(r)))
        # coefficients within 4 asymptotic standard errors
        X = psi[:, b, :]
        cov = fitted.variance[b] * np.linalg.inv(X.T @ X)
        z = (fitted.coef[b] - np.asarray(a)) / np.sqrt(np.diag(cov))
        assert np.all(np.abs(z) < 4), z
        assert fitted.variance[b] == pytest.approx(1.0, abs=0.06)
    # negative control: an AR(1) fit leaves coloured residuals that the test rejects
    under = SquareRootRLS().run(*ARModel(order=1).design(y))
    assert _ljung_box_p(under.innovations[50:, 0]) < 1e-6


def test_variance_warmup_loglik_and_stat_against_direct_computation():
    rng = np.random.default_rng(9)
    psi, y = _regression(rng, N=60, B=2, p=2, noise=0.5)
    res = SquareRootRLS(variance_warmup=8).run(psi, y)
    e = res.innovations
    assert np.all(np.isnan(res.variance[:8])) and np.all(np.isfinite(res.variance[8:]))
    for n in (8, 9, 20, 59):
        want = np.mean(e[8:n + 1] ** 2, axis=0)          # A.17 is the running mean
        np.testing.assert_allclose(res.variance[n], want, rtol=1e-12)
    prev = res.variance[9:-1]
    np.testing.assert_allclose(res.loglik[10:], stats.norm.logpdf(e[10:], scale=np.sqrt(prev)),
                               rtol=1e-12)
    np.testing.assert_allclose(res.stat[10:], e[10:] ** 2 / prev, rtol=1e-12)
    assert np.all(np.isnan(res.loglik[:9]))
    # posterior residuals on request
    post = SquareRootRLS(variance_source="posterior").run(psi, y)
    np.testing.assert_allclose(post.variance[-1],
                               np.mean(post.residuals[8:] ** 2, axis=0), rtol=1e-12)
    # the warm-up never starts before the order-p prediction exists
    late = SquareRootRLS(variance_warmup=0).run(psi, y)
    assert np.all(np.isnan(late.variance[:2])) and np.all(np.isfinite(late.variance[2:]))


def test_streaming_update_chunks_and_reset_equal_fresh_runs():
    rng = np.random.default_rng(10)
    psi, y = _regression(rng, N=90, B=3, p=3)
    whole = SquareRootRLS().run(psi, y)
    step = SquareRootRLS()
    outs = [step.update(psi[n], y[n]) for n in range(90)]
    np.testing.assert_array_equal(np.stack([o.prior_errors for o in outs]), whole.prior_errors)
    np.testing.assert_array_equal(np.stack([o.variance for o in outs]), whole.variance)
    # restart channel 1 at sample 40: it then equals a fresh estimator on psi[40:]
    rls = SquareRootRLS()
    rls.run(psi[:40], y[:40])
    rls.reset([1])
    after = rls.run(psi[40:], y[40:])
    fresh = SquareRootRLS().run(psi[40:, 1:2], y[40:, 1:2])
    np.testing.assert_array_equal(after.prior_errors[:, 1], fresh.prior_errors[:, 0])
    np.testing.assert_allclose(after.prior_errors[:, 0], whole.prior_errors[40:, 0])
    assert list(rls.n_samples_) == [90, 50, 90]


def test_ar_with_mean_and_linear_decay_models_against_lstsq():
    rng = np.random.default_rng(12)
    y = _simulate_ar([0.6, -0.2], 800, rng, channels=3, mean=2.0)
    got = estimate_ar(y, order=2, mean=True)
    assert ARModel(order=2, mean=True).param_names == ("mu", "a1", "a2")
    for b in range(3):
        X = np.column_stack([np.ones(798), y[1:-1, b], y[:-2, b]])
        np.testing.assert_allclose(got.coef[b], _lstsq(X, y[2:, b]), rtol=1e-9)
    # mean-free AR regressors
    psi = ARModel(order=3).regressors(y[:, 0])
    lags = np.column_stack([y[2:-1, 0], y[1:-2, 0], y[:-3, 0]])
    np.testing.assert_array_equal(psi[:, 0, :], lags)
    hist = ARModel(order=3, mean=True).regressor_from_history(y[:3])
    np.testing.assert_array_equal(hist, np.column_stack([np.ones(3), y[2], y[1], y[0]]))
    # impact envelope: log-energy = mu + a n
    n = np.arange(60)
    logs = 1.5 - 0.04 * n[:, None] + 0.1 * rng.normal(size=(60, 2))
    dec = estimate(LinearDecayModel(), logs)
    for b in range(2):
        np.testing.assert_allclose(dec.coef[b],
                                   _lstsq(np.column_stack([np.ones(60), n]), logs[:, b]), rtol=1e-9)
    shifted = LinearDecayModel(start=10).regressors(logs)
    np.testing.assert_array_equal(shifted[:, 0, 1], n + 10.0)


def test_bad_parameters_and_shapes_are_named():
    with pytest.raises(ValueError, match="variance_warmup"):
        SquareRootRLS(variance_warmup=-1).run(np.ones((3, 1, 1)), np.ones((3, 1)))
    with pytest.raises(ValueError, match="variance_source"):
        SquareRootRLS(variance_source="both").run(np.ones((3, 1, 1)), np.ones((3, 1)))
    with pytest.raises(ValueError, match="disagree"):
        SquareRootRLS().run(np.ones((3, 2, 1)), np.ones((3, 1)))
    rls = SquareRootRLS()
    rls.run(np.ones((3, 2, 2)), np.ones((3, 2)))
    with pytest.raises(ValueError, match="reset"):
        rls.run(np.ones((3, 2, 3)), np.ones((3, 2)))
    with pytest.raises(ValueError, match="order"):
        rls.coef(3)
    with pytest.raises(ValueError, match="order"):
        ARModel(order=0)
