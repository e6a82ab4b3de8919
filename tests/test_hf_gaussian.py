"""The Gaussian hf hypotheses (graph hf-gaussian) and the HMM peer's point accuracy.

Oracles: the trained Gaussians' means and variances against numpy over the labelled
conditioned points; the observer with fixed Gaussian levels against the thesis's
prior-estimated models and the HMM peer on switching runs whose states have fixed levels
and on runs whose levels are drawn anew per segment."""

from __future__ import annotations

import numpy as np
import pytest

from contactlab.archive import open_archive
from contactlab.observer import load_graph, recognize_archive, train_graph
from contactlab.peers.hmm import main as hmm_main
from contactlab.peers.hmm import point_accuracy
from contactlab.signals import trial_signals, truth_codes, window_of
from contactlab.synthetic import write_archive
from contactlab.synthetic.switching import switching_trials

STATES = ["H0", "H1", "H2", "H3"]


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    d = tmp_path_factory.mktemp("hfg")
    write_archive(switching_trials(6, seed=21, fresh=True), d / "train.h5")
    write_archive(switching_trials(3, seed=22, fresh=True), d / "test.h5")
    return d / "train.h5", d / "test.h5"


def test_gaussian_hypotheses_are_the_labelled_levels_of_y_h(runs):
    train, _ = runs
    graph = load_graph("hf-gaussian")
    models = train_graph(train, graph)
    gauss = models.kinematic["gaussian"]
    assert set(gauss) == {"H0", "H1", "H2"} and set(models.impacts) == {"H3"}
    pts = {k: [] for k in gauss}
    with open_archive(train) as arc:
        for trial in arc:
            data, index, _ = trial_signals(trial, ["hf"], reduce=models.reduce)
            codes = truth_codes(trial, index, STATES, window=window_of("hf", trial.rate_hz))
            for k, lab in enumerate(STATES[:3]):
                pts[lab].append(data["hf"][codes == k, 0])
    for lab, m in gauss.items():
        x = np.concatenate(pts[lab])
        assert m.mean[0] == pytest.approx(x.mean(), rel=1e-9)
        assert m.cov[0, 0] == pytest.approx(x.var(ddof=1) * (1 + 1e-3), rel=1e-6)   # + ridge
    levels = sorted(float(m.mean[0]) for m in gauss.values())
    assert levels[1] - levels[0] > 0.1          # the hypotheses differ in level


@pytest.fixture(scope="module")
def fixed_runs(tmp_path_factory):
    d = tmp_path_factory.mktemp("hfg-fixed")
    write_archive(switching_trials(6, seed=23), d / "train.h5")
    write_archive(switching_trials(3, seed=24), d / "test.h5")
    return d / "train.h5", d / "test.h5"


def _accuracy(name, train, test):
    models = train_graph(train, load_graph(name))
    return recognize_archive(test, graph=load_graph(name), models=models,
                             write=False)["accuracy"]


def test_fixed_levels_where_the_states_have_them_estimated_ones_where_they_vary(runs,
                                                                              fixed_runs):
    """Each state's level fixed (the fixed switching suite): the Gaussians recognise as
    the HMM does.  Levels drawn anew per segment (the fresh suite): the thesis's models,
    which estimate each segment's parameters from a trained prior, stay ahead."""
    train, test = fixed_runs
    gauss, peer = _accuracy("hf-gaussian", train, test), point_accuracy(train, test, STATES)
    assert gauss > 0.9 and peer > 0.9
    train, test = runs
    assert _accuracy("hf-context-free", train, test) > _accuracy("hf-gaussian", train, test)


def test_the_peer_module_prints_its_accuracy(fixed_runs, capsys):
    train, test = fixed_runs
    peer = point_accuracy(train, test, STATES)
    assert hmm_main([str(train), str(test)]) == 0
    out = capsys.readouterr().out
    assert f"{100 * peer:.1f} % of the labelled points" in out
    assert hmm_main([str(train)]) == 2 and hmm_main([str(train), "nope.h5"]) == 1
    assert "nope.h5: no such file" in capsys.readouterr().err


def test_recognize_holds_a_transient_node_at_most_its_longest_labelled_run(fixed_runs):
    """``train`` records each transient node's longest labelled run (the oracle: the runs
    of its label counted with numpy); ``recognize`` holds the node no longer by default,
    0.5 s where training had none, and ``--transient-max`` overrides it."""
    from contactlab.defaults import OBSERVER_TRANSIENT_MAX_S
    from contactlab.observer.recognize import RecognizeStage, transient_limits

    train, test = fixed_runs
    graph = load_graph("hf-gaussian")
    models = train_graph(train, graph)
    longest = 0.0
    with open_archive(train) as arc:
        for trial in arc:
            k = list(trial.label_names).index("H3")
            x = np.r_[0, (np.asarray(trial.labels) == k).astype(int), 0]
            starts, ends = np.flatnonzero(np.diff(x) == 1), np.flatnonzero(np.diff(x) == -1)
            if len(starts):
                longest = max(longest, (ends - starts).max() / trial.rate_hz)
    assert models.provenance["transient_longest_s"] == {"H3": pytest.approx(longest)}
    assert 0 < longest < OBSERVER_TRANSIENT_MAX_S
    assert transient_limits(graph, models) == {"H3": pytest.approx(longest)}
    models.provenance.pop("transient_longest_s")            # a models file without it
    assert transient_limits(graph, models) == {"H3": OBSERVER_TRANSIENT_MAX_S}
    models = train_graph(train, graph)
    out = recognize_archive(test, graph=graph, models=models, write=False, keep=True)
    fs = out["_runs"][0].fs
    for rec in out["_runs"]:
        n = len(rec.result.labels)
        bounds = [s for _, s in rec.result.map_path[1:]] + [n]
        held = [b - a for (nd, a), b in zip(rec.result.map_path, bounds) if nd == "H3"]
        assert all(h <= round(longest * fs) for h in held)
    stage = RecognizeStage(graph=graph, models=models, transient_max_s=0.3)
    assert stage.observer_kw["transient_max_s"] == 0.3
    assert RecognizeStage(graph=graph, models=models,
                          transient_max_s=0).observer_kw["transient_max_s"] is None
