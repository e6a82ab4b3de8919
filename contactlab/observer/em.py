"""Learning a feature graph's edges and transition probabilities with EM (thesis 9.2, 10.1.3).

10.1.3: "Given an initial guess at the appropriate features, maximum likelihood in the form
of the Expectation Modification (EM) algorithm could be used to refine the graph over
multiple trials.  In the implemented experiments, the experimenter essentially acted as this
algorithm adding edges to make the system more robust."  9.2 points to the HMM practice of
learning transitions "from repeated trials using the EM algorithm" [Hannaford and Lee, 1991].

Model: a hidden Markov chain over the graph's nodes, one step per sample, with
action-dependent transition matrices ``A[a]`` (9.1.3: the action at sample t selects the
edges) and the node models' per-sample log-likelihoods as emissions (``loglik[t, k]``, the
sum of node k's models, 6.10).  Baum-Welch (Rabiner 1989, eqs 37-40 and 109-110, with the
scaled forward-backward recursion) re-estimates the initial probabilities and every row of
every ``A[a]``; emissions are held fixed (the node models are trained separately).

Edges absent from the graph are *candidates*: they start with a small probability
``candidate_mass`` (shared by a row's candidates) so EM can give them mass; after EM an edge
absent from the graph is added when its expected number of transitions over all runs reaches
``min_expected`` (default 1: at least one transition's worth of posterior evidence) and its
learned jump probability reaches ``min_probability``.  Graph edges are kept (a graph states
what is possible; runs show what happened).

A graph's edge probabilities are jump probabilities (given that the node changes); a
per-sample chain also needs the probability of staying, ``1 - hazard``.  The initial hazard is
``1 / mean_dwell`` samples; EM learns each node's own.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numba
import numpy as np

from contactlab.errors import UsageError

__all__ = ["baum_welch", "EMResult", "graph_chain", "learned_edges", "viterbi"]


@dataclass
class EMResult:
    """Learned ``start`` (K,), ``transitions`` {action: (K, K)}, expected transition counts
    {action: (K, K)}, the data log-likelihood per iteration, and whether it converged."""

    start: np.ndarray
    transitions: dict[int, np.ndarray]
    expected: dict[int, np.ndarray]
    loglik: list[float] = field(default_factory=list)
    converged: bool = False

    def jump_probabilities(self, action: int) -> np.ndarray:
        """(K, K) probabilities of the next node given a change (the diagonal removed)."""
        a = self.transitions[action].copy()
        np.fill_diagonal(a, 0.0)
        s = a.sum(axis=1, keepdims=True)
        return np.divide(a, s, out=np.zeros_like(a), where=s > 0)


def _check(loglik_runs, actions_runs, start, trans):
    if not loglik_runs:
        raise UsageError("EM needs at least one run")
    k = len(start)
    for r, ll in enumerate(loglik_runs):
        if ll.ndim != 2 or ll.shape[1] != k:
            raise UsageError(f"run {r}: log-likelihoods must be (T, {k}); got {ll.shape}")
        if not np.isfinite(ll).any(axis=1).all():
            raise UsageError(f"run {r}: a sample no node can explain (every log-likelihood -inf)")
    for r, a in enumerate(actions_runs):
        missing = set(np.unique(a[1:]).tolist()) - set(trans)   # a[0] starts the run: no transition
        if missing:
            raise UsageError(f"run {r}: no transition matrix for action(s) {sorted(missing)}")


def _stacked(trans: dict, acts: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(A (n_actions, K, K), index (T,))``: the transition matrices stacked and each
    sample's action as an index into them (sample 0 starts the run: its action is unused)."""
    codes = sorted(trans)
    lookup = {a: i for i, a in enumerate(codes)}
    index = np.array([0] + [lookup[int(a)] for a in acts[1:]], np.int64)
    return np.ascontiguousarray(np.stack([trans[a] for a in codes])), index


@numba.njit(cache=True)
def _forward_backward_kernel(b, acts, start, A):  # pragma: no cover - compiled
    """Scaled forward-backward over scaled emissions ``b`` (T, K); returns alpha, beta, the
    expected transitions per stacked action, the scales, and -1 or the first sample no
    path explains."""
    T, K = b.shape
    alpha = np.empty((T, K))
    beta = np.ones((T, K))
    xi = np.zeros((A.shape[0], K, K))
    c = np.empty(T)
    a0 = start * b[0]
    c[0] = a0.sum()
    alpha[0] = a0 / c[0]
    for t in range(1, T):
        at = (alpha[t - 1] @ A[acts[t]]) * b[t]
        c[t] = at.sum()
        if c[t] <= 0:
            return alpha, beta, xi, c, t
        alpha[t] = at / c[t]
    for t in range(T - 1, 0, -1):
        a = acts[t]
        bb = b[t] * beta[t]
        for i in range(K):
            w = alpha[t - 1, i] / c[t]
            if w != 0.0:
                for j in range(K):
                    xi[a, i, j] += A[a, i, j] * w * bb[j]
        beta[t - 1] = (A[a] @ bb) / c[t]
    return alpha, beta, xi, c, -1


def _forward_backward(ll, acts, start, trans):
    """Scaled forward-backward (Rabiner 1989, 91-93): gamma (T, K), xi sums per action, log p."""
    m = ll.max(axis=1, keepdims=True)
    b = np.ascontiguousarray(np.exp(ll - m))
    A, index = _stacked(trans, acts)
    alpha, beta, xi, c, bad = _forward_backward_kernel(b, index, np.asarray(start, float), A)
    if bad >= 0:
        raise UsageError(f"sample {bad}: no path of the graph explains the run (all "
                         "probabilities 0); allow candidate edges or check the models")
    codes = sorted(trans)
    return alpha * beta, {a: xi[i] for i, a in enumerate(codes)}, float(np.sum(np.log(c)) + m.sum())


def baum_welch(loglik_runs, actions_runs, start, transitions, *, n_iter: int = 50,
               tol: float = 1e-4, update_start: bool = True) -> EMResult:
    """Baum-Welch over fixed emissions (module docstring).

    ``loglik_runs``: list of (T_r, K) per-sample node log-likelihoods; ``actions_runs``: list
    of (T_r,) action codes (the transition into sample t uses ``transitions[actions[t]]``);
    ``start`` (K,); ``transitions`` {action: (K, K) row-stochastic}.  Zeros stay zero (an
    edge EM may not use); iteration stops when the log-likelihood gains less than ``tol``."""
    start = np.asarray(start, float).copy()
    trans = {int(a): np.asarray(m, float).copy() for a, m in transitions.items()}
    lls = [np.asarray(x, float) for x in loglik_runs]
    acts = [np.asarray(a, np.int64) for a in actions_runs]
    _check(lls, acts, start, trans)
    res = EMResult(start, trans, {a: np.zeros_like(m) for a, m in trans.items()})
    for _ in range(n_iter):
        g0 = np.zeros_like(start)
        xi = {a: np.zeros_like(m) for a, m in trans.items()}
        total = 0.0
        for ll, ac in zip(lls, acts):
            gamma, x, lp = _forward_backward(ll, ac, start, trans)
            g0 += gamma[0]
            for a in xi:
                xi[a] += x[a]
            total += lp
        res.expected = xi
        improved = not res.loglik or total - res.loglik[-1] > tol
        res.loglik.append(total)
        if not improved:
            res.converged = True
            break
        if update_start:
            start = g0 / g0.sum()
        for a, e in xi.items():
            rows = e.sum(axis=1)
            trans[a] = np.where(rows[:, None] > 0, e / np.maximum(rows, 1e-300)[:, None], trans[a])
        res.start, res.transitions = start, trans
    return res


def graph_chain(graph, *, mean_dwell: float, candidate_mass: float = 1e-3, candidates: bool = True):
    """Per-sample chain of a :class:`FeatureGraph`: ``(start, {action: A})`` for every action
    the graph names (or action 0 alone).  Row i stays with ``1 - 1 / mean_dwell``; its jump
    mass goes to the graph's edges (their probabilities, else evenly), and with ``candidates``
    a share ``candidate_mass`` of it is spread over every absent edge."""
    K = graph.n_nodes
    h = 1.0 / float(mean_dwell)
    codes = range(len(graph.actions)) if graph.actions else [0]
    out = {}
    for a in codes:
        adj = graph.adjacency(a if graph.actions else None).astype(float)
        np.fill_diagonal(adj, 0.0)
        probs = graph.edge_probabilities.get(a, {})
        for (i, j), p in probs.items():
            if adj[i, j]:
                adj[i, j] = max(p, 1e-6)
        jump = np.divide(adj, adj.sum(axis=1, keepdims=True), out=np.zeros_like(adj),
                         where=adj.sum(axis=1, keepdims=True) > 0)
        if candidates:
            absent = (adj == 0) & ~np.eye(K, dtype=bool)
            n_abs = absent.sum(axis=1, keepdims=True)
            has = jump.sum(axis=1, keepdims=True) > 0
            share = np.where(has, candidate_mass, 1.0)
            jump = jump * (1.0 - candidate_mass * has) + np.where(absent, share / np.maximum(n_abs, 1), 0.0)
        A = h * jump
        A[np.arange(K), np.arange(K)] = 1.0 - h * jump.sum(axis=1)
        out[a] = A
    return graph.initial.copy(), out


def learned_edges(graph, result: EMResult, *, min_expected: float = 1.0,
                  min_probability: float = 0.01) -> dict[int, list[tuple[int, int, float, float]]]:
    """Per action: the edges absent from ``graph`` that EM adds, as (i, j, expected count,
    jump probability), by the criterion of the module docstring."""
    out = {}
    for a, e in result.expected.items():
        adj = graph.adjacency(a if graph.actions else None)
        jp = result.jump_probabilities(a)
        new = []
        for i, j in zip(*np.nonzero((e >= min_expected) & ~adj)):
            if i != j and jp[i, j] >= min_probability:
                new.append((int(i), int(j), float(e[i, j]), float(jp[i, j])))
        out[a] = new
    return out


def _log(x) -> np.ndarray:
    x = np.asarray(x, float)
    return np.log(np.maximum(x, 1e-300)) + np.where(x > 0, 0.0, -np.inf)


@numba.njit(cache=True)
def _viterbi_kernel(ll, acts, log_start, log_A):  # pragma: no cover - compiled
    T, K = ll.shape
    delta = log_start + ll[0]
    back = np.zeros((T, K), np.int64)
    new = np.empty(K)
    for t in range(1, T):
        a = acts[t]
        for j in range(K):
            best, arg = -np.inf, 0
            for i in range(K):
                v = delta[i] + log_A[a, i, j]
                if v > best:
                    best, arg = v, i
            back[t, j] = arg
            new[j] = best + ll[t, j]
        delta[:] = new
    path = np.empty(T, np.int64)
    path[-1] = np.argmax(delta)
    for t in range(T - 1, 0, -1):
        path[t - 1] = back[t, path[t]]
    return path


def viterbi(loglik, actions, start, transitions) -> np.ndarray:
    """(T,) the most probable node sequence of one run (log domain), for scoring a learned chain."""
    ll = np.ascontiguousarray(np.asarray(loglik, float))
    A, index = _stacked({int(a): m for a, m in transitions.items()},
                        np.asarray(actions, np.int64))
    return _viterbi_kernel(ll, index, _log(start), _log(A))
