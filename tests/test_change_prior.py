"""The trained change prior: a change out of a node of a graph without transition
probabilities costs log(h_i / R_i), h_i learned from the training labels."""

from __future__ import annotations

import numpy as np
import pytest

from contactlab.observer import Observer, observe, parse_graph
from contactlab.observer.graph import load_graph
from contactlab.observer.models import TemporalFeature
from contactlab.observer.recognize import change_priors, observer_keywords
from contactlab.observer.training import _dwell_in


def _models(means, var=1.0):
    return {k: TemporalFeature(name=k, order=1, mean=True, theta_mean=[mu, 0.0],
                               theta_sqrt=[0.05, 0.02], noise_var=var, structure="plain")
            for k, mu in means.items()}


def test_dwell_counts_labelled_time_and_changes_between_nodes():
    names = ["a", "b", "other"]
    # a a a b b | unlabelled | b other a a : the gap and "other" are skipped, so the
    # changes seen are a->b and b->a
    codes = np.array([0, 0, 0, 1, 1, -1, 1, 2, 0, 0])
    dwell, first = {}, {}
    nodes = {"a": ["a"], "b": ["b"], "c": ["c"]}
    _dwell_in(codes, names, 10.0, nodes, dwell, first)
    assert dwell == {"a": [0.5, 1], "b": [0.3, 1]}
    _dwell_in(np.array([-1, 2, 1, 1, 1, 1]), names, 10.0, nodes, dwell, first)
    assert dwell == {"a": [0.5, 1], "b": [0.7, 1]}
    assert first == {"a": 1, "b": 1}
    # a node renamed from its models' label is counted under that label; a node's own
    # name wins over another node's models' label
    dwell, first = {}, {}
    _dwell_in(codes, names, 10.0, {"rest": ["rest", "a"], "b": ["b"], "x": ["x", "b"]},
              dwell, first)
    assert dwell == {"rest": [0.5, 1], "b": [0.3, 1]}


def test_node_labels_follow_the_names_then_the_models():
    from contactlab.observer.training import node_labels

    assert node_labels(load_graph("free-contact")) == {
        "free": ["free"], "contact": ["contact"], "impact": ["impact"]}
    assert node_labels(load_graph("hf-gaussian"))["H3"] == ["H3"]


def test_trained_initial_probabilities_count_the_first_labelled_node():
    from types import SimpleNamespace

    from contactlab.observer.recognize import trained_initial

    doc = {"name": "g", "models": {"m": {"kind": "temporal"}}, "initial": "trained",
           "nodes": [{"name": n, "models": "m"} for n in "ABC"], "edges": ["* -> *"]}
    graph = parse_graph(doc)
    assert graph.initial_trained and np.allclose(graph.initial, 1 / 3)
    models = SimpleNamespace(provenance={"node_first": {"A": 6, "C": 1}})
    assert trained_initial(graph, models) == pytest.approx({"A": 0.7, "B": 0.1, "C": 0.2})
    assert trained_initial(graph, SimpleNamespace(provenance={})) is None
    doc["initial"] = "uniform"
    assert trained_initial(parse_graph(doc), models) is None
    # written back out, the graph still asks for it
    import tomllib

    from contactlab.observer.graph_toml import dumps_graph, graph_document
    again = parse_graph(tomllib.loads(dumps_graph(graph_document(graph))))
    assert again.initial_trained and np.allclose(again.initial, 1 / 3)


def test_change_priors_are_the_rule_of_succession_at_the_observers_rate():
    p = change_priors({"a": [2.0, 3], "b": [0.5, 0]}, fs=100.0)
    assert p == pytest.approx({"a": 4 / 202, "b": 1 / 52})
    assert change_priors(None, 100.0) is None
    kw = observer_keywords({"node_dwell": {"a": [2.0, 3]}, "transient_max_s": 0.1}, 50.0)
    assert kw["change_prior"] == pytest.approx({"a": 4 / 102})
    assert kw["transient_max"] == 5


def test_prior_equals_the_same_probabilities_written_on_the_edges():
    """The prior is the graph's edges with probabilities h_i / R_i: both observers make
    the same events, paths and path log-likelihoods."""
    means = {"lo": 0.0, "hi": 2.0, "mid": 1.0}
    rng = np.random.default_rng(7)
    y = np.concatenate([means[k] + rng.normal(0, 1.0, (250, 1))
                        for k in ("lo", "hi", "mid", "lo", "hi")])
    h = {"A": 0.004, "B": 0.01, "C": 0.002}
    nodes = [{"name": "A", "models": "lo", "initial": 1.0}, {"name": "B", "models": "hi"},
             {"name": "C", "models": "mid"}]
    edges = ["A -> B, C", "B -> C", "C -> A"]
    plain = parse_graph({"name": "g", "models": {k: {"kind": "temporal"} for k in means},
                         "nodes": nodes, "edges": edges})
    written = parse_graph({"name": "g", "models": {k: {"kind": "temporal"} for k in means},
                           "nodes": nodes, "actions": ["task"],
                           "edge_sets": [{"actions": ["task"],
                                          "edges": ["A -> B", "A -> C", "B -> C", "C -> A"],
                                          "probabilities": [h["A"] / 2, h["A"] / 2, h["B"],
                                                            h["C"]]}]})
    models = _models(means)
    a = observe(Observer(plain, models, change_prior=h), y, chunk=200)
    b = observe(Observer(written, models), y, chunk=200, action="task")
    free = observe(Observer(plain, models), y, chunk=200)
    assert [(e.time, e.change_time) for e in a.events] == [(e.time, e.change_time)
                                                         for e in b.events]
    assert a.map_path == b.map_path
    np.testing.assert_allclose(a.node_prob, b.node_prob, rtol=0, atol=1e-12)
    np.testing.assert_allclose([p.loglik for p in a.paths], [p.loglik for p in b.paths],
                               rtol=0, atol=1e-9)
    # and the prior did something: without it the log-likelihoods differ
    assert not np.allclose(sorted(p.loglik for p in a.paths)[-1],
                           sorted(p.loglik for p in free.paths)[-1])


def test_train_records_each_nodes_labelled_time_and_changes(tmp_path):
    """``train`` stores what the prior is made of; counted here from the archive's labels
    with numpy."""
    from contactlab.archive import open_archive
    from contactlab.observer.training import train_graph
    from contactlab.synthetic import write_archive
    from contactlab.synthetic.switching import switching_trials

    write_archive(switching_trials(2, seed=5), tmp_path / "train.h5")
    gm = train_graph(tmp_path / "train.h5", "hf-gaussian")
    dwell = gm.provenance["node_dwell"]
    secs, outs = {}, {}
    with open_archive(tmp_path / "train.h5") as a:
        for trial in a:
            names = list(trial.label_names)
            lab = np.asarray(trial.labels)
            lab = lab[lab >= 0]
            for k, name in enumerate(names):
                secs[name] = secs.get(name, 0.0) + np.sum(lab == k) / trial.rate_hz
                outs[name] = outs.get(name, 0) + int(np.sum((lab[:-1] == k) & (lab[1:] != k)))
    assert set(dwell) == {n for n in secs if secs[n] > 0}
    for n, (s, c) in dwell.items():
        assert s == pytest.approx(secs[n]) and c == outs[n]
    assert sum(c for _, c in dwell.values()) >= 10
    # the CLI says so for a graph that prices changes, and not for the thesis's
    from click.testing import CliRunner

    from contactlab.cli import main
    for graph, shown in (("hf-gaussian", True), ("hf-context-free", False)):
        r = CliRunner().invoke(main, ["train", str(tmp_path / "train.h5"), "--graph", graph,
                                      "--out", str(tmp_path / f"{graph}.h5"), "-q"])
        assert r.exit_code == 0, r.output
        assert ("changes priced from the labels" in r.output) == shown


@pytest.mark.parametrize("name", ["hf-context-free", "hf-context", "guarded-move", "maze"])
def test_the_thesis_graphs_leave_changes_free(name):
    graph = load_graph(name)
    assert graph.change_prior == "none"
    assert graph.to_dict()["change_prior"] == "none"


def test_graph_file_names_the_bad_change_prior():
    from contactlab.errors import DataError

    doc = {"name": "g", "models": {"m": {"kind": "temporal"}},
           "nodes": [{"name": "A", "models": "m", "initial": 1.0}], "change_prior": "learned"}
    with pytest.raises(DataError, match="change_prior"):
        parse_graph(doc)


def test_observer_rejects_a_prior_for_an_unknown_node():
    graph = parse_graph({"name": "g", "models": {"m": {"kind": "temporal"}},
                         "nodes": [{"name": "A", "models": "m", "initial": 1.0}]})
    with pytest.raises(ValueError, match="not a node"):
        Observer(graph, _models({"m": 0.0}), change_prior={"Z": 0.1})
    with pytest.raises(ValueError, match="probability"):
        Observer(graph, _models({"m": 0.0}), change_prior={"A": 1.5})


def test_a_graph_saying_none_ignores_the_prior():
    graph = parse_graph({"name": "g", "models": {"m": {"kind": "temporal"}},
                         "change_prior": "none",
                         "nodes": [{"name": "A", "models": "m", "initial": 1.0},
                                   {"name": "B", "models": "m"}], "edges": ["A -> B"]})
    obs = Observer(graph, _models({"m": 0.0}), change_prior={"A": 0.1})
    assert obs.change_prior == {}
    assert obs._log_transition(0, 1, None) == 0.0


def test_recognizing_with_models_that_counted_nothing_says_so():
    from types import SimpleNamespace

    from contactlab.observer.recognize import untrained_priors_note

    graph = load_graph("hf-gaussian")
    old = SimpleNamespace(provenance={"trials": ["a"]}, source="old.h5")
    (note,) = untrained_priors_note(graph, old)
    assert note.startswith("old.h5: graph 'hf-gaussian'") and "trained before" in note
    assert "changes are free" in note and "start is uniform" in note
    counted = SimpleNamespace(provenance={"node_dwell": {"H0": [1.0, 2]},
                                          "node_first": {"H0": 3}}, source="new.h5")
    assert untrained_priors_note(graph, counted) == []
    assert untrained_priors_note(load_graph("hf-context-free"), old) == []
