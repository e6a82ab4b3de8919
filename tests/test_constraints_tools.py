"""Friction filter, scaling, alignment, degree, direction, exploration, recursive form."""

import math

import numpy as np
import pytest

from contactlab.constraints import (POSITION_SD, AlignmentDegreeTest, CartesianConstraint,
                                    CartesianStiffness, RecursiveConstraint, alignment_penalty,
                                    alignment_statistic, angular_error_deg,
                                    decide_degree, decide_direction, direction_cosines,
                                    equivalent_angle_deg, exploration, friction_filter,
                                    joint_projection, lognormal_summary, prior_rate,
                                    reciprocal_scaling)
from contactlab.errors import UsageError
from contactlab.metrics import confusion_matrix
from tests.test_constraints_cartesian import contact_block


def rot_x(deg):
    c, s = math.cos(math.radians(deg)), math.sin(math.radians(deg))
    return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])


# -- friction (8.29) ----------------------------------------------------------------------------

def test_friction_filter_is_the_projection_off_the_velocity():
    rng = np.random.default_rng(0)
    w, v = rng.normal(size=(200, 3)), rng.normal(size=(200, 3))
    out = friction_filter(w, v)
    np.testing.assert_allclose(np.einsum("ti,ti->t", out, v), 0.0, atol=1e-12)   # _|_ v
    np.testing.assert_allclose(friction_filter(out, v), out, atol=1e-12)          # idempotent
    u = np.cross(v, rng.normal(size=(200, 3)))                                    # _|_ v: kept
    np.testing.assert_allclose(friction_filter(u, v), u, atol=1e-12)
    proj = np.eye(3)[None] - v[:, :, None] * v[:, None, :] / (v ** 2).sum(1)[:, None, None]
    np.testing.assert_allclose(out, np.einsum("tij,tj->ti", proj, w), atol=1e-12)


def test_friction_filter_leaves_stationary_samples():
    w = np.array([[1.0, 2.0, 3.0], [1.0, 2.0, 3.0]])
    v = np.array([[0.0, 0.0, 0.0], [1e-9, 0.0, 0.0]])
    np.testing.assert_array_equal(friction_filter(w, v, min_speed=1e-6), w)
    with pytest.raises(UsageError):
        friction_filter(w, v[:1])


# -- scaling (8.7-8.9) --------------------------------------------------------------------------

def test_scaling_preserves_reciprocity():
    s = reciprocal_scaling([1e-5, 2e-5, 4e-6], [0.01, 0.03, 0.002])
    prod = s.alpha * s.beta
    np.testing.assert_allclose(prod, prod[0], rtol=1e-12)            # 8.9
    u = reciprocal_scaling(1e-5, 0.01)
    np.testing.assert_allclose(u.beta, 1e5), np.testing.assert_allclose(u.alpha, 100.0)
    rng = np.random.default_rng(1)
    n = np.linalg.qr(rng.normal(size=(3, 3)))[0]
    ns, ts = s.normals_to_scaled(n[:, :1]), s.free_to_scaled(n[:, 1:])
    np.testing.assert_allclose(ns.T @ ts, 0.0, atol=1e-12)           # still reciprocal
    with pytest.raises(UsageError):
        reciprocal_scaling(0.0, 1.0)


# -- alignment (tables 8.1-8.5) -----------------------------------------------------------------

def test_alignment_of_a_known_rotation():
    N = np.eye(3)[:, :1]
    for deg in (0.5, 5.0, 30.0):
        M = rot_x(deg) @ np.array([[0.0], [0.0], [1.0]])
        assert angular_error_deg(M, np.array([[0.0], [0.0], [1.0]])) == pytest.approx(deg)
    P = joint_projection(np.eye(3)[:, 2:])
    Pr = joint_projection(rot_x(10) @ np.eye(3)[:, 2:], rot_x(10) @ np.eye(3)[:, :2])
    s = direction_cosines(Pr, P)
    np.testing.assert_allclose(np.sort(s), [math.cos(math.radians(10))] * 2 + [1.0])
    assert angular_error_deg(N, N) == 0.0


def test_lognormal_summary_matches_table_8_1_conversion():
    # table 8.1: mu -10.9 -> 0.34 deg, -5.09 -> 6.34, -4.00 -> 11.0 (thesis numbers)
    assert equivalent_angle_deg(-10.9) == pytest.approx(0.34, abs=0.01)
    assert equivalent_angle_deg(-5.09) == pytest.approx(6.34, abs=0.05)
    assert equivalent_angle_deg(-4.00) == pytest.approx(11.0, abs=0.1)
    d = np.exp(np.random.default_rng(2).normal(-8.0, 0.5, 400))
    out = lognormal_summary(d, sample_size=25)
    assert out["mu"] == pytest.approx(np.log(d).mean())
    assert out["sigma_sqrt_n"] == pytest.approx(out["sigma"] * 5)
    assert lognormal_summary(np.zeros(10))["angle_deg"] == 0.0       # the tables' NA


# -- degree (8.2) -------------------------------------------------------------------------------

def test_decide_degree_and_confusion():
    ll = np.array([[1.0, 3.0, np.nan, 0.0], [np.nan] * 4, [5.0, 4.0, 3.0, 2.0]])
    np.testing.assert_array_equal(decide_degree(ll), [1, -1, 0])
    C = confusion_matrix([0, 0, 1, 1], [0, 1, 1, -1], 4)[1]
    np.testing.assert_allclose(C[0], [0.5, 0.5, 0, 0])
    np.testing.assert_allclose(C[1], [0, 0.5, 0, 0])
    assert np.isnan(C[2:]).all()              # no blocks of degrees 2, 3: no rate


def test_likelihood_degree_test_on_rich_blocks():
    true, chosen = [], []
    for m in range(4):
        for seed in range(12):
            x, w, _, _ = contact_block(m, n=25, seed=100 * m + seed)
            true.append(m)
            chosen.append(CartesianConstraint().estimate(x, w).degree_)
    assert np.mean(np.array(true) == np.array(chosen)) >= 0.95


def test_alignment_degree_test_and_its_overconfidence_on_noise():
    stats, classes = [], []
    for m in range(4):
        for seed in range(30):
            x, w, _, _ = contact_block(m, n=25, seed=1000 + 50 * m + seed)
            stats.append(alignment_statistic(CartesianStiffness().estimate(x, w).P_))
            classes.append(m)
    test = AlignmentDegreeTest().fit(np.array(stats), np.array(classes))
    assert np.mean(test.predict(np.array(stats)) == np.array(classes)) > 0.95
    rng = np.random.default_rng(5)
    noise = np.array([alignment_statistic(CartesianStiffness(max_tilt_sd_deg=1e9).estimate(
        rng.normal(size=(25, 3)) * POSITION_SD, rng.normal(size=(25, 3)) * 0.01).P_)
        for _ in range(60)])
    ll = test.log_likelihoods(noise)
    post = np.exp(ll - ll.max(1, keepdims=True))
    post /= post.sum(1, keepdims=True)
    picks = np.argmax(ll, axis=1)
    assert len(np.unique(picks)) >= 2                  # a class "at random" ...
    assert np.median(post.max(1)) > 0.9                # ... chosen with high confidence


def test_alignment_degree_test_fit_returns_self():
    """``fit`` means scikit-learn's everywhere: estimate from data, return self."""
    stats = np.random.default_rng(1).normal(size=(40, 2))
    test = AlignmentDegreeTest()
    assert test.fit(stats, np.arange(40) % 2) is test


# -- direction (8.69-8.70) ----------------------------------------------------------------------

def test_direction_prior_and_penalty():
    assert prior_rate(15.0) == pytest.approx(2 / 3 / (1 - math.cos(math.radians(15))))
    P = joint_projection(np.eye(3)[:, 2:])
    Pr = joint_projection(rot_x(20) @ np.eye(3)[:, 2:])
    assert alignment_penalty(P, P) == pytest.approx(0.0, abs=1e-12)
    assert alignment_penalty(Pr, P) == pytest.approx(2 * (1 - math.cos(math.radians(20))))


def test_direction_decision_picks_the_true_frame():
    frame = np.eye(3)[:, [2, 0, 1]]                   # normal z
    xs, ws = [], []
    for seed in range(20):
        x, w, _, _ = contact_block(1, n=25, seed=seed, frame=frame)
        xs.append(x), ws.append(w)
    fits = CartesianConstraint().estimate_blocks(np.array(xs), np.array(ws))
    hyps = [np.array([[0.0], [0.0], [1.0]]), rot_x(20) @ np.array([[0.0], [0.0], [1.0]])]
    choice, scores = decide_direction(fits, hyps)
    assert (choice == 0).all() and scores.shape == (20, 2)
    # bottom of the plane = top: the sign cannot be told (8.3)
    _, s2 = decide_direction(fits, [hyps[0], -hyps[0]])
    np.testing.assert_allclose(s2[:, 0], s2[:, 1])


# -- exploration (9.1.2) ------------------------------------------------------------------------

def test_exploration_counts_moved_or_pushed_directions():
    I = np.zeros((6, 6))
    I[0, 0] = 100.0                   # moved along x
    I[5, 5] = 50.0                    # pushed along z
    e = exploration(I)
    assert e.significant[0] == 2 and not e.explored[0]
    np.testing.assert_allclose(np.abs(e.unexplored(0)[:, 0]), [0, 1, 0])
    I[1, 1] = 20.0
    assert exploration(I).explored[0]


# -- recursive form -----------------------------------------------------------------------------

def test_recursive_information_equals_batch():
    x, w, v, N = contact_block(1, n=80, seed=9)
    rec = RecursiveConstraint()
    path1 = rec.update(x[:30], w[:30], return_path=True)
    path2 = rec.update(x[30:], w[30:], return_path=True)
    batch = CartesianConstraint().estimate(x, w)
    np.testing.assert_allclose(rec.information_, batch.information_, rtol=1e-9, atol=1e-6)
    np.testing.assert_allclose(path2[-1], batch.information_, rtol=1e-9, atol=1e-6)
    first = CartesianConstraint().estimate(x[:30], w[:30])
    np.testing.assert_allclose(path1[-1], first.information_, rtol=1e-9, atol=1e-6)
    fit = rec.estimate()
    assert fit.degree_ == 1 and angular_error_deg(fit.normals_, batch.normals_) < 1e-6
    assert fit.loglik_ == pytest.approx(batch.loglik_, rel=1e-9)
