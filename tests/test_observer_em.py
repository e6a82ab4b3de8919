"""Baum-Welch over a feature graph (thesis 9.2, 10.1.3) against independent oracles."""

from __future__ import annotations

import numpy as np
import pytest
from hmmlearn.base import BaseHMM

from contactlab.errors import UsageError
from contactlab.observer.em import baum_welch, graph_chain, learned_edges
from contactlab.observer.graph import load_graph


class _FixedEmissions(BaseHMM):
    """hmmlearn's Baum-Welch with given per-sample log-likelihoods (X holds sample indices)."""

    def __init__(self, table, **kw):
        super().__init__(n_components=table.shape[1], params="st", init_params="", **kw)
        self.table = table

    def _compute_log_likelihood(self, X):
        return self.table[X[:, 0].astype(int)]

    def _get_n_fit_scalars_per_param(self):
        return {"s": self.n_components - 1, "t": self.n_components * (self.n_components - 1)}

    def _init(self, X, lengths=None):
        pass

    def _check(self):
        pass


def _random_problem(seed, K=4, runs=(60, 45, 80)):
    rng = np.random.default_rng(seed)
    lls = [rng.normal(0.0, 2.0, (T, K)) for T in runs]
    A = rng.uniform(0.2, 1.0, (K, K)) + 3 * np.eye(K)
    A[0, 3] = 0.0                                  # an edge the graph does not have stays absent
    A /= A.sum(axis=1, keepdims=True)
    pi = rng.uniform(0.5, 1.0, K)
    return lls, A, pi / pi.sum()


@pytest.mark.parametrize("seed", [0, 1])
def test_baum_welch_matches_hmmlearn_on_the_same_emissions(seed):
    lls, A, pi = _random_problem(seed)
    ours = baum_welch(lls, [np.zeros(len(x), int) for x in lls], pi, {0: A}, n_iter=6, tol=-np.inf)
    table = np.concatenate(lls)
    ref = _FixedEmissions(table, n_iter=6, tol=-np.inf, algorithm="viterbi")
    ref.startprob_, ref.transmat_ = pi.copy(), A.copy()
    ref.fit(np.arange(len(table))[:, None], lengths=[len(x) for x in lls])
    assert ours.transitions[0] == pytest.approx(ref.transmat_, abs=1e-9)
    assert ours.start == pytest.approx(ref.startprob_, abs=1e-9)
    assert ours.transitions[0][0, 3] == 0.0
    assert np.all(np.diff(ours.loglik) > -1e-9)                 # EM never lowers the likelihood
    assert ours.loglik == pytest.approx(list(ref.monitor_.history), rel=1e-10)


def test_observed_states_give_the_counted_transitions_per_action():
    # closed form: emissions that name the state make EM the supervised count of transitions
    states = np.array([0, 0, 1, 1, 1, 2, 0, 0, 2, 2, 1, 0])
    acts = np.array([0, 1, 1, 1, 2, 2, 2, 1, 1, 2, 2, 1])
    ll = np.where(np.eye(3, dtype=bool)[states], 0.0, -np.inf)
    A0 = {a: np.full((3, 3), 1 / 3) for a in (1, 2)}
    res = baum_welch([ll], [acts], np.full(3, 1 / 3), A0, n_iter=3)
    for a in (1, 2):
        counts = np.zeros((3, 3))
        for t in range(1, len(states)):
            if acts[t] == a:
                counts[states[t - 1], states[t]] += 1
        rows = counts.sum(axis=1) > 0
        assert res.expected[a] == pytest.approx(counts)
        assert res.transitions[a][rows] == pytest.approx(counts[rows] / counts[rows].sum(axis=1, keepdims=True))
    assert res.start == pytest.approx([1, 0, 0])


def test_a_missing_edge_is_recovered_and_bad_input_is_refused():
    g = load_graph("guarded-move")                  # 0 -> 1 -> 2 ..., no edge 0 -> 3
    start, chain = graph_chain(g, mean_dwell=20)
    assert set(chain) == {0} and chain[0].sum(axis=1) == pytest.approx(1.0)
    path = [0] * 30 + [3] * 30                     # runs that go 0 -> 3 directly
    ll = np.where(np.eye(g.n_nodes, dtype=bool)[path], 0.0, -8.0)
    res = baum_welch([ll] * 4, [np.zeros(60, int)] * 4, start, chain, n_iter=20)
    new = learned_edges(g, res)
    assert [(i, j) for i, j, _, _ in new[0]] == [(0, 3)]
    assert new[0][0][2] == pytest.approx(4.0, abs=0.05)          # one transition per run
    _, strict = graph_chain(g, mean_dwell=20, candidates=False)
    with pytest.raises(UsageError, match="no path of the graph explains"):
        baum_welch([np.where(np.eye(g.n_nodes, dtype=bool)[path], 0.0, -np.inf)], [np.zeros(60, int)],
                   start, strict)
    with pytest.raises(UsageError, match=r"run 0: log-likelihoods must be \(T, 6\)"):
        baum_welch([np.zeros((5, 2))], [np.zeros(5, int)], start, chain)
