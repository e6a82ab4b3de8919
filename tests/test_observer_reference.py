"""The observer against a plain per-sample implementation of 6.4.

:func:`reference_observe` is the algorithm written the slow, obvious way: one
path object per hypothesis, every model instance advanced one sample at a time
through its :class:`FeatureModel` ``run``, the Page-Hinkley tests (6.18) on each
instance, and at a detected change the successors, their start from the best
tracked predecessor, the catch-up over the buffered samples, the maximisation
over (node, start) and the pruning, each in a loop over Python lists.  The
observer batches instances in banks, runs windows of samples in compiled loops
and keeps paths in arrays; the two must agree on every event, every kept path
and every node probability.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from contactlab import defaults as D
from contactlab.observer import Observer, TemporalFeature, build_models, load_graph, observe
from contactlab.observer.models.composite import node_models

TESTS = ("increase", "up", "down")          # sides="mean" (the default)


class _Path:
    def __init__(self, pid, node, start, init, history, units, t_before):
        self.id, self.node, self.start, self.init = pid, node, start, init
        self.history = history                # [(node, start), ...]
        self.units = units                    # [[model, state, g (S,), last zero (S,)], ...]
        self.ll = init
        self.lls = {t_before: init}           # path log-likelihood after each sample


def _increments(model, C, q, chi2, z):
    """(S,) detector increments of the three tests for one sample (6.14, sides="mean")."""
    m = np.array([float(model.dim(C))])
    q = np.array([q])
    d = np.sqrt(q - 1.0)
    a = np.array([(0.5 * (-m * np.log(q)))[0], -(0.5 * d * d)[0], -(0.5 * -d * -d)[0]])
    b = np.array([(0.5 * (1.0 - 1.0 / q))[0], d[0], -d[0]])
    return a + b * np.array([chi2, z, z])


def reference_observe(graph, models, y, *, threshold=D.OBSERVER_THRESHOLD,
                      q=D.OBSERVER_CHANGE_SIZE, p_prune=D.OBSERVER_PRUNE, gap=D.OBSERVER_GAP):
    """Per-sample node probabilities, the events ``(time, path id, model, change time,
    spawned, merged, candidate log-likelihoods, kept)`` and the final paths.  A graph
    asking for survivors whose edges carry probabilities keeps each node's best path
    through the pruning."""
    survivors = bool(graph.survivors and graph.edge_probabilities)
    # the graph's one action's transition probabilities (6.1: a change costs log p)
    edge_p = next(iter(graph.edge_probabilities.values())) if survivors else {}
    act = 0 if graph.action_dependent else None      # a one-action graph's action

    def log_p(i, j):
        return math.log(edge_p[(i, j)]) if i != j and edge_p.get((i, j)) else 0.0

    def node_best(p, paths):
        """Whether no other path in p's node leads it (the first of equals)."""
        i = paths.index(p)
        return all(o.node != p.node or o.ll < p.ll or (o.ll == p.ll and j > i)
                   for j, o in enumerate(paths) if o is not p)

    y = np.asarray(y, dtype=np.float64)
    n, C = y.shape
    nodes = node_models(graph, models)
    K = graph.n_nodes
    L = max(m.lag for m in models.values())
    next_id = [0]

    def step(unit, t, start):
        model, state = unit[0], unit[1]
        ll, stat = model.run(state, y[t - model.lag:t + 1], t0=t, starts=np.array([start]))
        stat = np.asarray(stat, dtype=np.float64)
        chi2, z = (stat[0, 0], 0.0) if stat.ndim == 2 else (stat[0, 0, 0], stat[0, 0, 1])
        x = _increments(model, C, model.change_size or q, chi2, z)
        for s in range(len(TESTS)):
            v = unit[2][s] + x[s]
            unit[2][s] = v if v > 0.0 else 0.0
            if unit[2][s] == 0.0:
                unit[3][s] = t
        return float(ll[0, 0])

    def new_path(node, start, init, history, t_before):
        units = [[m, m.init_state(np.array([start]), C), [0.0] * len(TESTS),
                  [t_before] * len(TESTS)] for m in nodes[node].models]
        p = _Path(next_id[0], node, start, init, history, units, t_before)
        next_id[0] += 1
        return p

    paths, mass = [], 0.0
    for k in np.argsort(-graph.initial, kind="stable"):
        if graph.initial[k] <= 0:
            break
        paths.append(new_path(int(k), 0, math.log(graph.initial[k]), [(int(k), 0)], L - 1))
        mass += graph.initial[k]
        if mass > p_prune:
            break

    def probabilities():
        ll = np.array([p.ll for p in paths])
        w = np.exp(ll - ll.max())
        w /= w.sum()
        out = np.zeros(K)
        for p, v in zip(paths, w):
            out[p.node] += v
        return out

    probs = np.zeros((n, K))
    probs[:L] = probabilities()
    events = []
    for t in range(L, n):
        crossed = False
        for p in paths:
            for u in p.units:
                p.ll += step(u, t, p.start)
                crossed |= max(u[2]) > threshold
            p.lls[t] = p.ll
        best = max(p.ll for p in paths)
        if crossed or any(p.ll < best - gap and not (survivors and node_best(p, paths))
                          for p in paths):
            alarms = []
            for p in paths:
                for u in p.units:
                    over = [s for s in range(len(TESTS)) if u[2][s] > threshold]
                    if over:
                        for r in sorted({u[3][s] + 1 for s in over}):
                            alarms.append((p, u[0].name, r))
                        u[2] = [0.0] * len(TESTS)
                        u[3] = [t] * len(TESTS)
            spawned, merged, cands = [], [], []
            for p, _, r in alarms:
                for j in graph.successors(p.node, act):
                    if (j, r) in [c[:2] for c in cands]:
                        continue
                    init, prev = -math.inf, None
                    for o in paths:     # the best tracked path into (j, r), started before r
                        if o.start < r and j in graph.successors(o.node, act) \
                                and o.lls[r - 1] + log_p(o.node, j) > init:
                            init, prev = o.lls[r - 1] + log_p(o.node, j), o
                    if prev is not None:
                        cands.append((j, r, init, prev.history))
            for j, r, init, history in cands:
                old = [o for o in paths if (o.node, o.start) == (j, r)]
                if old:
                    o = old[0]
                    if init > o.init:
                        delta = init - o.init
                        o.ll += delta
                        o.lls = {s: v + delta if s >= r - 1 else v for s, v in o.lls.items()}
                        o.init, o.history = init, history + [(j, r)]
                        merged.append((graph.nodes[j].name, r))
                    continue
                p = new_path(j, r, init, history + [(j, r)], r - 1)
                for s in range(r, t + 1):               # catch up on the buffered samples
                    for u in p.units:
                        p.ll += step(u, s, r)
                    p.lls[s] = p.ll
                paths.append(p)
                spawned.append((graph.nodes[j].name, r))
            ll = np.array([p.ll for p in paths])
            order = np.argsort(-ll, kind="stable")
            w = np.exp(ll - ll[order[0]])
            w /= w.sum()
            n_keep = int(np.searchsorted(np.cumsum(w[order]), p_prune * (1 - 1e-12)) + 1)
            keep = [int(i) for i in order[:n_keep] if ll[i] >= ll[order[0]] - gap]
            if survivors:       # the best path of every node the kept ones leave out
                for node in {paths[i].node for i in order} - {paths[i].node for i in keep}:
                    keep.append(int(next(i for i in order if paths[i].node == node)))
            keep.sort()
            for k, (p, model, r) in enumerate(alarms or [(None, None, None)]):
                events.append((t, p.id if p else None, model, r, spawned if k == 0 else [],
                               merged if k == 0 else [], ll, keep))
            paths = [paths[i] for i in keep]
        probs[t] = probabilities()
    final = sorted(((p.id, graph.nodes[p.node].name, p.start, p.ll,
                     [(graph.nodes[j].name, s) for j, s in p.history]) for p in paths),
                   key=lambda x: -x[3])
    return probs, events, final


def _compare(res, ref):
    probs, events, final = ref
    np.testing.assert_allclose(res.node_prob, probs, rtol=0, atol=1e-12)
    assert len(res.events) == len(events)
    for e, (t, pid, model, r, spawned, merged, ll, keep) in zip(res.events, events):
        assert (e.time, e.path, e.model, e.change_time) == (t, pid, model, r)
        assert (e.spawned, e.merged) == (spawned, merged)
        np.testing.assert_allclose(e.candidates_loglik, ll, rtol=0, atol=1e-9)
        assert list(e.kept) == keep
    got = [(p.id, p.node, p.start, p.loglik, p.history) for p in res.paths]
    assert [g[:3] + g[4:] for g in got] == [f[:3] + f[4:] for f in final]
    np.testing.assert_allclose([g[3] for g in got], [f[3] for f in final], rtol=0, atol=1e-9)


@pytest.fixture(scope="module")
def switching(tmp_path_factory):
    from contactlab.observer.training import train_graph
    from contactlab.peers.hmm import labelled_points
    from contactlab.synthetic import write_archive
    from contactlab.synthetic.switching import switching_trials

    d = tmp_path_factory.mktemp("reference")
    write_archive(switching_trials(4, seed=11), d / "train.h5")
    write_archive(switching_trials(1, seed=12), d / "test.h5")
    graph = load_graph("hf-context-free")
    models = build_models(graph, train_graph(d / "train.h5", graph).trained)
    y = labelled_points(d / "test.h5", list(graph.node_names))[0]["y"]
    return graph, models, y


@pytest.mark.parametrize("chunk", [250, 4096])
def test_observer_matches_the_per_sample_reference_on_a_switching_trial(switching, chunk):
    graph, models, y = switching
    res = observe(Observer(graph, models), y, chunk=chunk)
    ref = reference_observe(graph, models, y)
    assert sum(e[2] is not None for e in ref[1]) >= 20          # many detected changes
    _compare(res, ref)


def test_observer_matches_the_reference_with_composite_nodes_and_few_edges():
    """Two-model nodes (path log-likelihoods add, 6.10), edges that forbid some changes,
    four channels."""
    rng = np.random.default_rng(3)
    seg = [(0.0, 1.0, 400), (3.0, 1.0, 300), (0.0, 3.0, 300), (3.0, 3.0, 300)]
    y = np.concatenate([mu + rng.normal(0, sd, (k, 4)) for mu, sd, k in seg])
    spec = {"lo": (0.0, 1.0), "hi": (3.0, 1.0), "quiet": (0.0, 1.0), "loud": (0.0, 9.0)}
    models = {k: TemporalFeature(name=k, order=1, mean=True, theta_mean=[mu, 0.0],
                                 theta_sqrt=[0.2, 0.05], noise_var=v, structure="plain")
              for k, (mu, v) in spec.items()}
    from contactlab.observer import parse_graph
    doc = {"name": "composite", "models": {k: {"kind": "temporal"} for k in spec},
           "nodes": [{"name": "A", "models": ["lo", "quiet"], "initial": 1.0},
                     {"name": "B", "models": ["hi", "quiet"]},
                     {"name": "C", "models": ["lo", "loud"]},
                     {"name": "D", "models": ["hi", "loud"]}],
           "edges": ["A -> B", "B -> C", "C -> D", "B -> A"]}
    graph = parse_graph(doc)
    res = observe(Observer(graph, models), y, chunk=100)
    ref = reference_observe(graph, models, y)
    assert sum(e[2] is not None for e in ref[1]) >= 3
    _compare(res, ref)


def test_observer_matches_the_reference_keeping_each_nodes_best_path():
    """A graph asking for survivors, whose edges carry probabilities, keeps the best path
    of every node through the pruning (Viterbi's survivors): the core and the reference
    agree, and some event keeps a path more than the gap below the best."""
    rng = np.random.default_rng(5)
    seg = [(0.0, 1.0, 300), (3.0, 1.0, 200), (1.5, 1.0, 250), (3.0, 1.0, 300)]
    y = np.concatenate([mu + rng.normal(0, sd, (k, 1)) for mu, sd, k in seg])
    spec = {"lo": 0.0, "hi": 3.0, "mid": 1.5}
    models = {k: TemporalFeature(name=k, order=1, mean=True, theta_mean=[mu, 0.0],
                                 theta_sqrt=[0.2, 0.05], noise_var=1.0, structure="plain")
              for k, mu in spec.items()}
    from contactlab.observer import parse_graph
    doc = {"name": "chain", "models": {k: {"kind": "temporal"} for k in spec},
           "actions": ["task"], "survivors": True,
           "nodes": [{"name": "A", "models": "lo", "initial": 1.0},
                     {"name": "B", "models": "hi"}, {"name": "C", "models": "mid"}],
           "edge_sets": [{"actions": ["task"], "edges": ["A -> B", "B -> C", "C -> B"],
                          "probabilities": [0.004, 0.004, 0.004]}]}
    graph = parse_graph(doc)
    obs = Observer(graph, models)
    assert obs.survivors
    res = observe(obs, y, chunk=128, action="task")
    ref = reference_observe(graph, models, y)
    _compare(res, ref)
    gap = obs.gap
    assert any(np.min(np.asarray(ll)[list(keep)]) < np.max(ll) - gap
               for *_, ll, keep in ref[1] if len(ll))
