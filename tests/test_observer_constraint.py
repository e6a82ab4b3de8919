"""Constraint and velocity feature models of the observer (8.1.1, 9.1.1) against oracles."""

import numpy as np
import pytest
from scipy import stats
from scipy.spatial.transform import Rotation

from contactlab.observer import Observer, observe, parse_graph
from contactlab.observer.models import ConstraintFeature, FixedVelocity, MovingVelocity
from contactlab.observer.models.constraint import constraint_normals, parse_constraint
from tests.conftest import assert_same_observer_results

V = np.array([[2.0, 0.3, 0.1], [0.3, 1.5, 0.2], [0.1, 0.2, 1.2]])


def _run(model, x, U=1):
    st = model.init_state(np.zeros(U, int), 6)
    return model.run(st, x, t0=0, starts=np.zeros(U, int)), st


@pytest.mark.parametrize("name", ["0", "Z", "YZ", "XZ", "3"])
def test_fixed_likelihood_is_the_closed_form_marginal(name):
    """Sum of the predictive terms == the joint normal density of the segment's residuals,
    with the surface point integrated out under its prior (scipy on the closed form)."""
    rng = np.random.default_rng(3)
    model = ConstraintFeature.named("c", name, V=V, offset_sd=1e-4)
    n = 30
    x = rng.normal(size=(n, 6)) * np.r_[[2e-5] * 3, [0.02] * 3]
    (ll, chi2), _ = _run(model, x)
    m = model.degree
    R = model.frame
    z = (x[:, :3] * model.scaling.beta) @ R[:, :m]
    f = (x[:, 3:] * model.scaling.alpha) @ R[:, m:]
    want = 0.0
    if m:
        Vn = V[:m, :m]
        C = np.kron(np.eye(n), Vn) + np.kron(np.ones((n, n)), Vn / model.kappa0)
        want += stats.multivariate_normal(np.zeros(n * m), C).logpdf(z.reshape(-1))
    if m < 3:
        want += stats.multivariate_normal(np.zeros(3 - m), V[m:, m:]).logpdf(f).sum()
    assert ll.shape == (n, 1)
    assert ll.sum() == pytest.approx(want, rel=1e-9)
    assert np.all(chi2 >= 0)


@pytest.mark.parametrize("mode", ["fixed", "estimated"])
def test_chunks_equal_one_run_and_instances_are_independent(mode):
    rng = np.random.default_rng(4)
    model = ConstraintFeature.named("c", "Z", mode=mode)
    x = rng.normal(size=(50, 6)) * 1e-3
    (ll, c2), _ = _run(model, x, U=2)
    st = model.init_state(np.zeros(2, int), 6)
    a = model.run(st, x[:13], t0=0, starts=np.zeros(2, int))
    b = model.run(st, x[13:], t0=13, starts=np.zeros(2, int))
    np.testing.assert_allclose(np.r_[a[0], b[0]], ll, rtol=1e-10, atol=1e-9)
    np.testing.assert_allclose(np.r_[a[1], b[1]], c2, rtol=1e-10, atol=1e-9)
    np.testing.assert_array_equal(ll[:, 0], ll[:, 1])


def _plane(rng, n, tilt_deg, *, normal_force=1.0):
    R = Rotation.from_euler("x", tilt_deg, degrees=True).as_matrix()
    N, T = R[:, 2:], R[:, :2]
    pos = (rng.normal(size=(n, 2)) * 2e-3) @ T.T + 0.01 * N.T + rng.normal(size=(n, 3)) * 1e-5
    frc = (normal_force + 0.1 * rng.normal(size=(n, 1))) @ N.T + rng.normal(size=(n, 3)) * 0.01
    return np.c_[pos, frc]


def test_model_of_the_true_frame_wins_and_estimation_finds_a_rotated_frame():
    rng = np.random.default_rng(5)
    x = _plane(rng, 400, 5.0)
    ll = {}
    for mode in ("fixed", "estimated"):
        for rot in (0.0, 5.0):
            m = ConstraintFeature.named("c", "Z", rotate_deg=[rot, 0, 0], mode=mode)
            ll[mode, rot] = _run(m, x)[0][0].sum()
    free = _run(ConstraintFeature.named("c", "0"), x)[0][0].sum()
    assert ll["fixed", 5.0] > ll["fixed", 0.0] + 1000          # 5 deg apart: decisive
    assert ll["estimated", 0.0] > ll["fixed", 0.0] + 1000      # the estimate follows the data
    assert ll["fixed", 5.0] > free + 1000                      # a pressed plane is not free


def test_fit_recovers_the_frame_and_noise_of_labelled_segments():
    rng = np.random.default_rng(6)
    segs = [_plane(rng, 300, 12.0) for _ in range(3)]
    m = ConstraintFeature(name="contact", degree=1, position_sd=1e-5,
                          force_sd=0.01).fit(segs)
    true = Rotation.from_euler("x", 12.0, degrees=True).as_matrix()[:, 2]
    assert abs(abs(m.normals[:, 0] @ true) - 1) < 1e-3
    # the normal-motion variance in normalised units is the position noise (+ the floor)
    assert 1.5 < m.V[0, 0] < 2.5
    fixed = ConstraintFeature(name="c", normals=constraint_normals("Z"), position_sd=1e-5,
                              force_sd=0.01).fit(segs)
    assert np.diag(fixed.V)[1:].max() > 10 * np.diag(m.V)[1:].max()   # wrong frame: force leaks


def test_trained_covariance_is_the_residuals_in_the_frame_the_model_scores():
    # anisotropic friction along the surface: the free block of V must be the scaled
    # force's second moment in the model's own free directions (plus the noise floor),
    # whatever basis of the free span the frame estimator happened to return
    rng = np.random.default_rng(9)
    segs = []
    for _ in range(3):
        s = _plane(rng, 400, 12.0)
        tangent = Rotation.from_euler("x", 12.0, degrees=True).as_matrix()[:, 0]
        s[:, 3:] += np.outer(rng.normal(0, 0.3, len(s)), tangent)    # friction along x'
        segs.append(s)
    m = ConstraintFeature(name="contact", degree=1, position_sd=1e-5,
                          force_sd=0.01).fit(segs)
    T = m.frame[:, 1:]
    f = np.concatenate([s[:, 3:] for s in segs]) * m._alpha
    want = (f @ T).T @ (f @ T) / len(f) + np.eye(2)
    np.testing.assert_allclose(m.V[1:, 1:], want, rtol=1e-9, atol=1e-9)


def test_velocity_models_fit_their_oracles():
    rng = np.random.default_rng(7)
    still = rng.normal(0, 0.003, size=(5000, 3))
    F = FixedVelocity().fit([still])
    assert F.sigma == pytest.approx(0.003, rel=0.03)
    x = rng.normal(size=(20, 3)) * 0.01
    ll = F.run({}, x, t0=0, starts=np.zeros(1))[0][:, 0]
    np.testing.assert_allclose(ll, stats.norm(0, F.sigma).logpdf(x).sum(axis=1))
    t = np.arange(2000)[:, None] / 250.0
    smooth = 0.05 * np.sin(2 * np.pi * np.array([0.3, 0.5, 0.7]) * t + np.array([0, 1, 2]))
    moving = [smooth + rng.normal(0, 0.001, (2000, 3))]
    M = MovingVelocity().fit(moving)
    assert M.high == pytest.approx(0.05, rel=0.05) and M.low == -M.high
    assert 0.0005 < M.sigma < 0.002
    # density: uniform convolved with the noise normal, integrated numerically
    v = 0.0493
    grid = np.linspace(M.low, M.high, 20001)
    want = np.trapezoid(stats.norm(grid, M.sigma).pdf(v), grid) / (M.high - M.low)
    assert np.exp(M.logpdf(np.array([v]))[0]) == pytest.approx(want, rel=1e-4)


def test_parse_constraint_names():
    assert parse_constraint("0")[0] == 0 and parse_constraint("3")[0] == 3
    m, N = parse_constraint("XZ")
    assert m == 2 and np.array_equal(N, np.eye(3)[:, [0, 2]])
    assert parse_constraint("1") == (1, None)
    for bad in ("W", "ZZ", "4", ""):
        with pytest.raises(ValueError):
            parse_constraint(bad)


def test_observer_tracks_free_to_contact_with_triples():
    """A free -> pressed-plane trace through an observer of (constraint, velocity) pairs."""
    rng = np.random.default_rng(8)
    free = np.c_[np.cumsum(rng.normal(size=(300, 3)) * 2e-5, axis=0),
                 rng.normal(size=(300, 3)) * 0.01]
    x = np.r_[free, _plane(rng, 300, 0.0)]
    v = np.r_[rng.normal(0, 0.002, (300, 3)), rng.normal(0, 0.002, (300, 3))]
    g = parse_graph({"models": {"C0": {"kind": "constraint", "constraint": "0"},
                                "CZ": {"kind": "constraint", "constraint": "Z"},
                                "CXZ": {"kind": "constraint", "constraint": "XZ"},
                                "M": {"kind": "velocity-moving", "low": -0.01, "high": 0.01,
                                      "sigma": 0.002}},
                     "nodes": [{"name": "free", "models": {"constraint": "C0", "velocity": "M"},
                                "initial": 1.0},
                               {"name": "Z", "models": {"constraint": "CZ", "velocity": "M"}},
                               {"name": "XZ", "models": {"constraint": "CXZ",
                                                         "velocity": "M"}}],
                     "edges": ["free -> Z, XZ"]})
    models = {"C0": ConstraintFeature.named("C0", "0", position_sd=1e-5, force_sd=0.01),
              "CZ": ConstraintFeature.named("CZ", "Z", position_sd=1e-5, force_sd=0.01),
              "CXZ": ConstraintFeature.named("CXZ", "XZ", position_sd=1e-5, force_sd=0.01),
              "M": MovingVelocity(name="M", low=-0.01, high=0.01, sigma=0.002)}
    res = observe(Observer(g, models), {"contact": x, "velocity": v})
    path = [n for n, _ in res.map_path]
    assert path[0] == "free" and path[-1] == "Z"
    start = dict((n, s) for n, s in res.map_path)["Z"]
    assert 295 <= start <= 320


@pytest.mark.parametrize("slides", [False, True])
def test_a_stuck_finger_is_likelier_under_two_normals_than_under_the_plane(slides):
    """A finger on a Z plane, the exploration pulling on it (9.1.1), with the floor's noise
    (normal motion v_n, friction along x and y v_x, v_y).  Z and XZ share the z normal and
    the y force, so their difference is XZ's x normal (scipy marginal, the surface point
    integrated out) minus Z's x force (scipy normal).  Stuck (x still), XZ wins by about
    1/2 ln(v_x / v_n) a sample -- sticking is a constraint (9.1.2 models it as (S,3,F));
    sliding 1 mm along x, Z wins."""
    vn, vx, vy = 1.4, 6000.0, 2800.0
    Z = ConstraintFeature.named("Z", "Z", V=np.diag([vn, vx, vy]), offset_sd=0.02)
    XZ = ConstraintFeature.named("XZ", "XZ", V=np.diag([vn, vn, vy]), offset_sd=0.02)
    n = 200
    t = np.arange(n) / 250.0
    x = np.zeros((n, 6))
    x[:, 0] = 1e-3 + (1e-3 * np.sin(2 * np.pi * 0.8 * t) if slides else 0.0)
    x[:, 2] = -0.01
    x[:, 3] = 0.15 * np.sin(2 * np.pi * 0.3 * t + 0.4)           # friction force, N
    x[:, 4] = 0.10 * np.sin(2 * np.pi * 0.25 * t)
    x[:, 5] = 0.5 + 0.2 * np.sin(2 * np.pi * 0.35 * t)
    (llz, _), _ = _run(Z, x)
    (llxz, _), _ = _run(XZ, x)
    xs = x[:, 0] * XZ.scaling.beta[0]
    C = vn * np.eye(n) + vn / XZ.kappa0 * np.ones((n, n))
    want = (stats.multivariate_normal(np.zeros(n), C).logpdf(xs)
            - stats.norm(0, np.sqrt(vx)).logpdf(x[:, 3] * Z.scaling.alpha[0]).sum())
    diff = llxz.sum() - llz.sum()
    assert diff == pytest.approx(want, rel=1e-6)       # scipy's factor of C limits it
    if slides:
        assert diff < -100 * n
    else:
        assert diff > 0.8 * n * 0.5 * np.log(vx / vn)


@pytest.mark.parametrize("sides", ["both", "all"])
def test_residual_models_test_only_an_increase(sides):
    """F and constraint models test only the covariance increase of 6.14: a still, quiet
    stretch (zero velocity, force below its noise) fires none of their detectors, whatever
    the observer's sides, while a velocity burst of 10 sigma fires F's increase test at
    once (the CUSUM of 6.18 on chi-square 300 a sample against the threshold 8)."""
    rng = np.random.default_rng(3)
    n = 400
    contact = np.c_[np.zeros((n, 3)), rng.normal(size=(n, 3)) * 0.002]   # force at 1/5 its sd
    vel = np.zeros((n, 3))
    vel[300:] = 10 * 0.001                                                # 10 sigma
    g = parse_graph({"models": {"C0": {"kind": "constraint", "constraint": "0"},
                                "F": {"kind": "velocity-fixed", "sigma": 0.001},
                                "M": {"kind": "velocity-moving", "low": -0.02, "high": 0.02,
                                      "sigma": 0.001}},
                     "nodes": [{"name": "still", "models": {"constraint": "C0", "velocity": "F"},
                                "initial": 1.0},
                               {"name": "moving", "models": {"constraint": "C0",
                                                             "velocity": "M"}}],
                     "edges": ["still -> moving"]})
    models = {"C0": ConstraintFeature.named("C0", "0", position_sd=1e-5, force_sd=0.01),
              "F": FixedVelocity(name="F", sigma=0.001),
              "M": MovingVelocity(name="M", low=-0.02, high=0.02, sigma=0.001)}
    res = observe(Observer(g, models, sides=sides), {"contact": contact, "velocity": vel})
    fired = [e for e in res.events if e.model is not None]
    assert fired and all(e.time >= 300 for e in fired)
    first = min(e.time for e in fired if e.model == "F")
    assert first <= 302
    assert [n for n, _ in res.map_path] == ["still", "moving"]


def test_moving_model_tests_a_stop_against_the_fixed_model():
    """In a graph with both velocity models, M's covariance-decrease test (6.14 with V / q)
    is the log-likelihood ratio of F's N(0, sigma_F^2) against M's second moment: its
    increment per sample equals scipy's normal log densities' difference, so it is
    positive only near rest (here below ~0.5 mm/s) and fires within a sample or two of a
    stop, not on slow motion."""
    g = parse_graph({"models": {"F": {"kind": "velocity-fixed", "sigma": 2e-4},
                                "M": {"kind": "velocity-moving", "low": -0.01, "high": 0.01,
                                      "sigma": 5e-5}},
                     "nodes": [{"name": "moving", "models": {"velocity": "M"}, "initial": 1.0},
                               {"name": "still", "models": {"velocity": "F"}}],
                     "edges": ["moving -> still"]})
    from contactlab.observer import build_models

    models = build_models(g)
    M = models["M"]
    var = 0.02 ** 2 / 12 + 5e-5 ** 2
    assert M.rest_sigma == 2e-4 and M.change_size == pytest.approx(var / 2e-4 ** 2)
    v = np.array([[0.003, -0.002, 0.001], [3e-4, 0.0, -1e-4], [0.0, 0.0, 0.0]])
    _, stat = M.run({}, v, t0=0, starts=np.zeros(1, int))
    q = M.change_size       # the decrease side of 6.14: (m/2) log q - (q - 1)/2 chi2
    dec = 1.5 * np.log(q) - 0.5 * (q - 1) * stat[:, 0]
    oracle = (stats.norm.logpdf(v, scale=2e-4) - stats.norm.logpdf(v, scale=np.sqrt(var))).sum(1)
    assert np.allclose(dec, oracle, rtol=1e-9, atol=1e-9)
    assert dec[0] < 0 < dec[2]
    # moving at 3 mm/s, then a stop: the change is found at the stop
    rng = np.random.default_rng(5)
    vel = np.r_[np.full((200, 3), 0.003), np.zeros((100, 3))] + rng.normal(0, 2e-5, (300, 3))
    res = observe(Observer(g, models, sides="both"), vel)
    assert [n for n, _ in res.map_path] == ["moving", "still"]
    assert 200 <= dict(res.map_path)["still"] <= 202
    assert all(e.time >= 200 for e in res.events if e.model is not None)
@pytest.mark.parametrize("name, tilt", [("Z", 12.0), ("XZ", 7.0)])
def test_estimated_frame_carries_the_8_70_prior_term(name, tilt):
    """With the frame estimated, the score adds log(a) - a alpha (8.70) for the estimate; on
    rich data from a frame turned by ``tilt`` about x the estimate is that frame, so the term
    is log(a) - a alpha with alpha of 8.69 computed here on the full 6 x 3 projections."""
    rng = np.random.default_rng(9)
    R = Rotation.from_euler("x", tilt, degrees=True).as_matrix()
    N0 = constraint_normals(name)
    m = N0.shape[1]
    frame0 = ConstraintFeature.named("c", name).frame
    N, T = R @ frame0[:, :m], R @ frame0[:, m:]
    n = 2000
    pos = (rng.normal(size=(n, 3 - m)) * 2e-3) @ T.T + rng.normal(size=(n, 3)) * 1e-5
    frc = (1.0 + 0.1 * rng.normal(size=(n, m))) @ N.T + rng.normal(size=(n, 3)) * 0.01
    x = np.c_[pos, frc]
    a = 19.5
    kw = dict(mode="estimated", prior_samples=a)
    with_term = _run(ConstraintFeature.named("c", name, **kw), x)[0][0].sum()
    data_only = _run(ConstraintFeature.named("c", name, frame_penalty=False, **kw), x)[0][0].sum()
    P = np.zeros((6, 3))
    P[:3, :m], P[3:, m:] = N, T
    PN = np.zeros((6, 3))
    PN[:3, :m], PN[3:, m:] = frame0[:, :m], frame0[:, m:]
    alpha = 3.0 - np.linalg.svd(P.T @ PN, compute_uv=False).sum()
    assert alpha == pytest.approx(2 * (1 - np.cos(np.radians(tilt))), rel=1e-9)
    assert with_term - data_only == pytest.approx(np.log(a) - a * alpha, rel=1e-3, abs=1e-3)


@pytest.mark.parametrize("name", ["0", "Z", "XZ", "3"])
def test_fixed_frame_chunks_agree_with_the_whole_segment(name):
    # the compiled pass keeps its running sums across chunks: two instances started at
    # different times and fed in uneven chunks score each sample as one pass over all does
    from contactlab.observer.models.constraint import ConstraintFeature

    rng = np.random.default_rng(4)
    V = np.cov(rng.normal(size=(3, 40))) + np.eye(3)
    mdl = ConstraintFeature.named("c", name, V=V)
    x = np.c_[rng.normal(size=(60, 3)) * 3e-5, rng.normal(size=(60, 3)) * 0.02]
    whole = mdl.run(mdl.init_state(np.zeros(2, int), 6), x, t0=0, starts=np.zeros(2, int))[0]
    st = mdl.init_state(np.zeros(2, int), 6)
    parts = [mdl.run(st, x[a:b], t0=a, starts=np.zeros(2, int))[0]
             for a, b in ((0, 1), (1, 23), (23, 60))]
    np.testing.assert_allclose(np.concatenate(parts), whole, rtol=1e-12, atol=1e-12)


def _estimated_oracle(model, x, count):
    """The estimated-frame score written with numpy and LAPACK, sample by sample: the
    frame from ``numpy.linalg.eigh`` of the centred information (8.19, 8.25), each span
    turned onto the nominal one by an SVD (orthogonal Procrustes), alpha of 8.69 from the
    singular values of the full 6 x 3 projections, 8.70's term; ``count`` samples of
    ``x``'s kind precede (their sums are those of ``x``'s rows before it, the state)."""
    m = model.degree
    N0, T0 = model.frame[:, :m], model.frame[:, m:]
    xs, ws = x[:, :3] * model._beta, x[:, 3:] * model._alpha
    P = model.prior_samples * (T0 @ T0.T - N0 @ N0.T)
    lls, prev = [], 0.0
    for t in range(count, len(x)):
        c = t
        sx, sxx, sww = xs[:t].sum(0), xs[:t].T @ xs[:t], ws[:t].T @ ws[:t]
        D = sxx - np.outer(sx, sx) / max(c, 1) - sww + P
        R = np.linalg.eigh(D)[1]
        B = []
        for Bh, B0 in ((R[:, :m], N0), (R[:, m:], T0)):
            if B0.shape[1]:
                u, _, vt = np.linalg.svd(Bh.T @ B0)
                Bh = Bh @ (u @ vt)
            B.append(Bh)
        Nh, Th = B
        ll = 0.0
        if m:
            e = (xs[t] - sx / (model.kappa0 + c)) @ Nh
            g = 1 + 1 / (model.kappa0 + c)
            ll += stats.multivariate_normal(np.zeros(m), np.linalg.inv(model._Vn_inv) * g).logpdf(e)
        if m < 3:
            f = ws[t] @ Th
            ll += stats.multivariate_normal(np.zeros(3 - m), np.linalg.inv(model._Vf_inv)).logpdf(f)
        if 0 < m < 3:
            PP, PN = np.zeros((6, 3)), np.zeros((6, 3))
            PP[:3, :m], PP[3:, m:] = Nh, Th
            PN[:3, :m], PN[3:, m:] = N0, T0
            alpha = 3 - np.linalg.svd(PP.T @ PN, compute_uv=False).sum()
            ll += -model.prior_samples * (alpha - prev) + (np.log(model.prior_samples) if c == 0 else 0)
            prev = alpha
        lls.append(ll)
    return np.array(lls)


@pytest.mark.parametrize("name", ["0", "Z", "XZ", "YZ", "3"])
def test_estimated_frame_score_matches_a_numpy_oracle_in_any_chunks(name):
    # a plane turned 20 deg about x and 10 about y: the estimated frame moves away from the
    # nominal one, so the spans' alignment and 8.70's term matter
    rng = np.random.default_rng(11)
    R = Rotation.from_euler("xy", [20, 10], degrees=True).as_matrix()
    n = 80
    pos = (rng.normal(size=(n, 3)) * [2e-3, 2e-3, 1e-5]) @ R.T
    frc = (np.c_[0.05 * rng.normal(size=(n, 2)), 1 + 0.1 * rng.normal(size=n)]) @ R.T
    x = np.c_[pos, frc]
    mdl = ConstraintFeature.named("c", name, V=V, mode="estimated", prior_samples=19.57)
    want = _estimated_oracle(mdl, x, 0)
    st = mdl.init_state(np.zeros(2, int), 6)
    got = np.concatenate([mdl.run(st, x[a:b], t0=a, starts=np.zeros(2, int))[0]
                          for a, b in ((0, 1), (1, 30), (30, n))])
    np.testing.assert_allclose(got[:, 0], want, rtol=1e-9, atol=1e-7)
    np.testing.assert_array_equal(got[:, 0], got[:, 1])
    # an instance that joins later starts from the prior, as a fresh run on its samples
    st = mdl.init_state(np.zeros(1, int), 6)
    late = mdl.run(st, x[40:], t0=40, starts=np.full(1, 40))[0][:, 0]
    np.testing.assert_allclose(late, _estimated_oracle(mdl, x[40:], 0), rtol=1e-9, atol=1e-7)


def test_log_ndtr_matches_scipy_in_both_tails():
    # scipy below 0; above, log1p of the upper tail (scipy's log of a number near one
    # keeps only its absolute precision there)
    from scipy.special import log_ndtr as scipy_log_ndtr, ndtr

    from contactlab.observer.models.velocity import log_ndtr

    x = np.r_[np.linspace(-60, 40, 2001), -20.0, -19.999, 6.0, 6.001, 0.0]
    got = np.array([log_ndtr(v) for v in x])
    want = np.where(x > 0, np.log1p(-ndtr(-np.abs(x))), scipy_log_ndtr(np.minimum(x, 0)))
    np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-300)


@pytest.mark.parametrize("mode", ["fixed", "estimated"])
def test_the_compiled_core_gives_the_general_forms_results_on_triples(mode):
    """Triples of (high frequency, constraint, velocity) models through the observer's
    compiled core (constraint and velocity models scored by their compiled steps inside its
    loop) and through the general form (model banks through ``run``): the same events,
    paths and path log-likelihoods to the bit, node probabilities to rounding, over a trace
    free and moving -> sliding on a plane turned 4 deg -> stuck -> sliding."""
    from contactlab.observer.models import TemporalFeature

    rng = np.random.default_rng(21)
    R = Rotation.from_euler("x", 4.0, degrees=True).as_matrix()
    n1, n2, n3, n4 = 250, 300, 200, 250
    free = np.c_[np.cumsum(rng.normal(size=(n1, 3)) * 2e-5, axis=0),
                 rng.normal(size=(n1, 3)) * 0.01]
    slide = _plane(rng, n2 + n4, 0.0) @ np.kron(np.eye(2), R.T)
    stuck = np.c_[np.full((n3, 3), 1e-3) + rng.normal(size=(n3, 3)) * 1e-5,
                  rng.normal(size=(n3, 3)) * 0.05 + [0.1, 0.0, 1.0]]
    x = np.r_[free, slide[:n2], stuck, slide[n2:]]
    v = np.r_[rng.normal(0, 0.003, (n1 + n2, 3)), rng.normal(0, 2e-4, (n3, 3)),
              rng.normal(0, 0.003, (n4, 3))]
    y = np.r_[rng.normal(0, 1, n1), rng.normal(0.5, 1.5, n2), rng.normal(0, 0.5, n3),
              rng.normal(0.5, 1.5, n4)]
    kw = dict(position_sd=1e-5, force_sd=0.01)

    def models(general):
        # the general form: the same classes without a core spec (run through ``run``)
        c, f, mv, t = [type(f"General{k.__name__}", (k,), {"core_spec": lambda self, ch: None})
                       if general else k
                       for k in (ConstraintFeature, FixedVelocity, MovingVelocity,
                                 TemporalFeature)]
        hf = dict(order=1, mean=True, theta_sqrt=[0.3, 0.05], structure="plain")
        return {"C0": c.named("C0", "0", **kw),
                "CZ": c.named("CZ", "Z", mode=mode, prior_samples=19.57, **kw),
                "CXZ": c.named("CXZ", "XZ", mode=mode, prior_samples=19.57, **kw),
                "C3": c.named("C3", "3", **kw),
                "F": f(name="F", sigma=2e-4),
                "M": mv(name="M", low=-0.01, high=0.01, sigma=0.003).with_rest(2e-4),
                "S": t(name="S", theta_mean=[0.0, 0.0], noise_var=1.0, **hf),
                "MC": t(name="MC", theta_mean=[0.5, 0.0], noise_var=2.2, **hf)}

    def node(name, hf, c, vel, **more):
        return {"name": name, "models": {"hf": hf, "constraint": c, "velocity": vel}, **more}

    doc = {"models": {"C0": {"kind": "constraint", "constraint": "0"},
                      "CZ": {"kind": "constraint", "constraint": "Z"},
                      "CXZ": {"kind": "constraint", "constraint": "XZ"},
                      "C3": {"kind": "constraint", "constraint": "3"},
                      "F": {"kind": "velocity-fixed", "sigma": 2e-4},
                      "M": {"kind": "velocity-moving", "low": -0.01, "high": 0.01,
                            "sigma": 0.003},
                      "S": {"kind": "temporal"}, "MC": {"kind": "temporal"}},
           "nodes": [node("free", "S", "C0", "M", initial=1.0), node("Z", "MC", "CZ", "M"),
                     node("XZ", "MC", "CXZ", "M"), node("stuck", "S", "C3", "F")],
           "edges": ["free -> Z, XZ", "Z -> stuck", "XZ -> stuck", "stuck -> Z, XZ"]}
    g = parse_graph(doc)
    data = {"hf": y[:, None], "contact": x, "velocity": v}
    core_obs, general_obs = Observer(g, models(False)), Observer(g, models(True))
    fast, slow = observe(core_obs, data, chunk=333), observe(general_obs, data, chunk=333)
    assert core_obs._core is not None and general_obs._core is None
    assert len([e for e in slow.events if e.model]) >= 4
    assert [n for n, _ in slow.map_path][:2] == ["free", "Z"] and "stuck" in dict(slow.map_path)
    assert_same_observer_results(fast, slow)

