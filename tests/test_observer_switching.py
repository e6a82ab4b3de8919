"""The observer on switching data we did not simulate (contactlab.synthetic.switching),
beside the supervised HMM peer; the switching generator holds the truth it claims."""

from __future__ import annotations

import numpy as np
import pytest

from contactlab.metrics import confusion_matrix
from contactlab.observer import Observer, TemporalFeature, load_graph, observe, parse_graph
from contactlab.observer.recognize import recognize_archive
from contactlab.observer.training import train_graph
from contactlab.peers.hmm import fit_hmm, labelled_points
from contactlab.signals import condition_array
from contactlab.synthetic import write_archive
from contactlab.synthetic.switching import (FRESH_RANGE, IMPACT_S, LEVELS, STEP,
                                            switching_trial, switching_trials)


def _runs(codes):
    edges = np.r_[0, np.flatnonzero(np.diff(codes)) + 1, len(codes)]
    return [(int(codes[a]), a, b) for a, b in zip(edges[:-1], edges[1:])]


def test_switching_states_levels_and_impacts_as_claimed():
    t = switching_trial(seed=3, duration_s=30.0)
    assert np.allclose(t.y / STEP, np.round(t.y / STEP))            # quantised
    hf = condition_array(t.y, "hf", fs=t.fs)
    idx = np.minimum(hf.index, len(t.codes) - 1)
    lab = t.codes[idx]
    y = hf.y.mean(axis=1)
    level = {k: y[lab == k].mean() for k in range(3)}
    assert level[0] < level[1] < level[2]                            # LEVELS 0 < 4 < 12
    impacts = [(a, b) for k, a, b in _runs(t.codes) if k == 3]
    assert impacts
    for a, b in impacts:
        assert IMPACT_S[0] * t.fs - 1 <= b - a <= IMPACT_S[1] * t.fs + 1
        # log energy falls linearly: a line explains most of y_h's variance in the burst
        k = np.flatnonzero((hf.index - 8 >= a) & (hf.index < b))
        if len(k) > 12:
            fit = np.polyfit(k, y[k], 1)
            resid = y[k] - np.polyval(fit, k)
            assert fit[0] < 0 and resid.var() < 0.3 * y[k].var()
    assert LEVELS["H1"] < LEVELS["H2"]


def test_fresh_variant_draws_levels_per_segment():
    t = switching_trial(seed=4, duration_s=40.0, fresh=True, impact_p=0.0)
    sd = [t.y[a + 50:b].std() for k, a, b in _runs(t.codes) if k == 2 and b - a > 300]
    assert len(sd) >= 3
    assert max(sd) / min(sd) > 1.5                                  # not one fixed level
    assert max(sd) < 1.5 * FRESH_RANGE[1]


@pytest.fixture(scope="module")
def suite(tmp_path_factory):
    d = tmp_path_factory.mktemp("switching")
    out = {}
    for fresh in (False, True):
        name = "fresh" if fresh else "fixed"
        train, test = d / f"{name}-train.h5", d / f"{name}-test.h5"
        write_archive(switching_trials(6, seed=11, fresh=fresh), train)
        write_archive(switching_trials(4, seed=12, fresh=fresh), test)
        graph = load_graph("hf-context-free")
        gm = train_graph(train, graph)                    # defaults, as `train --graph`
        ours = recognize_archive(test, graph=graph, models=gm, write=False, keep=True)
        states = list(graph.node_names)
        hmm = fit_hmm(labelled_points(train, states), len(states))
        total = np.zeros((4, 4), np.int64)
        for p in labelled_points(test, states):
            total += confusion_matrix(p["truth"], hmm.decode(p["y"])[1], 4)[0]
        out[name] = (ours, float(np.trace(total) / total.sum()))
    return out


def test_observer_with_defaults_matches_the_supervised_hmm_on_fixed_parameters(suite):
    ours, hmm = suite["fixed"]
    assert hmm > 0.9                                                # the peer is near perfect
    assert ours["accuracy"] >= hmm - 0.02
    assert ours["delays"]["missed"] <= 0.1 * ours["delays"]["transitions"]


def test_observer_beats_the_hmm_when_parameters_are_drawn_per_segment(suite):
    ours, hmm = suite["fresh"]
    assert ours["accuracy"] > hmm + 0.05


def test_impact_nodes_end(suite):
    """No MAP-path stay in the transient node outlasts the longest impact by much."""
    longest = IMPACT_S[1] * 250 + 10                              # conditioned samples
    for name in ("fixed", "fresh"):
        for rec in suite[name][0]["_runs"]:
            stays = [b - a for k, a, b in _runs(rec.result.labels) if k == 3]
            assert max(stays, default=0) <= longest


def _ab():
    """Two nodes A (level 0) and B (level 1.5) of AR(1)-with-a-mean models, A <-> B."""
    models = {k: TemporalFeature(name=k, order=1, mean=True, theta_mean=[mu, 0.0],
                                 theta_sqrt=[0.05, 0.01], noise_var=1.0, structure="plain")
              for k, mu in (("A", 0.0), ("B", 1.5))}
    g = parse_graph({"name": "ab", "models": {k: {"kind": "temporal"} for k in "AB"},
                     "nodes": [{"name": "A", "models": "A", "initial": 1.0},
                               {"name": "B", "models": "B", "initial": 0.0}],
                     "edges": ["A -> B", "B -> A"]})
    return g, models


def test_a_change_missed_at_first_is_recovered():
    """A beam of one path drops the new path at the first alarm (it has less evidence
    yet); the old path's detector is reset and must fire again, so the path still
    reaches the new node."""
    rng = np.random.default_rng(5)
    n0, n1 = 300, 600
    y = np.r_[rng.normal(0.0, 1.0, n0), rng.normal(1.5, 1.0, n1)]
    g, models = _ab()
    res = observe(Observer(g, models, max_paths=1), y)
    assert res.map_path[-1][0] == "B"
    assert n0 - 5 <= [s for node, s in res.map_path if node == "B"][0] <= n0 + 60
    assert np.mean(res.labels[n0 + 60:] == 1) == 1.0


def test_the_beam_keeps_at_most_max_paths_the_most_probable_first():
    """With a hair-trigger detector and neither mass nor gap pruning every alarm adds paths;
    the beam width bounds how many an event keeps, and it keeps the most probable ones
    (a cap wider than the beam ever gets changes nothing)."""
    from contactlab.defaults import OBSERVER_MAX_PATHS

    rng = np.random.default_rng(7)
    y = np.r_[rng.normal(0.0, 1.0, 400), rng.normal(1.5, 1.0, 400), rng.normal(0, 1, 400)]
    g, models = _ab()
    kw = dict(threshold=0.5, p_prune=1.0, gap=np.inf)
    assert Observer(g, models).max_paths == OBSERVER_MAX_PATHS
    free = observe(Observer(g, models, max_paths=None, **kw), y)
    widest = max(len(e.kept) for e in free.events)
    assert widest > 12
    capped = observe(Observer(g, models, max_paths=12, **kw), y)
    assert max(len(e.kept) for e in capped.events) == 12
    assert capped.map_path[-1][0] == "A" and any(n == "B" for n, _ in capped.map_path)
    wide = observe(Observer(g, models, max_paths=widest, **kw), y)
    assert wide.map_path == free.map_path
    np.testing.assert_array_equal(wide.labels, free.labels)
