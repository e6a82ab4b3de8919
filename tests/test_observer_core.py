"""The 6.4 observer against independent oracles and simulated ground truth."""

from __future__ import annotations

import json

import numpy as np
import pytest
from scipy import integrate, stats
from scipy.special import logsumexp

from contactlab.observer import (FixedVelocity, ImpactFeature, MovingVelocity, Observer,
                                 TemporalFeature, observe, parse_graph)
from tests.conftest import assert_same_observer_results

# AR(1) with a forcing mean: y(n) = mu + a y(n-1) + e, e ~ N(0, v)
PARAMS = {"A": (0.0, 0.5, 1.0), "B": (3.0, 0.5, 1.0), "C": (0.0, 0.5, 6.0)}


def ar_models(params=PARAMS, sd=(0.3, 0.05)):
    return {k: TemporalFeature(name=k, order=1, mean=True, theta_mean=[mu, a], theta_sqrt=list(sd),
                               noise_var=v, structure="plain") for k, (mu, a, v) in params.items()}


def graph(names, *, edges=("* -> *",), self_transition=True, initial="uniform", extra=None):
    doc = {"name": "t", "models": {k: {"kind": "temporal"} for k in names},
           "nodes": [{"name": k, "models": k, "self_transition": self_transition} for k in names],
           "edges": list(edges)}
    if initial == "uniform":
        doc["initial"] = "uniform"
    else:
        for n, p in zip(doc["nodes"], initial):
            n["initial"] = p
    doc.update(extra or {})
    return parse_graph(doc)


def simulate(segments, n, seed, params=PARAMS):
    rng = np.random.default_rng(seed)
    y = np.zeros(n)
    bounds = [s for _, s in segments] + [n]
    for (k, s), e in zip(segments, bounds[1:]):
        mu, a, v = params[k]
        noise = rng.normal(scale=np.sqrt(v), size=e - s)
        for i in range(s, e):
            y[i] = mu + a * (y[i - 1] if i else 0.0) + noise[i - s]
    return y


def merge_short(path, min_len, n):
    """Merge self-transitions, drop segments shorter than min_len samples, merge again."""
    def merge(p):
        out = []
        for node, s in p:
            if not out or out[-1][0] != node:
                out.append((node, s))
        return out

    path = merge(path)
    ends = [s for _, s in path[1:]] + [n]
    return merge([(node, s) for (node, s), e in zip(path, ends) if e - s >= min_len])


def test_single_node_loglik_is_the_gaussian_marginal():
    """One node, no changes: path log-likelihood = log N(y; Psi m, Psi P Psi^T + v I) (scipy)."""
    rng = np.random.default_rng(3)
    n = 150
    y = np.cumsum(rng.normal(size=n)) * 0.3 + rng.normal(size=n)
    mu0, P0, v = np.array([0.2, 0.6]), np.diag([0.5, 0.2]) ** 2, 0.8
    model = TemporalFeature(name="A", order=1, mean=True, theta_mean=mu0, theta_sqrt=[0.5, 0.2],
                            noise_var=v, structure="plain")
    g = graph(["A"], edges=(), self_transition=False)
    obs = Observer(g, {"A": model}, threshold=1e9)
    observe(obs, y, chunk=37)
    Psi = np.c_[np.ones(n - 1), y[:-1]]                   # rows for samples 1..n-1 (lag 1)
    cov = Psi @ P0 @ Psi.T + v * np.eye(n - 1)
    oracle = stats.multivariate_normal(Psi @ mu0, cov).logpdf(y[1:])
    (path,) = obs.paths()
    assert path.loglik == pytest.approx(oracle, rel=1e-9, abs=1e-8)
    assert path.history == [("A", 0)]


def test_composite_node_logliks_add():
    """A node (temporal, velocity F) scores the sum of the two models' log-likelihoods."""
    rng = np.random.default_rng(4)
    n = 80
    hf = rng.normal(size=n)
    vel = rng.normal(scale=0.01, size=(n, 3))
    temporal = TemporalFeature(name="S", order=1, mean=True, theta_mean=[0.0, 0.0],
                               theta_sqrt=[0.3, 0.3], noise_var=1.0, structure="plain")
    fixed = FixedVelocity(name="F", sigma=0.01)
    doc = {"name": "c", "initial": "uniform",
           "models": {"S": {"kind": "temporal"}, "F": {"kind": "velocity-fixed", "sigma": 0.01}},
           "nodes": [{"name": "N", "models": {"hf": "S", "velocity": "F"}, "self_transition": False}]}
    obs = Observer(parse_graph(doc), {"S": temporal, "F": fixed}, threshold=1e9)
    obs.update({"hf": hf, "velocity": vel})
    Psi = np.c_[np.ones(n - 1), hf[:-1]]
    cov = Psi @ np.diag([0.09, 0.09]) @ Psi.T + np.eye(n - 1)
    oracle = (stats.multivariate_normal(np.zeros(n - 1), cov).logpdf(hf[1:])
              + stats.norm(0, 0.01).logpdf(vel[1:]).sum())
    assert obs.paths()[0].loglik == pytest.approx(oracle, rel=1e-9)


def test_moving_velocity_density_is_uniform_convolved_with_noise():
    m = MovingVelocity(low=-0.01, high=0.01, sigma=0.002)
    for v in (-0.018, -0.011, 0.0, 0.004, 0.0105, 0.02):
        dens, _ = integrate.quad(lambda u: stats.norm(u, 0.002).pdf(v) / 0.02, -0.01, 0.01,
                                 points=[v], limit=200)
        assert m.logpdf(v) == pytest.approx(np.log(dens), rel=1e-6)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_map_path_recovers_piecewise_ar(seed):
    """Switching AR processes: the MAP path's node sequence and change times.

    Segments shorter than 50 samples are ignored: the Page-Hinkley change time
    (last zero of a slowly drifting statistic) can come early, and the path
    search then inserts a short wrong segment before the right one (the
    "extra transitions" of 7.3.2)."""
    truth = [("A", 0), ("B", 700), ("C", 1400), ("A", 2100), ("B", 2800)]
    n = 3500
    y = simulate(truth, n, seed)
    obs = Observer(graph(["A", "B", "C"]), ar_models(), sides="both")
    res = observe(obs, y, chunk=512)
    path = merge_short(res.map_path, 50, n)
    assert [k for k, _ in path] == [k for k, _ in truth]
    for (_, s), (_, s_true) in zip(path[1:], truth[1:]):
        assert abs(s - s_true) <= 40
    # per-sample labels along the MAP path agree with the truth almost everywhere
    true_lab = np.zeros(n, dtype=int)
    for (k, s) in truth:
        true_lab[s:] = "ABC".index(k)
    assert np.mean(res.labels == true_lab) > 0.97
    assert np.mean(res.node_prob.argmax(axis=1) == true_lab) > 0.9
    np.testing.assert_allclose(res.node_prob.sum(axis=1), 1.0, rtol=1e-12)


def test_mean_step_with_impact_node():
    """Rest -> impact decay -> contact: the transient impact node is found between the two."""
    rng = np.random.default_rng(7)
    n0, n1, n2 = 400, 60, 400
    rest = rng.normal(-2.0, 0.3, n0)
    t = np.arange(n1)
    impact = 4.0 - 0.08 * t + rng.normal(0, 0.3, n1)
    contact = rng.normal(-1.0, 0.3, n2)
    y = np.concatenate([rest, impact, contact])
    segs = [a - 0.05 * np.arange(80) + rng.normal(0, 0.3, 80)
            for a in rng.normal(4.0, 0.3, 8)]
    imp = ImpactFeature(name="I").fit(segs)
    models = {
        "R": TemporalFeature(name="R", order=1, mean=True, theta_mean=[-2.0, 0.0],
                             theta_sqrt=[0.1, 0.05], noise_var=0.09, structure="plain"),
        "K": TemporalFeature(name="K", order=1, mean=True, theta_mean=[-1.0, 0.0],
                             theta_sqrt=[0.1, 0.05], noise_var=0.09, structure="plain"),
        "I": imp}
    doc = {"name": "imp", "models": {"R": {"kind": "temporal"}, "K": {"kind": "temporal"},
                                     "I": {"kind": "impact"}},
           "nodes": [{"name": "rest", "models": "R", "initial": 1.0},
                     {"name": "impact", "models": "I", "transient": True},
                     {"name": "contact", "models": "K"}],
           "edges": ["rest -> impact", "impact -> contact"]}
    res = observe(Observer(parse_graph(doc), models, sides="both"), y, chunk=100)
    path = merge_short(res.map_path, 10, len(y))
    assert [k for k, _ in path] == ["rest", "impact", "contact"]
    assert abs(path[1][1] - n0) <= 3
    assert abs(path[2][1] - (n0 + n1)) <= 25


def test_impact_prior_fitted_from_segments():
    rng = np.random.default_rng(8)
    mus, slopes = rng.normal(4.0, 0.2, 40), rng.normal(-0.05, 0.005, 40)
    segs = [m + s * np.arange(200) + rng.normal(0, 0.1, 200) for m, s in zip(mus, slopes)]
    imp = ImpactFeature(name="impact").fit(segs)
    assert imp.theta_mean[0, 0] == pytest.approx(4.0, abs=0.1)
    assert imp.theta_mean[0, 1] == pytest.approx(-0.05, abs=0.003)
    cov = imp.theta_sqrt[0] @ imp.theta_sqrt[0].T
    assert np.sqrt(cov[0, 0]) == pytest.approx(0.2, rel=0.35)
    assert imp.noise_var[0] == pytest.approx(0.01, rel=0.1)


def test_chunking_gives_identical_results():
    truth = [("A", 0), ("B", 300), ("C", 650), ("A", 900)]
    y = simulate(truth, 1200, 5)
    g = graph(["A", "B", "C"])
    results = [observe(Observer(g, ar_models(), sides="both"), y, chunk=c) for c in (1, 7, 1200)]
    for r in results[1:]:
        np.testing.assert_array_equal(r.node_prob, results[0].node_prob)
        np.testing.assert_array_equal(r.map_node, results[0].map_node)
        assert r.map_path == results[0].map_path
        assert [e.to_dict() for e in r.events] == [e.to_dict() for e in results[0].events]
    assert len([e for e in results[0].events if e.model]) >= 3


class General(TemporalFeature):
    """An AR model the compiled core does not run (no ``kalman_spec``): the observer's
    general form, model banks advanced through ``run``."""

    def kalman_spec(self, channels):
        return None


def test_models_sharing_a_bank_give_the_results_of_one_bank_each():
    """AR models of one structure run in one bank (batch_key); each model alone in its
    bank (batch_key None) must give the same events, paths and probabilities."""
    class Alone(General):
        def batch_key(self):
            return None

    truth = [("A", 0), ("B", 300), ("C", 650), ("A", 900)]
    y = simulate(truth, 1200, 5)
    g = graph(["A", "B", "C"])
    shared = {k: General(name=k, order=1, mean=True, theta_mean=[mu, a], theta_sqrt=[0.3, 0.05],
                         noise_var=v, structure="plain") for k, (mu, a, v) in PARAMS.items()}
    alone = {k: Alone(name=k, order=1, mean=True, theta_mean=[mu, a], theta_sqrt=[0.3, 0.05],
                      noise_var=v, structure="plain") for k, (mu, a, v) in PARAMS.items()}
    shared_obs, alone_obs = Observer(g, shared), Observer(g, alone)
    shared, single = observe(shared_obs, y, chunk=100), observe(alone_obs, y, chunk=100)
    assert len(shared_obs._banks) == 1 and len(alone_obs._banks) == 3
    np.testing.assert_array_equal(shared.node_prob, single.node_prob)
    assert shared.map_path == single.map_path
    assert [e.to_dict() for e in shared.events] == [e.to_dict() for e in single.events]
    assert sum(len(e.spawned) for e in shared.events) >= 6


@pytest.mark.parametrize("structure,estimate,order_c,channels",
                         [("plain", False, 1, 1), ("track", True, 1, 1), ("fixed", False, 1, 1),
                          ("plain", True, 2, 1), ("fixed", False, 1, 2), ("track", True, 1, 2)])
def test_the_compiled_core_gives_the_general_forms_results(structure, estimate, order_c,
                                                           channels):
    """The compiled core (every filter step, detector, spawn, catch-up and pruning in one
    compiled loop) against the general form (model banks through ``run``) on the same
    stream: the same events, paths and path log-likelihoods to the bit, node probabilities
    to rounding; AR models of each regressor structure, the running noise estimate, impact
    models (time regressors) on a four-node graph, models of different parameter counts
    (an AR(2) among AR(1)s: the core's general step) and of two parameters on one channel
    (its two-pass step) and on two (its two-parameter step per channel)."""
    truth = [("A", 0), ("B", 300), ("C", 650), ("A", 900), ("B", 1300)]
    y = simulate(truth, 1600, 7)
    if channels == 2:
        y = np.c_[y, 0.5 * y + np.random.default_rng(3).normal(scale=0.5, size=len(y))]
    L = np.array([[1.0, 0.0], [0.2, 1.5]])

    def models(cls):
        out = {}
        for k, (mu, a, v) in PARAMS.items():
            p = order_c if k == "C" else 1
            out[k] = cls(name=k, order=p, mean=True, theta_mean=[mu, a] + [0.0] * (p - 1),
                         theta_sqrt=[0.3, 0.05] + [0.05] * (p - 1), noise_var=v,
                         structure=structure, estimate_noise=estimate,
                         structure_sqrt=None if structure == "plain" else L)
        imp = ImpactFeature(name="I", theta_mean=[3.0, -0.01], theta_sqrt=[1.0, 0.01],
                            noise_var=1.0)
        if cls is General:
            class GeneralImpact(ImpactFeature):
                def kalman_spec(self, channels):
                    return None
            imp = GeneralImpact(name="I", theta_mean=[3.0, -0.01], theta_sqrt=[1.0, 0.01],
                                noise_var=1.0)
        out["I"] = imp
        return out

    doc = {"name": "t", "models": {**{k: {"kind": "temporal"} for k in PARAMS},
                                   "I": {"kind": "impact"}},
           "nodes": [{"name": k, "models": k} for k in [*PARAMS, "I"]],
           "edges": ["* -> *"], "initial": "uniform"}
    g = parse_graph(doc)
    core_obs, general_obs = Observer(g, models(TemporalFeature)), Observer(g, models(General))
    fast = observe(core_obs, y, chunk=333)
    slow = observe(general_obs, y, chunk=333)
    assert core_obs._core is not None and general_obs._core is None
    assert len([e for e in slow.events if e.model]) >= 5
    assert_same_observer_results(fast, slow)
    # the event log of the core (records made when read): indexing, slices, plain JSON
    log = core_obs.events_
    assert len(log) == len(slow.events) and log[-1].to_dict() == slow.events[-1].to_dict()
    assert [e.to_dict() for e in log[3:9]] == [e.to_dict() for e in slow.events[3:9]]
    json.dumps([e.to_dict() for e in log])


@pytest.mark.parametrize("p_prune", [0.9, 0.999])
def test_pruning_keeps_mass_and_gap(p_prune):
    truth = [("A", 0), ("B", 300), ("C", 650), ("A", 900), ("B", 1200)]
    y = simulate(truth, 1500, 6)
    res = observe(Observer(graph(["A", "B", "C"]), ar_models(), p_prune=p_prune, gap=20.0,
                           sides="both"), y, chunk=256)
    assert res.events
    for e in res.events:
        ll = e.candidates_loglik
        kept_mass = np.exp(ll[e.kept] - logsumexp(ll)).sum()
        # mass P_prune retained (paths cut by the gap carry at most exp(-20) each)
        assert kept_mass >= p_prune - len(ll) * np.exp(-20.0)
        assert np.all(ll[e.kept] >= ll.max() - 20.0)
        # the kept paths are the most probable ones, and no more than needed
        dropped = np.setdiff1d(np.arange(len(ll)), e.kept)
        assert ll[e.kept].min() >= np.max(ll[dropped], initial=-np.inf)
        if len(e.kept) > 1:
            without_last = np.sort(ll[e.kept])[1:]
            assert np.exp(without_last - logsumexp(ll)).sum() < p_prune


@pytest.mark.parametrize("gap", [35.0, 60.0])
def test_p_prune_one_drops_paths_by_the_gap_alone(gap):
    """P_prune = 1 keeps every path within the gap: a share of exp(-30) of the mass is
    not a reason to drop a path when the gap is wider than 30 nats."""
    from contactlab.observer.events import keep_set

    pll = np.array([0.0, -10.0, -30.0, -50.0, -70.0])
    n = len(pll)
    keep = np.empty(n, np.int64)
    nk = keep_set(pll, np.zeros(n, np.int64), n, 1.0, gap, -1, False, np.empty(n, np.int64),
                  np.empty(n), keep)
    assert keep[:nk].tolist() == [i for i in range(n) if pll[i] >= -gap]
    truth = [("A", 0), ("B", 300), ("C", 650), ("A", 900), ("B", 1200)]
    res = observe(Observer(graph(["A", "B", "C"]), ar_models(), p_prune=1.0, gap=gap,
                           sides="both"), simulate(truth, 1500, 6), chunk=256)
    behind = 0
    for e in res.events:
        ll = e.candidates_loglik
        inside = np.flatnonzero(ll >= ll.max() - gap)
        assert np.array_equal(np.sort(e.kept), inside)
        behind += int(np.sum(ll[e.kept] < ll.max() - 28.0))
    assert behind > 0          # paths a 1e-12 share of the mass would have dropped, kept


def test_action_dependent_edges_gate_transitions():
    """A -> B exists only while 'move' is commanded (9.1.3)."""
    y = simulate([("A", 0), ("B", 500)], 1000, 9)
    extra = {"actions": ["rest", "move"],
             "edge_sets": [{"actions": ["move"], "edges": ["A -> B"]}]}
    g = graph(["A", "B"], edges=(), initial=[1.0, 0.0], extra=extra)
    at_rest = observe(Observer(g, ar_models()), y, action="rest", chunk=100)
    assert {k for k, _ in at_rest.map_path} == {"A"}
    moving = observe(Observer(g, ar_models()), y, action=np.ones(1000, dtype=int), chunk=100)
    path = merge_short(moving.map_path, 20, 1000)
    assert [k for k, _ in path] == ["A", "B"] and abs(path[1][1] - 500) <= 15
    with pytest.raises(ValueError, match="action"):
        Observer(g, ar_models()).update(y[:10])


def test_buffers_stay_bounded_on_a_long_stream():
    """200k samples of a four-node graph: the buffers never grow with the stream."""
    params = {"A": (0.0, 0.5, 1.0), "B": (3.0, 0.5, 1.0), "C": (0.0, 0.5, 6.0),
              "D": (-3.0, 0.3, 2.0)}
    n = 200_000
    truth = [("ABCD"[i % 4], i * 10_000) for i in range(n // 10_000)]
    y = simulate(truth, n, 11, params)
    obs = Observer(graph(list("ABCD")), ar_models(params), sides="both")
    longest = 0
    for a in range(0, n, 2000):
        obs.update(y[a:a + 2000])
        longest = max(longest, obs.buffer_len_, len(obs._hist))
        assert len(obs.paths()) <= 16
    assert longest < 20_000
    assert obs.n_seen_ == n


def test_trained_feature_objects_take_the_graph_model_names():
    """A trained ImpactFeature named by its label ("H3") serves graph model "I" as "I"."""
    from pathlib import Path

    from contactlab.observer import load_graph
    from contactlab.observer.models.composite import _build

    graph = load_graph(Path(__file__).parents[1] / "datasets_spec/graphs/hf-context-free.toml")
    impact = ImpactFeature(name="H3", theta_mean=[0.0, -0.02], theta_sqrt=np.eye(2) * 0.01,
                           noise_var=0.1)
    built = _build(graph.models["I"], {"H3": impact}, graph, "m.h5")
    assert built.name == "I" and built.signal == "hf"
    assert impact.name == "H3"                      # the trained object is not mutated


def test_mean_sd_rescales_the_prior_of_the_first_parameter():
    """with_mean_sd (9.1.1's S model): the prior covariance becomes D P0 D with
    D = diag(mean_sd / sd_0, 1); the path log-likelihood is the Gaussian marginal under it."""
    rng = np.random.default_rng(8)
    n = 120
    y = -4.0 + 0.4 * rng.normal(size=n)
    S0 = np.array([[0.05, 0.0], [0.02, 0.1]])
    model = TemporalFeature(name="A", order=1, mean=True, theta_mean=[-7.0, 0.0],
                            theta_sqrt=S0, noise_var=0.2, structure="plain")
    wide = model.with_mean_sd(2.5)
    D = np.diag([2.5 / np.hypot(*S0[0]), 1.0])
    P0 = D @ S0 @ S0.T @ D
    assert np.sqrt(P0[0, 0]) == pytest.approx(2.5)
    g = graph(["A"], edges=(), self_transition=False)
    Psi = np.c_[np.ones(n - 1), y[:-1]]
    for m, P in ((model, S0 @ S0.T), (wide, P0)):
        obs = Observer(g, {"A": m}, threshold=1e9)
        observe(obs, y, chunk=50)
        oracle = stats.multivariate_normal(Psi @ [-7.0, 0.0],
                                           Psi @ P @ Psi.T + 0.2 * np.eye(n - 1)).logpdf(y[1:])
        assert obs.paths()[0].loglik == pytest.approx(oracle, rel=1e-9)
    # the original is untouched
    assert np.allclose(model.theta_sqrt[0], S0)
    with pytest.raises(ValueError, match="mean_sd"):
        model.with_mean_sd(0.0)


def test_first_orthogonal_parameter_is_the_level():
    """The premise of mean_sd: with the constant regressor first, the first orthogonal
    parameter of an AR(1)-with-mean fit is the block's sample mean (numpy)."""
    from contactlab.estimators.models import ARModel, estimate

    rng = np.random.default_rng(9)
    y = np.zeros(400)
    for t in range(1, 400):
        y[t] = -3.0 + 0.5 * y[t - 1] + rng.normal()
    fit = estimate(ARModel(order=1, mean=True), y[:, None])
    assert fit.orthogonal[0, 0] == pytest.approx(y[1:].mean(), rel=1e-9)


def _held_impact(seed):
    """Rest (A), an impact at 300, then a contact 2 above the level the tight contact model
    C knows: the adaptive decay model I tracks the contact and no test of it fires."""
    P = {"A": (0.0, 0.5, 1.0), "C": (3.0, 0.5, 1.0)}
    y = simulate([("A", 0), ("C", 300)], 1200, seed, params=P)
    y[300:340] += 8 * np.exp(-np.arange(40) / 10)
    y[300:] += 2.0

    def models(temporal, impact):
        out = {k: temporal(name=k, order=1, mean=True, theta_mean=[mu, a], theta_sqrt=[0.01, 0.01],
                           noise_var=v, structure="plain") for k, (mu, a, v) in P.items()}
        out["I"] = impact(name="I", theta_mean=[6.0, -0.05], theta_sqrt=[2.0, 0.05], noise_var=1.0)
        return out

    class GeneralImpact(ImpactFeature):
        def kalman_spec(self, channels):
            return None

    g = parse_graph({"name": "t", "models": {"A": {"kind": "temporal"}, "C": {"kind": "temporal"},
                                             "I": {"kind": "impact"}},
                     "nodes": [{"name": "A", "models": "A", "initial": 1.0},
                               {"name": "C", "models": "C"},
                               {"name": "I", "models": "I", "transient": True}],
                     "edges": ["A -> I", "I -> C", "C -> A", "A -> C"]})
    return y, g, models(TemporalFeature, ImpactFeature), models(General, GeneralImpact)


def _runs(history, node, n):
    """(start, end) of each maximal run of ``node`` along a path history."""
    out, bounds = [], [s for _, s in history[1:]] + [n]
    for (nd, s), e in zip(history, bounds):
        if nd == node:
            if out and out[-1][1] == s:
                out[-1] = (out[-1][0], e)
            else:
                out.append((s, e))
    return out


@pytest.mark.parametrize("seed", [1, 3])
def test_a_transient_node_ends_after_its_longest_duration(seed):
    """6.4 as written keeps an impact node whose decay model tracks the contact after it
    to the end of the run; with ``transient_max`` no path stays in the transient node
    longer, the contact after it is labelled C, and the compiled core and the general
    form give the same results."""
    y, g, fast_models, slow_models = _held_impact(seed)
    n, tm = len(y), 60
    held = observe(Observer(g, fast_models), y)
    assert max(e - s for s, e in _runs(held.map_path, "I", n)) > 500      # the failure mode
    core = Observer(g, fast_models, transient_max=tm)
    fast = observe(core, y, chunk=257)
    slow = observe(Observer(g, slow_models, transient_max=tm), y, chunk=257)
    assert core._core is not None
    assert_same_observer_results(fast, slow)
    assert any(e.model == "I" for e in fast.events)
    # the limit is per segment (a detected change may restart the impact, a second one)
    for p in fast.paths:
        bounds = [s for _, s in p.history[1:]] + [n]
        assert all(e - s <= tm for (nd, s), e in zip(p.history, bounds) if nd == "I")
    assert max(e - s for s, e in _runs(fast.map_path, "I", n)) < 3 * tm
    assert np.all(fast.labels[300 + 3 * tm:] == g.node_names.index("C"))
    with pytest.raises(ValueError, match="transient_max"):
        Observer(g, fast_models, transient_max=0)
    # per node: the same limit given for the node by name is the same observer
    named = observe(Observer(g, fast_models, transient_max={"I": tm}), y, chunk=257)
    assert_same_observer_results(fast, named)
    with pytest.raises(ValueError, match="not a node"):
        Observer(g, fast_models, transient_max={"Q": tm})
