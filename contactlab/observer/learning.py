"""Learning a feature graph's missing edges from unlabelled runs with EM (10.1.3).

"Given an initial guess at the appropriate features, maximum likelihood in the form of the
Expectation Modification (EM) algorithm could be used to refine the graph over multiple
trials" (10.1.3).  :func:`learn_graph` does it for an archive: the node models are the
trained ones (``contactlab train --graph``); each run's per-sample node log-likelihoods
(:func:`node_logliks`) are the emissions of a hidden Markov chain over the graph's nodes
(:func:`contactlab.observer.em.graph_chain`: the graph's edges, every absent edge a
candidate with a small probability); Baum-Welch (:func:`contactlab.observer.em.baum_welch`)
re-estimates the transitions, and an absent edge with at least one expected transition's
worth of evidence is added (:func:`contactlab.observer.em.learned_edges`).  The runs need
no labels.

Emissions (our choice: the thesis does not say how its observer's likelihoods would feed
EM).  The observer scores a node by the predictive log-likelihood of its models' estimator
instances, started where the path entered the node (6.10).  For a per-sample chain each
node's models are restarted every ``block`` samples (0.1 s at the conditioned 250 Hz: the
thesis's decision block, 8.2) from their trained priors, so a sample's emission is the
node's predictive log-likelihood given at most the block before it -- local, as a chain's
emission must be, and still the estimator's own likelihood rather than a fixed density.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

import numpy as np

from contactlab.observer.em import baum_welch, graph_chain, learned_edges
from contactlab.observer.graph import FeatureGraph
from contactlab.observer.graph_toml import graph_document
from contactlab.observer.models.base import FeatureModel, ModelBank
from contactlab.observer.observer import Observer
from contactlab.signals import trial_signals

__all__ = ["BLOCK", "MEAN_DWELL_S", "node_logliks", "learn_graph"]

#: samples per emission block at the conditioned rate (0.1 s at 250 Hz, 8.2's block)
BLOCK = 25
#: the chain's initial mean dwell in a node, seconds (EM learns each node's own)
MEAN_DWELL_S = 1.0


def node_logliks(trial, graph: FeatureGraph, models: Mapping[str, FeatureModel], *,
                 reduce: str = "none", block: int = BLOCK, path=None):
    """``(loglik (T, K), actions (T,) or None, fs)``: every node's per-sample log-likelihood
    of ``trial`` (its models' predictive log-likelihoods summed, each model restarted
    from its prior every ``block`` samples; the first samples its models' lag needs
    are 0 for every node), and the trial's action codes."""
    from contactlab.observer.recognize import trial_actions

    if block < 1:
        raise ValueError(f"block must be >= 1; got {block}")
    obs = Observer(graph, models, rate_hz=float(trial.rate_hz))   # samples weighed as in recognize
    data, index, fs = trial_signals(trial, obs.signals, reduce=reduce, path=path)
    n = len(index)
    per_model = {}
    for name, model in obs.models.items():
        x = np.asarray(data[model.signal], dtype=np.float64)
        x = x[:, None] if x.ndim == 1 else x
        bank = ModelBank(model, x.shape[1])
        ll = np.zeros(n)
        for b in range(obs.lag, n, block):
            e = min(b + block, n)
            starts, state = bank.new([b])
            got, _ = bank.run(x[b - model.lag:e], t0=b, starts=starts, state=state)
            ll[b:e] = np.asarray(got)[:, 0]
        per_model[name] = ll
    out = np.zeros((n, graph.n_nodes))
    for j, node in enumerate(obs.nodes):
        for m in node.models:
            out[:, j] += per_model[m.name]
    return out, trial_actions(trial, graph, index, path=path), fs


def learn_graph(archive, graph: FeatureGraph, models: Mapping[str, FeatureModel], *,
                reduce: str = "none", trials=None, block: int = BLOCK,
                mean_dwell_s: float = MEAN_DWELL_S, n_iter: int = 30,
                min_expected: float = 1.0, quiet: bool = True) -> tuple[dict, dict]:
    """EM over the runs of ``archive`` (no labels needed): ``(document, summary)``.

    ``document`` is ``graph`` as a graph document (:func:`graph_document`) with the
    learned edges added (to the top-level edges of a graph without actions, else to
    an edge set of the action; an edge set with ``probabilities`` gets the learned
    jump probability); ``summary`` lists the added edges with their expected counts
    and jump probabilities, the learned jump probabilities of every edge, and the data
    log-likelihood per iteration.
    """
    from contactlab.archive import open_archive
    from contactlab.progress import progress

    path = Path(archive)
    lls, acts, fs = [], [], None
    with open_archive(path) as arch:
        ids = arch.select(trials)
        for tid in progress(ids, desc="em", quiet=quiet, unit="trial"):
            ll, act, fs = node_logliks(arch.trial(tid), graph, models, reduce=reduce,
                                       block=block, path=path)
            lls.append(ll)
            acts.append(np.zeros(len(ll), np.int64) if act is None or isinstance(act, str)
                        else np.asarray(act, np.int64))
    if not lls:
        raise ValueError("no trial to learn from")
    start, chain = graph_chain(graph, mean_dwell=max(mean_dwell_s * fs, 2.0))
    res = baum_welch(lls, acts, start, chain, n_iter=n_iter)
    added = learned_edges(graph, res, min_expected=min_expected)
    names = list(graph.node_names)
    doc = graph_document(graph)
    summary = {"trials": len(lls), "iterations": len(res.loglik), "converged": res.converged,
               "loglik": [float(v) for v in res.loglik], "added": [], "jump_probabilities": {},
               "transition_probabilities": {}}
    for a, edges in added.items():
        action = graph.actions[a] if graph.actions else None
        for i, j, count, p in edges:
            text = f"{names[i]} -> {names[j]}"
            summary["added"].append({"edge": text, "action": action,
                                     "expected_transitions": round(count, 3),
                                     "jump_probability": round(p, 4)})
            if action is None:
                doc["edges"].append(text)
                continue
            es = next((s for s in doc.setdefault("edge_sets", []) if s["actions"] == [action]),
                      None)
            if es is None:
                es = {"actions": [action], "edges": []}
                doc["edge_sets"].append(es)
            es["edges"].append(text)
            if "probabilities" in es:
                es["probabilities"].append(round(p, 6))
        jp = res.jump_probabilities(a)
        summary["jump_probabilities"][action or "*"] = {
            f"{names[i]} -> {names[j]}": round(float(jp[i, j]), 4)
            for i, j in zip(*np.nonzero(jp > 1e-3))}
        per = res.transitions[a] * (1.0 - np.eye(len(names)))
        summary["transition_probabilities"][action or "*"] = {
            f"{names[i]} -> {names[j]}": float(per[i, j]) for i, j in zip(*np.nonzero(per))}
    return doc, summary
