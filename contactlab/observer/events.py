"""6.4's decisions at a detected change, compiled once for both forms of the observer.

"If a change in any model is detected": which tests alarmed and at which change times
(6.15's maximiser, each test's last zero + 1), which transient paths reached the end of
their longest duration, the candidate instances ``(node, start)`` that follow them
(step 1) with the best tracked predecessor of each (the maximisation of 6.1/6.5 over
the predecessors of a feature instance), whether each candidate is already tracked
(step 2), and after the new paths are in, the paths the pruning keeps (the mass
``P_prune``, the gap below the best, 9.1.1).  The observer's compiled core
(:mod:`~contactlab.observer.engine`) and its general form
(:class:`~contactlab.observer.observer.Observer` over model banks) hold their paths
differently -- flat arrays and a segment table, Python objects -- and each applies
these decisions to its own: the merges, the new paths and their instances, the
compaction.  A plain per-sample implementation of 6.4 in the tests
(``tests/test_observer_reference.py``) is the independent check of both.
"""

from __future__ import annotations

import math

import numba
import numpy as np

__all__ = ["collect_alarms", "best_candidates", "keep_set", "gap_drops"]


@numba.njit(cache=True)
def collect_alarms(ta, threshold, tmax, udf, ulz, upath, umodel, n_units, pnode, pstart,
                   n_paths, al_p, al_k, al_r, rs):  # pragma: no cover - compiled
    """The alarms at sample ``ta``: ``(path, model, change time)`` in ``al_p``, ``al_k``,
    ``al_r`` and their count, then the count of those from the detectors.

    Every test of an instance ``u`` whose statistic ``udf[u]`` crossed ``threshold`` is a
    detected change dated at its own last zero + 1 (a big jump makes all of an
    instance's tests cross, and the largest statistic may date from an old excursion);
    each distinct time is an alarm, in increasing order, and the instance's tests are
    reset (step 4: statistics 0, last zeros ``ta``).  Then a path on a transient node
    held for its longest duration ``tmax[node]`` ends: an alarm at the end of its
    duration (its first instance's model).  ``rs``: scratch of at least the number of
    tests."""
    S = udf.shape[1]
    nA = 0
    for u in range(n_units):
        nr = 0
        for s in range(S):
            if udf[u, s] > threshold:
                r = ulz[u, s] + 1
                dup = False
                for i in range(nr):
                    if rs[i] == r:
                        dup = True
                if not dup:
                    i = nr
                    while i > 0 and rs[i - 1] > r:
                        rs[i] = rs[i - 1]
                        i -= 1
                    rs[i] = r
                    nr += 1
        if nr == 0:
            continue
        for s in range(S):
            udf[u, s] = 0.0
            ulz[u, s] = ta
        for i in range(nr):
            al_p[nA] = upath[u]
            al_k[nA] = umodel[u]
            al_r[nA] = rs[i]
            nA += 1
    n_detected = nA
    for p in range(n_paths):
        tm = tmax[pnode[p]]
        if tm > 0 and ta - pstart[p] >= tm:
            for u in range(n_units):
                if upath[u] == p:
                    al_p[nA] = p
                    al_k[nA] = umodel[u]
                    al_r[nA] = pstart[p] + tm
                    nA += 1
                    break
    return nA, n_detected


@numba.njit(cache=True)
def best_candidates(n_alarms, n_detected, al_p, al_r, pnode, pstart, pslot, n_paths, hist,
                    hist_base, actions, action_base, succ, n_succ, log_t,
                    c_j, c_r, c_init, c_from, c_found):  # pragma: no cover - compiled
    """Step 1 and the test of step 2: the candidate instances ``(c_j, c_r)`` that follow
    the alarms, in alarm order, each once; returns their count.

    An alarm's candidates are its node's successors under the action at its change time
    ``r`` (``actions[r - action_base]``, -1 for none: row ``action + 1`` of ``succ``,
    ``n_succ`` and ``log_t``); an ended transient (alarms from ``n_detected`` on) goes
    on elsewhere, not to itself.  ``c_init``: the best tracked path's log-likelihood
    after sample ``r - 1`` (``hist[r - hist_base, slot]``) plus ``log p(i -> j)``, over
    the paths started before ``r`` (an instance explains at least one measurement, the
    lattice of fig 6.2: else one change would carry a path through a chain of nodes of
    no samples each), the first on ties; ``c_from``: that path (-1: none); ``c_found``:
    the tracked path of the same ``(node, start)`` (-1: a new instance)."""
    nC = 0
    for i in range(n_alarms):
        r = al_r[i]
        a1 = actions[r - action_base] + 1
        node = pnode[al_p[i]]
        for jj in range(n_succ[a1, node]):
            j = succ[a1, node, jj]
            if i >= n_detected and j == node:
                continue
            seen = False
            for c in range(nC):
                if c_j[c] == j and c_r[c] == r:
                    seen = True
                    break
            if seen:
                continue
            best = -np.inf
            prev = -1
            hr = r - hist_base
            for p in range(n_paths):
                if pstart[p] < r:
                    v = hist[hr, pslot[p]] + log_t[a1, pnode[p], j]
                    if v > best:
                        best = v
                        prev = p
            found = -1
            for p in range(n_paths):
                if pnode[p] == j and pstart[p] == r:
                    found = p
                    break
            c_j[nC] = j
            c_r[nC] = r
            c_init[nC] = best
            c_from[nC] = prev
            c_found[nC] = found
            nC += 1
    return nC


@numba.njit(cache=True, inline="always")
def gap_drops(pll, pnode, n_paths, p, best, gap, survivors):  # pragma: no cover - compiled
    """Whether the pruning would drop path ``p`` for its gap below the ``best``
    log-likelihood (an event at this sample): it is more than ``gap`` below, and, with
    ``survivors``, another path in its node leads it (the first of equals survives)."""
    if pll[p] >= best - gap:
        return False
    if not survivors:
        return True
    for q in range(n_paths):
        if q != p and pnode[q] == pnode[p] and (pll[q] > pll[p] or (pll[q] == pll[p] and q < p)):
            return True
    return False


@numba.njit(cache=True)
def keep_set(pll, pnode, n_paths, p_keep, gap, max_paths, survivors, order, w,
             keep):  # pragma: no cover - compiled
    """The pruning (6.4, 9.1.1): rank the ``n_paths`` paths by log-likelihood ``pll``
    (stable, largest first), keep the most probable until their share of the mass
    reaches ``p_keep`` (``p_keep >= 1``: no mass rule), then only those within ``gap`` of
    the best and at most ``max_paths`` (negative: no limit); with ``survivors``, also the
    best path ending in each node (``pnode``) the kept ones leave out.  Writes the kept
    paths, in increasing order, to ``keep`` and returns their count (``order``, ``w``:
    scratch of ``n_paths``)."""
    for i in range(n_paths):
        x = pll[i]
        j = i
        while j > 0 and pll[order[j - 1]] < x:
            order[j] = order[j - 1]
            j -= 1
        order[j] = i
    top = pll[order[0]]
    tot = 0.0
    for i in range(n_paths):
        w[i] = math.exp(pll[i] - top)
        tot += w[i]
    n_keep = n_paths
    cum = 0.0
    for i in range(n_paths if p_keep < 1.0 else 0):   # P_prune = 1: no mass rule
        cum += w[order[i]] / tot
        if cum >= p_keep:
            n_keep = i + 1
            break
    nk = 0
    for i in range(n_keep):
        if pll[order[i]] >= top - gap and (max_paths < 0 or nk < max_paths):
            keep[nk] = order[i]
            nk += 1
    if survivors:
        n_nodes = 0
        for i in range(n_paths):
            n_nodes = max(n_nodes, pnode[i] + 1)
        seen = np.zeros(n_nodes, np.bool_)
        for i in range(nk):
            seen[pnode[keep[i]]] = True
        for i in range(n_paths):
            p = order[i]
            if not seen[pnode[p]]:
                seen[pnode[p]] = True
                keep[nk] = p
                nk += 1
    keep[:nk].sort()
    return nk
