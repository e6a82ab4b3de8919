"""EM over unlabelled runs (10.1.3): edges a graph lacks come back, through the library and
`contactlab train --em`.  Oracle: the transitions the synthetic truth makes."""

from collections import Counter

import numpy as np
import pytest
import tomllib
from click.testing import CliRunner

from contactlab.cli import main
from contactlab.observer.graph import bundled_graphs, load_graph, parse_graph
from contactlab.observer.graph_toml import write_graph
from contactlab.observer.learning import learn_graph, node_logliks
from contactlab.observer.recognize import bind_models
from contactlab.observer.training import train_graph
from contactlab.synthetic import write_archive
from contactlab.synthetic.switching import switching_trials

CUT = ["H0 -> H1, H3", "H1 -> H0, H2, H3", "H2 -> H1, H3", "H3 -> H0, H1, H2"]


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("em")
    trials = switching_trials(4, seed=1)
    path = tmp / "sw.h5"
    write_archive(trials, path)
    doc = tomllib.loads(bundled_graphs()["hf-context-free"].read_text())
    doc["edges"] = CUT                     # H0 <-> H2 removed
    graph = write_graph(doc, tmp / "cut.toml")
    return tmp, trials, path, graph


def _truth_transitions(trials) -> Counter:
    c = Counter()
    for t in trials:
        for i in np.flatnonzero(np.diff(t.codes)) + 1:
            c[(t.names[t.codes[i - 1]], t.names[t.codes[i]])] += 1
    return c


def test_em_recovers_the_removed_edges_and_nothing_else(runs):
    _, trials, path, graph_file = runs
    graph = load_graph(graph_file)
    graph, gm, built = bind_models(graph, train_graph(path, graph))
    doc, summary = learn_graph(path, graph, built, reduce=gm.reduce)
    truth = _truth_transitions(trials)
    added = {tuple(e["edge"].split(" -> ")): e for e in summary["added"]}
    assert set(added) == {("H0", "H2"), ("H2", "H0")}
    for pair, e in added.items():             # about as many as the truth makes
        assert 0.5 * truth[pair] <= e["expected_transitions"] <= 2.5 * truth[pair]
    learned = parse_graph(doc)
    names = list(learned.node_names)
    assert (names.index("H0"), names.index("H2")) in learned.edges
    assert np.all(np.diff(summary["loglik"]) > -1e-6 * np.abs(summary["loglik"][1:]))


def test_node_logliks_favour_the_true_node(runs):
    _, trials, path, graph_file = runs
    graph = load_graph(graph_file)
    graph, gm, built = bind_models(graph, train_graph(path, graph))
    from contactlab.archive import open_archive
    from contactlab.signals import trial_signals, truth_codes

    with open_archive(path) as arch:
        trial = arch.trial(arch.select()[0])
        ll, act, fs = node_logliks(trial, graph, built, reduce=gm.reduce)
        _, index, _ = trial_signals(trial, ["hf"], reduce=gm.reduce)
        truth = truth_codes(trial, index, list(graph.node_names))
    assert ll.shape == (len(index), graph.n_nodes) and act is None and fs == 250.0
    # per 0.1-s block, the summed log-likelihood picks the true state in most blocks
    blocks = [(b, b + 25) for b in range(25, len(truth) - 25, 25)
              if (truth[b:b + 25] == truth[b]).all() and truth[b] in (0, 1, 2)]
    hits = [np.argmax(ll[a:b].sum(axis=0)) == truth[a] for a, b in blocks]
    assert np.mean(hits) > 0.8


def test_train_em_cli_writes_a_graph_recognize_reads(runs):
    tmp, _, path, graph_file = runs
    r = CliRunner().invoke(main, ["train", str(path), "--graph", str(graph_file), "--em",
                                  "--out", str(tmp / "m.h5"), "--json", "-q"])
    assert r.exit_code == 0, r.output
    import json

    em = json.loads(r.stdout)["em"]
    assert {e["edge"] for e in em["added"]} == {"H0 -> H2", "H2 -> H0"}
    learned = tmp / "m.toml"
    assert em["graph_out"] == str(learned) and learned.exists()
    r = CliRunner().invoke(main, ["recognize", str(path), "--graph", str(learned), "--models",
                                  str(tmp / "m.h5"), "--no-write", "--json", "-q"])
    assert r.exit_code == 0, r.output
    assert json.loads(r.stdout)["accuracy"] > 0.9
    # the learned graph is not overwritten without --force
    r = CliRunner().invoke(main, ["train", str(path), "--graph", str(graph_file), "--em",
                                  "--out", str(tmp / "m2.h5"), "--graph-out", str(learned)])
    assert r.exit_code != 0 and "m.toml" in r.stderr and len(r.stderr.strip().splitlines()) == 1


@pytest.mark.parametrize("args, fragment", [
    (["--em"], "--em needs --graph"),
    (["--graph", "hf-context-free", "--graph-out", "g.toml"], "--graph-out needs --em"),
])
def test_train_em_usage_errors(runs, args, fragment):
    tmp, _, path, _ = runs
    r = CliRunner().invoke(main, ["train", str(path), "--out", str(tmp / "u.h5"), *args])
    assert r.exit_code == 2 and fragment in r.stderr
    assert len(r.stderr.strip().splitlines()) == 1
