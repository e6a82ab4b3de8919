"""Cartesian constraint estimators (8.12-8.28) against simulated truth and numpy/scipy oracles."""

import math

import numpy as np
import pytest

from contactlab.constraints import (FORCE_SD, POSITION_SD, CartesianConstraint,
                                    CartesianStiffness, angular_error_deg, joint_projection)
from contactlab.constraints import frames as F
from contactlab.errors import DataError, UsageError
from contactlab.constraints.scaling import reciprocal_scaling


def contact_block(m, *, n=100, seed=0, amp=2e-3, press=1.0, force_var=0.2, mu=0.0,
                  frame=None):
    """Point moving on m random linear constraints: motion along the free
    directions, force along the normals (plus Coulomb friction mu), sensor noise."""
    rng = np.random.default_rng(seed)
    Q = frame if frame is not None else np.linalg.qr(rng.normal(size=(3, 3)))[0]
    N, T = Q[:, :m], Q[:, m:]
    t = np.linspace(0, 1, n)
    path = np.array([np.sin(2 * np.pi * (j + 1) * t + rng.uniform(0, 6))
                     for j in range(3 - m)]).reshape(3 - m, n)
    x = (T @ (path * amp)).T
    fn = (N @ (rng.normal(size=(m, n)) * force_var + press)).T
    v = np.gradient(x, axis=0)
    speed = np.linalg.norm(v, axis=1, keepdims=True)
    fric = -mu * np.linalg.norm(fn, axis=1, keepdims=True) * v / np.maximum(speed, 1e-300)
    w = fn + fric
    x = x + rng.normal(size=x.shape) * POSITION_SD
    w = w + rng.normal(size=w.shape) * FORCE_SD
    return x, w, v * 250.0, N


@pytest.mark.parametrize("m", [0, 1, 2, 3])
def test_constraint_form_recovers_random_frames(m):
    for seed in range(4):
        x, w, _, N = contact_block(m, seed=seed)
        fit = CartesianConstraint().estimate(x, w)
        assert fit.status_ == "ok" and fit.degree_ == m
        assert fit.normals_.shape == (3, m) and fit.free_.shape == (3, 3 - m)
        assert angular_error_deg(fit.normals_, N) < 0.5
        frame = np.concatenate([fit.normals_, fit.free_], axis=1)
        np.testing.assert_allclose(frame.T @ frame, np.eye(3), atol=1e-10)   # reciprocal bases
        assert np.argmax(fit.log_likelihoods_) == m


@pytest.mark.parametrize("m", [1, 2])
def test_logdet_newton_matches_powell_and_a_grid(m):
    x, w, _, _ = contact_block(m, n=40, seed=11, amp=2e-4, force_var=0.02)
    est = CartesianConstraint(degree=m)
    fit = est.estimate(x, w)
    I = fit.information_[None]
    R_new = np.concatenate([fit.scaling.normals_to_scaled(fit.normals_),
                            fit.scaling.free_to_scaled(fit.free_)], axis=1)
    f_new = F.logdet_value(I, R_new[None], m, 1.0)[0]
    R_pow, f_pow, _, _ = F.powell_logdet(I[0], F.gram_schmidt_start(I, m)[0], m, 1.0)
    assert f_new <= f_pow + 1e-8
    assert angular_error_deg(R_pow[:, :m], R_new[:, :m]) < 1e-3
    # grid over the sphere: the unit vector u is the normal (m=1) or the free direction (m=2)
    th, ph = np.meshgrid(np.linspace(0, np.pi, 91), np.linspace(0, 2 * np.pi, 181))
    u = np.stack([np.sin(th) * np.cos(ph), np.sin(th) * np.sin(ph), np.cos(th)], -1).reshape(-1, 3)
    Rs = np.stack([F.trace_closed_form(I, 1)[0]] * len(u))
    comp = np.linalg.qr(np.concatenate([u[:, :, None], np.broadcast_to(np.eye(3), (len(u), 3, 3))],
                                       axis=2))[0]
    Rs = comp[:, :, :3] if m == 1 else comp[:, :, [1, 2, 0]]
    f_grid = F.logdet_value(np.broadcast_to(I, (len(u),) + I.shape[1:]), Rs, m, 1.0)
    assert f_new <= f_grid.min() + 1e-9


@pytest.mark.parametrize("m", [1, 2])
def test_trace_criterion_newton_equals_closed_form(m):
    rng = np.random.default_rng(3)
    for seed in range(3):
        x, w, _, _ = contact_block(m, seed=seed)
        fit = CartesianConstraint(degree=m, criterion="trace", solver="newton").estimate(x, w)
        I = fit.information_
        k = 3
        D = I[:k, :k] - I[k:, k:]
        lam = np.linalg.eigvalsh(D)                       # Ky Fan oracle
        R = np.concatenate([fit.scaling.normals_to_scaled(fit.normals_),
                            fit.scaling.free_to_scaled(fit.free_)], axis=1)
        value = F.trace_value(I[None], R[None], m)[0]
        assert value == pytest.approx(np.trace(I[k:, k:]) + lam[:m].sum(), rel=1e-9, abs=1e-9)
        for _ in range(50):                               # no orthonormal frame does better
            Qr = np.linalg.qr(rng.normal(size=(3, 3)))[0]
            assert F.trace_value(I[None], Qr[None], m)[0] >= value - 1e-9


def test_loglik_is_8_15_at_the_ml_covariance():
    x, w, _, _ = contact_block(1, n=60, seed=5)
    fit = CartesianConstraint(degree=1, noise_floor=0.0).estimate(x, w)
    nu = fit.residuals_
    V = nu.T @ nu / len(nu)                                # 8.17 from the residuals
    np.testing.assert_allclose(V, fit.V_, rtol=1e-9, atol=1e-9)
    direct = -0.5 * (len(nu) * np.linalg.slogdet(V)[1]
                     + np.einsum("ti,ij,tj->", nu, np.linalg.inv(V), nu))   # 8.15
    assert fit.loglik_ == pytest.approx(direct, rel=1e-9)


def test_stiffness_form_is_the_eigh_subspace():
    x, w, _, N = contact_block(1, n=80, seed=2)
    fit = CartesianStiffness(noise_floor=0.0).estimate(x, w)
    y = np.hstack([x / POSITION_SD, w / FORCE_SD])
    C = np.cov(y.T, bias=True)                             # 8.19 with the mean removed
    lam, vec = np.linalg.eigh(C)
    assert angular_error_deg(fit.P_, vec[:, :3]) < 1e-4
    assert fit.loglik_ == pytest.approx(-80 / 2 * (np.log(lam[:3]).sum() + 3), rel=1e-9)
    assert fit.degree_ == 1 and angular_error_deg(fit.normals_, N) < 2.0
    assert angular_error_deg(fit.P_, joint_projection(N)) < 2.0


def test_anisotropic_accuracies_keep_reciprocity():
    x, w, _, N = contact_block(2, seed=4)
    est = CartesianConstraint(position_sd=[5e-6, 9e-6, 2e-5], force_sd=[0.01, 0.02, 0.005])
    fit = est.estimate(x, w)
    assert fit.degree_ == 2
    np.testing.assert_allclose(fit.normals_.T @ fit.free_, 0.0, atol=1e-10)
    assert angular_error_deg(fit.normals_, N) < 1.0


def test_friction_filter_rescues_the_stiffness_form():
    x, w, v, N = contact_block(1, n=200, seed=6, mu=0.6, force_var=0.05)
    raw = CartesianStiffness(degree=1).estimate(x, w)
    filt = CartesianStiffness(degree=1, friction=True).estimate(x, w, velocity=v)
    cons = CartesianConstraint(friction=True).estimate(x, w, velocity=v)
    assert angular_error_deg(filt.normals_, N) < angular_error_deg(raw.normals_, N)
    assert cons.degree_ == 1 and angular_error_deg(cons.normals_, N) < 1.0


def test_velocity_variant():
    x, w, v, N = contact_block(1, n=100, seed=8)
    v = v + np.random.default_rng(0).normal(size=v.shape) * 1e-3
    fit = CartesianConstraint(motion="velocity").estimate(x, w, velocity=v)
    assert fit.degree_ == 1 and angular_error_deg(fit.normals_, N) < 1.0
    with pytest.raises(UsageError):
        CartesianConstraint(motion="velocity").estimate(x, w)


def test_estimate_blocks_equals_estimate():
    xs, ws = [], []
    for seed in range(6):
        x, w, _, _ = contact_block(seed % 4, n=25, seed=seed)
        xs.append(x), ws.append(w)
    est = CartesianConstraint()
    blocks = est.estimate_blocks(np.array(xs), np.array(ws))
    for b in range(6):
        one = est.estimate(xs[b], ws[b])
        np.testing.assert_allclose(blocks.log_likelihoods[b], one.log_likelihoods_, rtol=1e-9)
        assert blocks.degree[b] == (one.degree_ if one.degree_ is not None else -1)


def test_angle_sd_is_calibrated():
    """The predicted angular standard error matches the scatter of the estimates."""
    frame = np.linalg.qr(np.random.default_rng(99).normal(size=(3, 3)))[0]
    errs, sds = [], []
    for seed in range(120):
        x, w, _, N = contact_block(1, n=50, seed=seed, amp=1e-4, force_var=0.02, frame=frame)
        fit = CartesianConstraint(degree=1).estimate(x, w)
        errs.append(math.radians(angular_error_deg(fit.normals_, N)))
        sds.append(math.sqrt(np.trace(fit.cov_)))
    ratio = math.sqrt(np.mean(np.square(errs))) / np.mean(sds)
    assert 0.7 < ratio < 1.4


def test_too_few_samples_is_an_error():
    x, w, _, _ = contact_block(1, n=6)
    with pytest.raises(DataError, match="needs at least 7"):
        CartesianConstraint().estimate(x, w)
    with pytest.raises(DataError):
        CartesianStiffness().estimate(x, w)


def test_non_finite_is_an_error():
    x, w, _, _ = contact_block(1, n=20)
    w[3, 1] = np.nan
    with pytest.raises(DataError):
        CartesianConstraint().estimate(x, w)


def test_identical_samples_are_undetermined():
    x = np.tile([0.01, 0.02, 0.03], (30, 1))
    w = np.tile([0.0, 0.0, 1.0], (30, 1))
    fit = CartesianConstraint().estimate(x, w)
    assert fit.status_ == "undetermined" and fit.degree_ is None
    assert np.isnan(fit.normals_).all() and "exploration" in fit.reason_
    st = CartesianStiffness().estimate(x, w)
    assert st.status_ == "undetermined" and np.isnan(st.normals_).all()
    # a two-constraint frame is not determined by one constant force
    fit2 = CartesianConstraint(degree=2).estimate(x, w)
    assert fit2.status_ == "undetermined" and np.isnan(fit2.normals_).all()


def test_no_motion_no_force_is_undetermined():
    rng = np.random.default_rng(1)
    x = rng.normal(size=(50, 3)) * POSITION_SD
    w = rng.normal(size=(50, 3)) * FORCE_SD
    for degree in (None, 1, 2):
        fit = CartesianConstraint(degree=degree).estimate(x, w)
        assert fit.status_ == "undetermined", degree
        assert np.isnan(fit.normals_).all()


def test_motion_along_one_line_is_undetermined_for_the_degree():
    """Moving along x with no force cannot tell whether y and z are free (9.1.1)."""
    x, w, _, _ = contact_block(0, n=60, seed=3, frame=np.eye(3))
    x[:, 1:] = np.random.default_rng(0).normal(size=(60, 2)) * POSITION_SD
    fit = CartesianConstraint().estimate(x, w)
    assert fit.status_ == "undetermined" and fit.unexplored_.shape[1] == 2


def test_bad_parameters():
    x, w, _, _ = contact_block(1, n=20)
    for kw in ({"degree": 4}, {"criterion": "nope"}, {"solver": "eigh"}, {"motion": "x"},
               {"noise_floor": -1.0}, {"position_sd": 0.0}):
        with pytest.raises(UsageError):
            CartesianConstraint(**kw).estimate(x, w)


def test_estimate_from_running_information_equals_the_block_estimate():
    """estimate_information_blocks on the running information of RecursiveConstraint after
    n samples is estimate_blocks on those n samples (frames, 8.18, decision)."""
    from contactlab.constraints import CartesianConstraint, RecursiveConstraint
    from contactlab.synthetic import contact_trial

    t = contact_trial(seed=8, degree=1, duration_s=0.4, position_sd=1e-5, force_sd=0.01)
    pos, frc = t.position[::4], t.force[::4]
    est = CartesianConstraint(position_sd=1e-5, force_sd=0.01)
    rec = RecursiveConstraint(est)
    path = rec.update(pos, frc, return_path=True)
    ends = np.array([30, 60, 99])
    got = est.estimate_information_blocks(path[ends - 1], ends, scaling=rec.scaling)
    for i, n in enumerate(ends):
        want = est.estimate_blocks(pos[:n], frc[:n])
        np.testing.assert_allclose(got.log_likelihoods[i], want.log_likelihoods[0], rtol=1e-9)
        assert got.degree[i] == want.degree[0] == 1
    assert got.n.tolist() == ends.tolist()


def _diagonal_information(R, dx, dw):
    """Joint information with Ixx = R diag(dx) R^T, Iww = R diag(dw) R^T, no cross terms."""
    I = np.zeros((6, 6))
    I[:3, :3] = R @ np.diag(dx) @ R.T
    I[3:, 3:] = R @ np.diag(dw) @ R.T
    return I


def test_ratio_start_is_the_exact_minimiser_of_a_diagonal_information():
    # oracle: with Ixx, Iww diagonal in R, log det V = sum_normals log(dx+1) + sum_free
    # log(dw+1); the best m axes are those with the smallest (dx+1)/(dw+1) (enumerated)
    from itertools import combinations
    from scipy.spatial.transform import Rotation

    rng = np.random.default_rng(3)
    for _ in range(20):
        R = Rotation.random(random_state=rng).as_matrix()
        dx, dw = rng.uniform(0, 1000, 3), rng.uniform(0, 1000, 3)
        I = _diagonal_information(R, dx, dw)
        for m in (1, 2):
            best = min(combinations(range(3), m), key=lambda c: sum(
                math.log(dx[i] + 1) - math.log(dw[i] + 1) for i in c))
            R0 = F.ratio_start(I[None], m, 1.0)[0]
            ang = np.degrees(np.arccos(np.clip(np.linalg.svd(R0[:, :m].T @ R[:, best],
                                                             compute_uv=False).min(), -1, 1)))
            assert ang < 1e-5


def test_default_start_finds_the_optimum_when_friction_outweighs_motion():
    # the velocity-form line of 8.1.1.2: motion along the free direction (22 units rms)
    # smaller than the stick friction force along it (55 units), which is larger than
    # the force into one of the normals (24 units).  The trace start (Ixx - Iww) takes
    # the free direction for a normal and Newton stays in that basin; the default keeps
    # the better of the trace and ratio starts, whose frame is the true one (the exact
    # optimum, previous test).
    from scipy.spatial.transform import Rotation

    R = Rotation.random(random_state=np.random.default_rng(5)).as_matrix()
    dx = np.array([1.0, 1.0, 500.0])       # normals: velocity noise only; free: moves
    dw = np.array([600.0, 5000.0, 3000.0])
    I = _diagonal_information(R, dx, dw)
    sc = reciprocal_scaling(1.0, 1.0, 3)
    N = R[:, :2]
    trace_only = CartesianConstraint(degree=2, start="trace").estimate_information(I, 400, scaling=sc)
    default = CartesianConstraint(degree=2).estimate_information(I, 400, scaling=sc)
    assert angular_error_deg(trace_only.normals_, N) > 45          # the local optimum
    assert angular_error_deg(default.normals_, N) < 1e-4
    assert default.loglik_ >= default.loglik_at(N) - 1e-9


@pytest.mark.parametrize("m", [1, 2])
def test_per_sample_scores_average_to_the_analytic_gradient(m):
    # oracle: logdet_gradient (the derivative of log det V, itself checked against Powell)
    rng = np.random.default_rng(11)
    y = rng.standard_normal((200, 6)) * rng.uniform(0.5, 30, 6) + rng.standard_normal(6)
    R = np.linalg.qr(rng.standard_normal((3, 3)))[0]
    I = y.T @ y / len(y)
    _, g = F.logdet_gradient(I[None], R[None], m, 1.0)
    s = F.logdet_scores(y, R, m, 1.0)
    assert np.allclose(s.mean(axis=0), g[0].reshape(-1), rtol=1e-9, atol=1e-12)


def test_long_run_covariance_of_an_ar1_series():
    # closed form: the long-run variance of x_t = rho x_{t-1} + e_t is sd_e^2 / (1 - rho)^2;
    # white noise keeps its variance
    rng = np.random.default_rng(2)
    from scipy.signal import lfilter
    e = rng.standard_normal((40000, 1))
    x = lfilter([1.0], [1.0, -0.8], e, axis=0)
    lr, lag = F.long_run_covariance(x)
    assert lag > 5
    assert abs(lr[0, 0] / (1 / 0.2 ** 2) - 1) < 0.15
    w, lag_w = F.long_run_covariance(e)
    assert abs(w[0, 0] - 1) < 0.05 and lag_w <= 10


def test_hac_sd_equals_iid_sd_on_independent_samples():
    # independent Gaussian samples: the sandwich estimates the inverse information
    # (the same sd to within its sampling error)
    from scipy.spatial.transform import Rotation
    rng = np.random.default_rng(4)
    Rt = Rotation.random(random_state=rng).as_matrix()
    n = 2000
    pos = rng.normal(0, 3e-3, (n, 2)) @ Rt[:, 1:].T + rng.normal(0, 1e-5, (n, 3))
    frc = rng.normal(1.0, 0.3, (n, 1)) * Rt[:, :1].T + rng.normal(0, 0.01, (n, 3))
    kw = dict(degree=1, position_sd=1e-5, force_sd=0.01)
    hac = CartesianConstraint(**kw).estimate(pos, frc)
    iid = CartesianConstraint(**kw, uncertainty="iid").estimate(pos, frc)
    assert hac.angle_sd_deg_ == pytest.approx(iid.angle_sd_deg_, rel=0.15)
