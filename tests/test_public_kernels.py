"""The public compiled steps other modules share: kalman_step and cusum_step.

Oracles: a textbook (covariance-form) Kalman filter in numpy, and numpy's
``maximum(0, df + x)``.
"""

import numpy as np

from contactlab.detection import cusum_step
from contactlab.estimators import kalman_step


def _textbook_kalman(psi, y, theta0, P0, R):
    theta, P = theta0.copy(), P0.copy()
    out, ll = [], []
    for h, z in zip(psi, y):
        S = h @ P @ h + R
        nu = z - h @ theta
        K = P @ h / S
        theta = theta + K * nu
        P = P - np.outer(K, h @ P)
        out.append(theta.copy())
        ll.append(-0.5 * (np.log(2 * np.pi * S) + nu * nu / S))
    return np.array(out), np.array(ll)


def test_kalman_step_matches_textbook_filter_and_chunks():
    rng = np.random.default_rng(0)
    N, B, p = 200, 3, 2
    psi = rng.normal(size=(N, B, 1, p))
    y = np.einsum("nbmp,p->nbm", psi, [0.7, -0.3]) + 0.5 * rng.normal(size=(N, B, 1))
    P0 = np.diag([4.0, 1.0])

    def state():
        return dict(theta=np.zeros((B, p)),
                    theta_sqrt=np.broadcast_to(np.linalg.cholesky(P0), (B, p, p)).copy(),
                    noise_sqrt=np.full((B, 1, 1), 0.5))

    res = kalman_step(psi, y, **state())
    for b in range(B):
        theta, ll = _textbook_kalman(psi[:, b, 0], y[:, b, 0], np.zeros(p), P0, 0.25)
        np.testing.assert_allclose(res.theta[:, b], theta, rtol=1e-9, atol=1e-12)
        np.testing.assert_allclose(res.loglik[:, b], ll, rtol=1e-9, atol=1e-12)
    # the state is the caller's: two chunks equal one call
    st = state()
    a = kalman_step(psi[:77], y[:77], **st)
    b = kalman_step(np.ascontiguousarray(psi[77:]), np.ascontiguousarray(y[77:]), **st)
    np.testing.assert_allclose(np.concatenate([a.theta, b.theta]), res.theta, rtol=1e-12)
    np.testing.assert_allclose(st["theta"], res.theta[-1], rtol=1e-12)


def test_cusum_step_is_the_clipped_sum():
    rng = np.random.default_rng(1)
    df, x = rng.normal(size=50), rng.normal(size=50)
    got = np.array([cusum_step(d, v) for d, v in zip(df, x)])
    np.testing.assert_array_equal(got, np.maximum(0.0, df + x))
    assert cusum_step(1.0, -1.0) == 0.0                     # exactly zero: a last zero
