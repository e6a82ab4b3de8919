"""The observer's compiled core (6.4).

When every model of a graph runs here (:meth:`FeatureModel.core_spec`): square-root
Kalman filters whose regressors the core can form itself (the AR regressors of
:class:`~contactlab.observer.models.temporal.TemporalFeature`, the time since the
start of :class:`~contactlab.observer.models.impact.ImpactFeature`) and models scored
directly by a compiled step per sample (the velocity models F and M,
:func:`~contactlab.observer.models.velocity.velocity_step`, and the constraint models
of fixed or estimated frame, :func:`~contactlab.observer.models.constraint.constraint_step`:
9.1's triples; a stateless model's score of a sample is computed once for all its
instances), the whole of
6.4 -- per sample the instances' filter steps, the Page-Hinkley tests and the path
sums; at a detected change the alarms, the successors and their best
predecessors, the maximisation over (node, start), the catch-up of the new paths
over the buffered samples and the pruning -- runs in one compiled loop over flat
preallocated arrays (:func:`run_core`), so an event costs microseconds.  It is
:class:`~contactlab.observer.observer.Observer`'s general form step by step, the
same arithmetic in the same order, so the events, paths and path
log-likelihoods are the general form's to the bit (the tests run both); the node
probabilities and the pruning weights use the C library's ``exp`` and plain sums,
which differ from numpy's by a few units in the last place.

The filter step is the package's one square-root Kalman step,
:func:`~contactlab.estimators.kalman.sqrt_step`, for one scalar filter (m = 1, every
channel of the linear feature models is one) on the instance's state row
(:func:`_kalman_channel`, compiled apart, takes the parameter count as an argument, so the
loop is compiled once for every count; the detectors call
:func:`~contactlab.detection.cusum.cusum_step`).  A written-out two-parameter step on
scalars (the state in registers, the instances in passes so that their dependent chains
overlap) measured no faster on the 7.3 graphs (the hour of y_h at 2,300-2,900x real time
with it and 2,500-2,900x without) and was one more copy of the step, so it is gone.
Every part of the loop is a named helper (:func:`_filter_step`, :func:`_direct_score`,
:func:`_detectors`, :func:`_path_sums`, :func:`_catch_up_sums`, :func:`_event_fits`,
:func:`_spawn`, :func:`_prune`); an event's decisions are
:mod:`~contactlab.observer.events`', which the general form uses too.

State: paths (id, node, start, initial and current log-likelihood, column of the
log-likelihood history, segment), instances ("units": path, model, start,
detector statistics and last zeros, filter state per channel) and a table of
segments ``(node, start, previous segment)`` holding the paths' histories (6.1),
compacted to those still reachable when it fills.  The loop stops at an event
that would overflow an array (:data:`FULL`); the caller grows them and resumes
with the event.  Events go to tables an
:class:`~contactlab.observer.paths.EventLog` keeps.
"""

from __future__ import annotations

import math
from collections import namedtuple

import numba
import numpy as np

from contactlab.detection.cusum import cusum_step
from contactlab.estimators.kalman import sqrt_step, step_scratch
from contactlab.observer.events import best_candidates, collect_alarms, gap_drops, keep_set
from contactlab.observer.models.constraint import SCRATCH as CONSTRAINT_SCRATCH
from contactlab.observer.models.constraint import constraint_step
from contactlab.observer.models.gaussian import gaussian_step
from contactlab.observer.models.velocity import velocity_step

_HALF_LOG_2PI = 0.5 * 1 * math.log(2.0 * math.pi)

__all__ = ["REG_AR", "REG_TIME", "REG_VELOCITY", "REG_CONSTRAINT", "REG_GAUSSIAN", "OK", "FULL",
           "Core", "CoreConfig", "CoreEvents", "CoreState", "run_core", "state_width"]

#: regressors the core forms: AR (``[1,] y(t-1) .. y(t-p)`` per channel) and ``[1, t - start]``
REG_AR, REG_TIME = 0, 1
#: models scored directly by their compiled step (no Kalman filter): velocity (F, M) and
#: constraint models (:func:`~contactlab.observer.models.velocity.velocity_step`,
#: :func:`~contactlab.observer.models.constraint.constraint_step`)
REG_VELOCITY, REG_CONSTRAINT = 2, 3
#: a phase's Gaussian on a multi-channel stream, stateless like the velocity models
#: (:func:`~contactlab.observer.models.gaussian.gaussian_step`)
REG_GAUSSIAN = 4
#: :func:`run_core` status: done, or stopped before a sample for room
OK, FULL = 0, 1
# counters: paths, units, segments, free slots, slots, next path id, events, alarms,
# candidate log-likelihoods, kept indices, spawned, merged
C_P, C_U, C_SEG, C_FREE, C_SLOTS, C_ID, C_EV, C_AL, C_CAND, C_KEEP, C_SP, C_MG = range(12)
N_COUNTERS = 12
# columns of the event table
E_TA, E_AL0, E_NAL, E_CAND0, E_NCAND, E_KEEP0, E_NKEEP, E_SP0, E_NSP, E_MG0, E_NMG = range(11)
N_EV_COLS = 11
#: columns of a model's row in ``CoreConfig.model_info``: its regressors (``REG_*``), AR
#: order, whether the AR model has a constant, parameter count, first column in the
#: measurement buffer, channels, regressor structure (``kalman.MODE_*``), whether the noise
#: is estimated on-line
MI_REG, MI_ORDER, MI_MEAN, MI_Q, MI_COL, MI_CHANNELS, MI_MODE, MI_EST = range(8)


#: the core's configuration, fixed for one observer: each model's row (``MI_*``
#: columns), its running noise estimate's prior count, each test's increment ``a + b x``
#: per model and its source (0: the chi-square, 1: the normalised innovation or rival
#: margin), each model's prior state row per channel, the threshold, the path gap, the
#: mass kept and the beam width (-1: none), the successors and log transition
#: probabilities, each node's models (``kind_ptr``, ``kind_list``), the largest parameter
#: count, the directly scored models' parameter rows, each node's longest duration, whether
#: the pruning keeps each node's best path
CoreConfig = namedtuple("CoreConfig", [
    "model_info", "noise_prior_count", "side_a", "side_b", "side_src", "prior_state",
    "threshold", "gap", "p_keep", "max_paths", "succ", "n_succ", "log_t", "kind_ptr",
    "kind_list", "q_max", "model_params", "max_duration", "survivors"])
#: the core's state: instances (path, model, start, detector statistics, last zeros, state
#: rows), the measurement buffer and the global row of its first row, the paths'
#: log-likelihood history and its first row, the counters (``C_*``), paths (id, node,
#: start, history column, segment, initial and current log-likelihood), the free history
#: columns, the actions and their first row, the segments (node, start, previous)
CoreState = namedtuple("CoreState", [
    "unit_path", "unit_model", "unit_start", "unit_df", "unit_lz", "unit_state", "x",
    "x_base", "hist", "hist_base", "counters", "path_id", "path_node", "path_start",
    "path_slot", "path_seg", "path_init", "path_ll", "free_slots", "actions", "action_base",
    "seg_node", "seg_start", "seg_prev"])
#: the event tables (:class:`~contactlab.observer.paths.EventLog` reads them): events
#: (``E_*`` columns), alarms, candidates' log-likelihoods, kept paths, spawned, merged
CoreEvents = namedtuple("CoreEvents", ["events", "alarms", "cand_ll", "kept", "spawned",
                                       "merged"])


def state_width(qmax: int) -> int:
    """Length of a unit-channel state row: theta (qmax), S and Ls (qmax x qmax each,
    row-major), then Ve, Lv and the running-variance count."""
    return qmax + 2 * qmax * qmax + 3


@numba.njit(cache=True)
def _init_unit(u, p, k, r, lz, pst, upath, umodel, ustart, udf, ulz, ust):  # pragma: no cover
    """Unit ``u`` of path ``p``: a fresh instance of model ``k`` started at ``r`` (its
    prior state row, detectors at zero with last zero ``lz``)."""
    upath[u] = p
    umodel[u] = k
    ustart[u] = r
    udf[u, :] = 0.0
    ulz[u, :] = lz
    ust[u] = pst[k]


@numba.njit(cache=True)
def _spawn(ta, cfg, st, ev, newp, scr):  # pragma: no cover - compiled
    """6.4, "if a change in any model is detected" at ``ta``: the alarms, the candidates
    with their best predecessors (step 1), the maximisation over (node, start) (step 2)
    and the new paths with fresh instances (step 3), each at its initial log-likelihood
    with its history row ``r`` written; ``newp`` receives (path, first unit, end unit)
    of each new path for the caller's catch-up (``scr``: :func:`run_core`'s scratch
    arrays for the events).  Returns the number of new paths."""
    pst, thr, tmax = cfg.prior_state, cfg.threshold, cfg.max_duration
    succ, n_succ, logT = cfg.succ, cfg.n_succ, cfg.log_t
    nk_ptr, nk_list = cfg.kind_ptr, cfg.kind_list
    upath, umodel, ustart, udf, ulz, ust = (st.unit_path, st.unit_model, st.unit_start,
                                            st.unit_df, st.unit_lz, st.unit_state)
    ha, hbase, cnt, free = st.hist, st.hist_base, st.counters, st.free_slots
    pid, pnode, pstart, pslot, pseg, pinit, pll = (st.path_id, st.path_node, st.path_start,
                                                   st.path_slot, st.path_seg, st.path_init,
                                                   st.path_ll)
    aa, abase = st.actions, st.action_base
    snode, sstart, sprev = st.seg_node, st.seg_start, st.seg_prev
    evt, alt, spt, mgt = ev.events, ev.alarms, ev.spawned, ev.merged
    nP, nU = cnt[C_P], cnt[C_U]
    al_p, al_k, al_r, rs, c_j, c_r, c_init, c_prev, c_found = scr[:9]
    nA, nA_det = collect_alarms(ta, thr, tmax, udf, ulz, upath, umodel, nU, pnode, pstart, nP,
                                al_p, al_k, al_r, rs)
    nC = best_candidates(nA, nA_det, al_p, al_r, pnode, pstart, pslot, nP, ha, hbase, aa,
                         abase, succ, n_succ, logT, c_j, c_r, c_init, c_prev, c_found)
    for c in range(nC):                          # the predecessors' segments, before merges
        if c_prev[c] >= 0:
            c_prev[c] = pseg[c_prev[c]]
    # maximisation over (node, start) (step 2): a tracked instance takes a better start
    sp0, mg0 = cnt[C_SP], cnt[C_MG]
    for c in range(nC):
        found = c_found[c]
        j, r, init = c_j[c], c_r[c], c_init[c]
        if found >= 0 and init > pinit[found]:
            delta = init - pinit[found]
            pll[found] += delta
            sl = pslot[found]
            for tt in range(r, ta + 2):
                ha[tt - hbase, sl] += delta
            pinit[found] = init
            g = cnt[C_SEG]
            snode[g], sstart[g], sprev[g] = j, r, c_prev[c]
            cnt[C_SEG] = g + 1
            pseg[found] = g
            mgt[cnt[C_MG], 0] = j
            mgt[cnt[C_MG], 1] = r
            cnt[C_MG] += 1
    n_new = 0
    for c in range(nC):
        if c_found[c] >= 0 or c_prev[c] < 0:     # tracked, or no path began before r
            continue
        j, r, init = c_j[c], c_r[c], c_init[c]
        p = cnt[C_P]
        cnt[C_P] = p + 1
        pid[p] = cnt[C_ID]
        cnt[C_ID] += 1
        pnode[p] = j
        pstart[p] = r
        pinit[p] = init
        pll[p] = init
        if cnt[C_FREE] > 0:
            cnt[C_FREE] -= 1
            sl = free[cnt[C_FREE]]
        else:
            sl = cnt[C_SLOTS]
            cnt[C_SLOTS] += 1
        pslot[p] = sl
        g = cnt[C_SEG]
        snode[g], sstart[g], sprev[g] = j, r, c_prev[c]
        cnt[C_SEG] = g + 1
        pseg[p] = g
        ha[r - hbase, sl] = init
        newp[n_new, 0] = p
        newp[n_new, 1] = cnt[C_U]
        for ik in range(nk_ptr[j], nk_ptr[j + 1]):
            _init_unit(cnt[C_U], p, nk_list[ik], r, r - 1, pst, upath, umodel, ustart, udf,
                       ulz, ust)
            cnt[C_U] += 1
        newp[n_new, 2] = cnt[C_U]
        n_new += 1
        spt[cnt[C_SP], 0] = j
        spt[cnt[C_SP], 1] = r
        cnt[C_SP] += 1
    for i in range(nA_det, nA):                  # the ended transients leave
        pll[al_p[i]] = -np.inf
    # the event's alarms, spawned and merged (its record is completed by _prune)
    e = cnt[C_EV]
    evt[e, E_TA] = ta
    evt[e, E_AL0] = cnt[C_AL]
    evt[e, E_NAL] = nA
    for i in range(nA):
        a = cnt[C_AL] + i
        alt[a, 0] = pid[al_p[i]]
        alt[a, 1] = pnode[al_p[i]]
        alt[a, 2] = al_k[i]
        alt[a, 3] = al_r[i]
    cnt[C_AL] += nA
    evt[e, E_SP0] = sp0
    evt[e, E_NSP] = cnt[C_SP] - sp0
    evt[e, E_MG0] = mg0
    evt[e, E_NMG] = cnt[C_MG] - mg0
    return n_new


@numba.njit(cache=True)
def _prune(ta, cfg, st, ev, scr):  # pragma: no cover - compiled
    """Rank the paths, keep mass P_prune, drop those ``gap`` below the best (6.4, 9.1.1);
    complete the event record; move the kept paths and their units to the front (``scr``:
    :func:`run_core`'s scratch arrays for the events)."""
    gap, p_keep, max_paths = cfg.gap, cfg.p_keep, cfg.max_paths
    upath, umodel, ustart, udf, ulz, ust = (st.unit_path, st.unit_model, st.unit_start,
                                            st.unit_df, st.unit_lz, st.unit_state)
    cnt, free = st.counters, st.free_slots
    pid, pnode, pstart, pslot, pseg, pinit, pll = (st.path_id, st.path_node, st.path_start,
                                                   st.path_slot, st.path_seg, st.path_init,
                                                   st.path_ll)
    evt, candt, keept = ev.events, ev.cand_ll, ev.kept
    nP = cnt[C_P]
    order, w, keep, remap = scr[9:]
    nk = keep_set(pll, pnode, nP, p_keep, gap, max_paths, cfg.survivors, order, w, keep)
    # the event record
    e = cnt[C_EV]
    evt[e, E_CAND0] = cnt[C_CAND]
    evt[e, E_NCAND] = nP
    candt[cnt[C_CAND]:cnt[C_CAND] + nP] = pll[:nP]
    cnt[C_CAND] += nP
    evt[e, E_KEEP0] = cnt[C_KEEP]
    evt[e, E_NKEEP] = nk
    keept[cnt[C_KEEP]:cnt[C_KEEP] + nk] = keep[:nk]
    cnt[C_KEEP] += nk
    cnt[C_EV] = e + 1
    if nk == nP:
        return
    # compaction: kept paths and their units move to the front, dropped slots are freed
    for i in range(nP):
        remap[i] = -1
    for n in range(nk):
        remap[keep[n]] = n
    for i in range(nP):
        if remap[i] < 0:
            free[cnt[C_FREE]] = pslot[i]
            cnt[C_FREE] += 1
    for n in range(nk):
        i = keep[n]
        pid[n], pnode[n], pstart[n], pslot[n] = pid[i], pnode[i], pstart[i], pslot[i]
        pseg[n], pinit[n], pll[n] = pseg[i], pinit[i], pll[i]
    cnt[C_P] = nk
    n = 0
    for u in range(cnt[C_U]):
        p = remap[upath[u]]
        if p < 0:
            continue
        if n != u:
            umodel[n], ustart[n] = umodel[u], ustart[u]
            udf[n] = udf[u]
            ulz[n] = ulz[u]
            ust[n] = ust[u]
        upath[n] = p
        n += 1
    cnt[C_U] = n


@numba.njit(cache=True, inline="always")
def _direct_step(reg, p, s, x, w):  # pragma: no cover - compiled
    """A directly scored model's log-likelihood and chi-square of one sample ``x`` (its
    signal's columns), its state row ``s`` advanced (``w``: scratch); the Gaussian model,
    which also gives its rival margin, is stepped by the caller."""
    if reg == REG_CONSTRAINT:
        return constraint_step(p, s, x, w)
    return velocity_step(p, x)


@numba.njit(cache=True, inline="always")
def _regressors(mi, k, x, row, col, tt, start, H):  # pragma: no cover - compiled
    """Any model's regressors at sample ``tt`` into ``H[0]``: AR (the constant first) or
    ``[1, t - start]``."""
    if mi[k, MI_REG] == REG_AR:
        j = 0
        if mi[k, MI_MEAN]:
            H[0, 0] = 1.0
            j = 1
        for i in range(1, mi[k, MI_ORDER] + 1):
            H[0, j + i - 1] = x[row - i, col]
    else:
        H[0, 0] = 1.0
        H[0, 1] = float(tt - start)


@numba.njit(cache=True, inline="always")
def _step_scratch(qmax):  # pragma: no cover - compiled
    """The filter step's scratch: the regressors, the measurement and
    :func:`~contactlab.estimators.kalman.sqrt_step`'s own."""
    return np.zeros((1, qmax)), np.zeros(1), step_scratch(1, qmax)


@numba.njit(cache=True)
def _event_scratch(n_units, n_paths, S, deg):  # pragma: no cover - compiled
    """:func:`_spawn`'s and :func:`_prune`'s scratch: alarms, candidates (at most the
    graph's out-degree per alarm), the ranking, the kept paths and their new places."""
    nuc = n_units * S
    return (np.empty(nuc, np.int64), np.empty(nuc, np.int64), np.empty(nuc, np.int64),
            np.empty(S, np.int64), np.empty(nuc * deg, np.int64),
            np.empty(nuc * deg, np.int64), np.empty(nuc * deg),
            np.empty(nuc * deg, np.int64), np.empty(nuc * deg, np.int64),
            np.empty(n_paths, np.int64), np.empty(n_paths), np.empty(n_paths, np.int64),
            np.empty(n_paths, np.int64))


@numba.njit(cache=True)
def _graph_bounds(cfg):  # pragma: no cover - compiled
    """Whether any model is scored directly, the most models of a node, and the graph's
    out-degree (an alarm's candidates are its node's successors)."""
    mi = cfg.model_info
    direct = False
    for k in range(mi.shape[0]):
        direct = direct or mi[k, MI_REG] >= REG_VELOCITY
    maxk = 0
    for j in range(cfg.log_t.shape[1]):
        maxk = max(maxk, cfg.kind_ptr[j + 1] - cfg.kind_ptr[j])
    return direct, maxk, max(1, cfg.n_succ.max())


@numba.njit(cache=True)
def _kalman_channel(ust, u, c, q, qmax, y, mode, est, pcount, sc):  # pragma: no cover
    """One sample of one scalar filter (m = 1) by the package's square-root step
    (:func:`~contactlab.estimators.kalman.sqrt_step`) on the state row ``ust[u, c]``
    (:func:`state_width`'s layout, read in place as the step's arrays), the regressors in
    ``H[0]`` of the scratch ``sc`` (:func:`_step_scratch`).  Returns the log-likelihood,
    ``-al^2 / 2`` and the normalised innovation ``al``.  Compiled apart, not inlined: a
    call per channel costs less than compiling the step into every specialisation of
    :func:`run_core` (3 s of each)."""
    H, yv, ssc = sc
    row = ust[u, c]
    oS = qmax
    oL = qmax + qmax * qmax
    oV = qmax + 2 * qmax * qmax
    yv[0] = y
    lc, ll, row[oV + 2] = sqrt_step(
        H, yv, row[:qmax], row[oS:oL].reshape((qmax, qmax)),
        row[oL:oV].reshape((qmax, qmax)), row[oV:oV + 1].reshape((1, 1)),
        row[oV + 1:oV + 2].reshape((1, 1)), est, mode, row[oV + 2], pcount, 1, q, ssc)
    return ll, lc, ssc[6][0]


@numba.njit(cache=True, inline="always")
def _filter_step(mi, mf, x, ust, ustart, u, k, tt, row, qmax, sc):  # pragma: no cover
    """A Kalman instance ``u`` (model ``k``) on sample ``tt``: its log-likelihood,
    chi-square and normalised innovation, its channels added as ``run_kalman`` adds them
    (each channel :func:`_kalman_channel`)."""
    q = mi[k, MI_Q]
    C, mode, est = mi[k, MI_CHANNELS], mi[k, MI_MODE], mi[k, MI_EST] != 0
    pcount = mf[k]
    ll_sum = 0.0
    chi = 0.0
    zs = 0.0
    for c in range(C):
        col = mi[k, MI_COL] + c
        _regressors(mi, k, x, row, col, tt, ustart[u], sc[0])
        ll, lc, al = _kalman_channel(ust, u, c, q, qmax, x[row, col], mode, est, pcount, sc)
        if C == 1:
            ll_sum = ll
            chi = lc * -2.0
            zs = al
        else:
            ll_sum += ll
            chi += -2.0 * lc
            zs += al
    if C > 1:
        zs = zs * (1.0 / math.sqrt(C))
    return ll_sum, chi, zs


@numba.njit(cache=True, inline="always")
def _direct_score(mi, mp, x, ust, u, k, tt, row, vt, vll, vchi, vz, wk):  # pragma: no cover
    """A directly scored instance ``u`` (model ``k``) on sample ``tt``: its log-likelihood,
    chi-square and rival margin (0 but for a Gaussian).  A stateless model's score of a
    sample (``vt[k]``: the sample model ``k`` was last scored at; ``vll``, ``vchi``,
    ``vz``: its scores) is computed once for all its instances."""
    reg = mi[k, MI_REG]
    if (reg == REG_VELOCITY or reg == REG_GAUSSIAN) and vt[k] == tt:
        return vll[k], vchi[k], vz[k]
    col, C = mi[k, MI_COL], mi[k, MI_CHANNELS]
    if reg == REG_GAUSSIAN:
        # z: the best rival's log-likelihood margin (its rival test's increment)
        ll, chi, z = gaussian_step(mp[k], x[row, col:col + C])
        vt[k], vll[k], vchi[k], vz[k] = tt, ll, chi, z
        return ll, chi, z
    # z = 0: its mean tests never fire; no channel filters
    ll, chi = _direct_step(reg, mp[k], ust[u, 0], x[row, col:col + C], wk)
    if reg == REG_VELOCITY:
        vt[k], vll[k], vchi[k], vz[k] = tt, ll, chi, 0.0
    return ll, chi, 0.0


@numba.njit(cache=True, inline="always")
def _detectors(sa, sb, src, df, lz, u, k, tt, chi, z, top):  # pragma: no cover - compiled
    """Instance ``u``'s detector row at sample ``tt``: 6.18 on ``a + b x`` for every test
    (``a``, ``b``: ``sa[k]``, ``sb[k]``; ``x``: the chi-square, or where ``src`` is 1 the
    normalised innovation or rival margin ``z``), the last zeros noted.  Returns the
    largest statistic so far of the sample (``top``)."""
    for si in range(df.shape[1]):
        x = sa[k, si] + sb[k, si] * (chi if src[si] == 0 else z)
        dv = cusum_step(df[u, si], x)
        df[u, si] = dv
        # selects, not branches: a branch on the step's result that the processor
        # mispredicts holds the next instance's step until this one has finished, which
        # serialises the instances' dependent chains
        last = lz[u, si]
        lz[u, si] = tt if dv == 0.0 else last
        top = dv if dv > top else top
    return top


@numba.njit(cache=True)
def _event_fits(cfg, st, ev, t, deg, maxk):  # pragma: no cover - compiled
    """Whether the arrays hold the event at ``t``: its crossed tests and ended transient
    paths bound its candidates (each alarm at most the graph's out-degree ``deg``, each
    candidate at most ``maxk`` instances)."""
    cnt, udf, thr = st.counters, st.unit_df, cfg.threshold
    pnode, pstart, tmax = st.path_node, st.path_start, cfg.max_duration
    nP, nU = cnt[C_P], cnt[C_U]
    nA = 0
    for u in range(nU):
        for si in range(udf.shape[1]):
            if udf[u, si] > thr:
                nA += 1
    for p in range(nP):
        tm = tmax[pnode[p]]
        if tm > 0 and t - pstart[p] >= tm:
            nA += 1
    nC = nA * deg
    return (nP + nC <= st.path_id.shape[0] and nU + nC * maxk <= st.unit_path.shape[0]
            and cnt[C_SLOTS] + max(nC - cnt[C_FREE], 0) <= st.hist.shape[1]
            and cnt[C_SEG] + nC <= st.seg_node.shape[0]
            and cnt[C_EV] + 1 <= ev.events.shape[0] and cnt[C_AL] + nA <= ev.alarms.shape[0]
            and cnt[C_CAND] + nP + nC <= ev.cand_ll.shape[0]
            and cnt[C_KEEP] + nP + nC <= ev.kept.shape[0]
            and cnt[C_SP] + nC <= ev.spawned.shape[0] and cnt[C_MG] + nC <= ev.merged.shape[0])


@numba.njit(cache=True, inline="always")
def _catch_up_sums(newp, n_new, ccll, inc, ua, ct, pstart, pslot, ha, hr):  # pragma: no cover
    """The catch-up's sample ``ct``: each new path begun by then adds its instances'
    log-likelihoods (``inc`` from instance ``ua``) and writes its history row ``hr``."""
    for i in range(n_new):
        p = newp[i, 0]
        if pstart[p] > ct:
            continue
        cll = ccll[i]
        for u in range(newp[i, 1], newp[i, 2]):
            cll += inc[u - ua]
        ccll[i] = cll
        ha[hr, pslot[p]] = cll


@numba.njit(cache=True, inline="always")
def _path_sums(pll, upath, inc, nP, nU, ha, hr, pslot, gap, tmax, pnode, pstart,
               t, survivors):  # pragma: no cover - compiled
    """After sample ``t``: each path's log-likelihood (6.10) and its history row ``hr``;
    whether a path fell ``gap`` below the best or a transient node reached its longest
    duration (an event besides a crossed test)."""
    event = False
    for u in range(nU):
        pll[upath[u]] += inc[u]
    best = -np.inf
    for p in range(nP):
        if pll[p] > best:
            best = pll[p]
    for p in range(nP):
        ha[hr, pslot[p]] = pll[p]
        if gap_drops(pll, pnode, nP, p, best, gap, survivors):
            event = True
        tm = tmax[pnode[p]]
        if tm > 0 and t - pstart[p] >= tm:
            event = True
    return event


@numba.njit(cache=True)
def run_core(t_from, t_to, t_out, cfg, st, ev, nprob, mapn, pending):  # pragma: no cover
    """Samples ``t_from .. t_to - 1`` (global indices; ``nprob``/``mapn`` rows from
    ``t_out``).  Returns ``(status, t)``: :data:`OK` and ``t_to``, or :data:`FULL` and
    the sample whose event did not fit the arrays (:func:`_event_fits`: every crossed test
    with its own change time, every successor new); the caller grows them and resumes at
    ``t`` with ``pending`` (the sample itself is done, its event is not).  ``cfg``,
    ``st``, ``ev``: :class:`CoreConfig`, :class:`CoreState`, :class:`CoreEvents`.

    One loop advances either every instance by the current sample or, after an event,
    the instances of the new paths begun by the catch-up sample (their detectors run, no
    thresholding).  Per sample: every instance by :func:`_filter_step` or
    :func:`_direct_score` and its detector row (:func:`_detectors`); then the catch-up's
    sums or the paths' (6.10) and at an event
    :func:`_spawn`, the catch-up and :func:`_prune`; then the node probabilities.
    """
    mi, mf, mp, sa, sb, ssrc = (cfg.model_info, cfg.noise_prior_count, cfg.model_params,
                                cfg.side_a, cfg.side_b, cfg.side_src)
    thr, gap, tmax = cfg.threshold, cfg.gap, cfg.max_duration
    upath, umodel, ustart, udf, ulz, ust = (st.unit_path, st.unit_model, st.unit_start,
                                            st.unit_df, st.unit_lz, st.unit_state)
    xa, xbase, ha, hbase, cnt = st.x, st.x_base, st.hist, st.hist_base, st.counters
    pnode, pstart, pslot, pinit, pll = (st.path_node, st.path_start, st.path_slot,
                                        st.path_init, st.path_ll)
    n_units, n_paths = upath.shape[0], pll.shape[0]
    inc = np.empty(n_units)                   # per-instance log-likelihood increments
    newp = np.empty((n_paths, 3), np.int64)   # an event's new paths: path, instances
    wp = np.empty(n_paths)                    # path weights of a sample
    ccll = np.empty(n_paths)                  # the new paths' log-likelihoods in the catch-up
    K = cfg.log_t.shape[1]
    qmax = cfg.q_max
    sc = _step_scratch(qmax)
    wk = np.empty(CONSTRAINT_SCRATCH)         # the direct steps' scratch
    # a stateless model's score of sample vt[k] (computed once for all its instances)
    vt = np.full(mi.shape[0], -1 << 62, np.int64)
    vll = np.empty(mi.shape[0])
    vchi = np.empty(mi.shape[0])
    vz = np.empty(mi.shape[0])
    direct, maxk, deg = _graph_bounds(cfg)
    scr = _event_scratch(n_units, n_paths, udf.shape[1], deg)
    t = t_from
    catch = False            # catching up the new paths of an event
    n_new = 0
    ct = 0                   # the catch-up's sample
    nP, nU = 0, 0
    while True:
        if not catch:
            if t >= t_to:
                break
            nP, nU = cnt[C_P], cnt[C_U]
            ua, ub, tt = 0, (0 if pending else nU), t
        else:
            ua, ub, tt = newp[0, 1], newp[n_new - 1, 2], ct
        row = tt - xbase
        top = 0.0
        for u in range(ua, ub):
            if catch and ustart[u] > tt:
                continue                        # a new instance not yet begun
            k = umodel[u]
            if mi[k, MI_REG] >= REG_VELOCITY:
                ll, chi, z = _direct_score(mi, mp, xa, ust, u, k, tt, row, vt, vll, vchi, vz,
                                           wk)
            else:
                ll, chi, z = _filter_step(mi, mf, xa, ust, ustart, u, k, tt, row, qmax,
                                          sc)
            top = _detectors(sa, sb, ssrc, udf, ulz, u, k, tt, chi, z, top)
            inc[u - ua] = ll
        if catch:
            _catch_up_sums(newp, n_new, ccll, inc, ua, ct, pstart, pslot, ha, ct + 1 - hbase)
            ct += 1
            if ct <= t:
                continue
            for i in range(n_new):
                pll[newp[i, 0]] = ccll[i]
            catch = False
            _prune(t, cfg, st, ev, scr)
        else:
            # path sums (6.10), history, and the events: a crossing, a path gap below the
            # best, a transient node at its longest duration
            if pending:
                event = True
                pending = False
            else:
                event = _path_sums(pll, upath, inc, nP, nU, ha, t + 1 - hbase, pslot, gap, tmax,
                                   pnode, pstart, t, cfg.survivors) or top > thr
            if event:
                if not _event_fits(cfg, st, ev, t, deg, maxk):
                    return FULL, t
                n_new = _spawn(t, cfg, st, ev, newp, scr)
                if n_new > 0:
                    # the new paths' instances run together over the buffered samples
                    # from the earliest change time (independent filters: their steps
                    # overlap in the processor)
                    catch = True
                    ct = t
                    for i in range(n_new):
                        p = newp[i, 0]
                        ccll[i] = pinit[p]
                        ct = min(ct, pstart[p])
                    continue
                _prune(t, cfg, st, ev, scr)
        # node probabilities (6.5) and the best path's node after sample t
        nP = cnt[C_P]
        best_p = 0
        for p in range(1, nP):
            if pll[p] > pll[best_p]:
                best_p = p
        ro = t - t_out
        for k in range(K):
            nprob[ro, k] = 0.0
        if nP == 1:                             # exp(0) / exp(0)
            nprob[ro, pnode[0]] = 1.0
        else:
            top_ll = pll[best_p]
            tot = 0.0
            for p in range(nP):
                wp[p] = math.exp(pll[p] - top_ll)
                tot += wp[p]
            for p in range(nP):
                nprob[ro, pnode[p]] += wp[p] / tot
        mapn[ro] = pnode[best_p]
        t += 1
    return OK, t_to


def _cap(need: int, have: int) -> int:
    return max(have, 2 * need, 16)


class Core:
    """The arrays of :func:`run_core` for one observer, their growth, and its events.

    ``specs``: each model's :meth:`~contactlab.observer.models.base.FeatureModel.core_spec`
    (in the observer's model order) with its first column in the measurement buffer.
    """

    def __init__(self, *, specs: list[dict], node_kinds: list[list[int]], side_a, side_b,
                 side_src, threshold: float, gap: float, p_keep: float, max_paths: int | None,
                 succ, n_succ, log_t, tmax=None, survivors: bool = False):
        M = len(specs)
        kal = [s for s in specs if s["reg"] < REG_VELOCITY]
        direct = [s for s in specs if s["reg"] >= REG_VELOCITY]
        qmax = max((s["q"] for s in kal), default=1)
        cmax = max((s["channels"] for s in kal), default=1)
        self.qmax, self.cmax = qmax, cmax
        # a directly scored model keeps one state row (channel 0) of its own layout
        self.width = max([state_width(qmax)] + [len(s["prior"]) for s in direct])
        K = len(node_kinds)
        self.K = K
        # each model's prior state row per channel (layout of state_width); its parameter
        # row (directly scored models)
        pst = np.zeros((M, cmax, self.width))
        mp = np.zeros((M, max([1] + [len(s["params"]) for s in direct])))
        oS, oL, oV = qmax, qmax + qmax * qmax, qmax + 2 * qmax * qmax
        for k, s in enumerate(specs):
            if s["reg"] >= REG_VELOCITY:
                pst[k, 0, :len(s["prior"])] = s["prior"]
                mp[k, :len(s["params"])] = s["params"]
                continue
            q, prior = s["q"], s["prior"]
            for c in range(s["channels"]):
                pst[k, c, :q] = prior["theta"][0, c]
                for i in range(q):
                    pst[k, c, oS + i * qmax:oS + i * qmax + q] = prior["S"][0, c, i]
                    pst[k, c, oL + i * qmax:oL + i * qmax + q] = prior["Ls"][0, c, i]
                pst[k, c, oV] = prior["Ve"][0, c, 0, 0]
                pst[k, c, oV + 1] = prior["Lv"][0, c, 0, 0]
                pst[k, c, oV + 2] = prior["vcount"][0, c]
        nk_ptr = np.zeros(K + 1, np.int64)
        for j, ks in enumerate(node_kinds):
            nk_ptr[j + 1] = nk_ptr[j] + len(ks)
        nk_list = np.array([k for ks in node_kinds for k in ks], np.int64)
        self.maxk = max(len(ks) for ks in node_kinds)
        self.deg = max(1, int(np.max(n_succ)))      # the graph's out-degree
        mi = np.array([[s["reg"], s.get("order", 0), int(s.get("mean", False)), s.get("q", 0),
                        s["col"], s["channels"], s.get("mode", 0),
                        int(s.get("estimate_noise", False))] for s in specs], np.int64)
        mf = np.array([s.get("noise_prior_count", 0.0) for s in specs], np.float64)
        # per node, the longest a transient node is held (samples; 0: no limit)
        tmax = np.zeros(K, np.int64) if tmax is None else tmax
        self.cfg = CoreConfig(mi, mf, np.ascontiguousarray(side_a, np.float64),
                    np.ascontiguousarray(side_b, np.float64),
                    np.ascontiguousarray(side_src, np.int64),
                    pst, float(threshold), float(gap), float(p_keep),
                    -1 if max_paths is None else int(max_paths),
                    np.ascontiguousarray(succ, np.int64), np.ascontiguousarray(n_succ, np.int64),
                    np.ascontiguousarray(log_t, np.float64), nk_ptr, nk_list, qmax, mp,
                    np.ascontiguousarray(tmax, np.int64), bool(survivors))
        self.S = len(side_src)
        self._t_event = 0
        self.cnt = np.zeros(N_COUNTERS, np.int64)
        self._acts = None

        self._alloc_paths(16)
        self._alloc_units(32)
        self._alloc_segs(256)
        self._alloc_events(256, 1024, 4096)

    # -- arrays ------------------------------------------------------------------------
    def _alloc_paths(self, n: int) -> None:
        old = getattr(self, "paths_", None)
        new = {"id": np.zeros(n, np.int64), "node": np.zeros(n, np.int64),
               "start": np.zeros(n, np.int64), "slot": np.zeros(n, np.int64),
               "seg": np.zeros(n, np.int64), "init": np.zeros(n), "ll": np.zeros(n),
               "free": np.zeros(n, np.int64)}
        if old is not None:
            for k, v in old.items():
                new[k][:len(v)] = v
        self.paths_ = new

    def _alloc_units(self, n: int) -> None:
        old = getattr(self, "units_", None)
        S, C = self.S, self.cmax
        new = {"path": np.zeros(n, np.int64), "model": np.zeros(n, np.int64),
               "start": np.zeros(n, np.int64), "df": np.zeros((n, S)),
               "lz": np.zeros((n, S), np.int64), "st": np.zeros((n, C, self.width))}
        if old is not None:
            for k, v in old.items():
                new[k][:len(v)] = v
        self.units_ = new

    def _alloc_segs(self, n: int) -> None:
        old = getattr(self, "segs_", None)
        new = {"node": np.zeros(n, np.int64), "start": np.zeros(n, np.int64),
               "prev": np.full(n, -1, np.int64)}
        if old is not None:
            for k, v in old.items():
                new[k][:len(v)] = v
        self.segs_ = new

    def _alloc_events(self, n_ev: int, n_al: int, n_ll: int) -> None:
        self.ev = CoreEvents(np.zeros((n_ev, N_EV_COLS), np.int64), np.zeros((n_al, 4), np.int64),
                   np.zeros(n_ll), np.zeros(n_ll, np.int64), np.zeros((n_al, 2), np.int64),
                   np.zeros((n_al, 2), np.int64))

    def ensure_room(self, hist) -> None:
        """Grow the arrays for the event pending at the sample :func:`run_core` stopped at."""
        c = self.cnt
        nP, nU = int(c[C_P]), int(c[C_U])
        nA = int((self.units_["df"][:nU] > self.cfg.threshold).sum())
        tmax = self.cfg.max_duration[self.paths_["node"][:nP]]
        nA += int(((tmax > 0) & (self._t_event - self.paths_["start"][:nP] >= tmax)).sum())
        nC = nA * self.deg
        if nP + nC > len(self.paths_["id"]):
            self._alloc_paths(_cap(nP + nC, 0))
        if nU + nC * self.maxk > len(self.units_["path"]):
            self._alloc_units(_cap(nU + nC * self.maxk, 0))
        if c[C_SEG] + nC > len(self.segs_["node"]):
            self._compact_segs()
            if c[C_SEG] + nC > len(self.segs_["node"]):
                self._alloc_segs(_cap(int(c[C_SEG]) + nC, 0))
        ev = self.ev
        if nA > len(ev[1]) or nC > len(ev[4]) or nP + nC > len(ev[2]):
            self._alloc_events(len(ev[0]), _cap(max(nA, nC), len(ev[1])),
                               _cap(nP + nC, len(ev[2])))
        new_slots = max(nC - int(c[C_FREE]), 0)          # the freed slots are taken first
        if int(c[C_SLOTS]) + new_slots > hist.width:
            hist.widen(_cap(int(c[C_SLOTS]) + new_slots, 0))

    def _compact_segs(self) -> None:
        """Keep only the segments the active paths' histories reach, renumbered."""
        n_seg = int(self.cnt[C_SEG])
        nP = int(self.cnt[C_P])
        new_seg, n_new = _compact(self.segs_["node"], self.segs_["start"], self.segs_["prev"],
                                  self.paths_["seg"][:nP], n_seg)
        self.paths_["seg"][:nP] = new_seg
        self.cnt[C_SEG] = n_new

    def state(self, xbuf, hist, act) -> tuple:
        """The state tuple of :func:`run_core` (buffers: storage and global row of its first
        row)."""
        p, u, s = self.paths_, self.units_, self.segs_
        if self._acts is None or self._acts.base is not act.a:
            self._acts = act.a[:, 0]
        return CoreState(u["path"], u["model"], u["start"], u["df"], u["lz"], u["st"], xbuf.a,
                xbuf.t0 - xbuf.off, hist.a, hist.t0 - hist.off, self.cnt, p["id"], p["node"],
                p["start"], p["slot"], p["seg"], p["init"], p["ll"], p["free"], self._acts,
                act.t0 - act.off, s["node"], s["start"], s["prev"])

    # -- paths -------------------------------------------------------------------------
    def add_path(self, pid: int, node: int, start: int, init: float, slot: int,
                 kinds: list[int], lz: int) -> None:
        """An initial path (6.4, initialisation) with fresh instances of ``kinds``."""
        c = self.cnt
        if c[C_P] + 1 > len(self.paths_["id"]):
            self._alloc_paths(_cap(int(c[C_P]) + 1, 0))
        if c[C_U] + len(kinds) > len(self.units_["path"]):
            self._alloc_units(_cap(int(c[C_U]) + len(kinds), 0))
        if c[C_SEG] + 1 > len(self.segs_["node"]):
            self._alloc_segs(_cap(int(c[C_SEG]) + 1, 0))
        i = int(c[C_P])
        p = self.paths_
        p["id"][i], p["node"][i], p["start"][i], p["slot"][i] = pid, node, start, slot
        p["init"][i] = p["ll"][i] = init
        g = int(c[C_SEG])
        self.segs_["node"][g], self.segs_["start"][g], self.segs_["prev"][g] = node, start, -1
        p["seg"][i] = g
        c[C_SEG] += 1
        c[C_P] += 1
        c[C_ID] = max(int(c[C_ID]), pid + 1)
        c[C_SLOTS] = max(int(c[C_SLOTS]), slot + 1)
        for k in kinds:
            u = self.units_
            _init_unit(int(c[C_U]), i, k, start, lz, self.cfg.prior_state, u["path"], u["model"],
                       u["start"], u["df"], u["lz"], u["st"])
            c[C_U] += 1

    def history(self, seg: int) -> list[tuple[int, int]]:
        s = self.segs_
        out = []
        while seg >= 0:
            out.append((int(s["node"][seg]), int(s["start"][seg])))
            seg = int(s["prev"][seg])
        return out[::-1]

    def min_last_zero(self) -> int | None:
        nU = int(self.cnt[C_U])
        return int(self.units_["lz"][:nU].min()) if nU else None

    # -- running -------------------------------------------------------------------------
    def run(self, t_from: int, t_to: int, t_out: int, xbuf, hist, act, node_prob, map_node,
            make_events) -> None:
        """Samples ``t_from .. t_to - 1``; ``make_events(tables)`` turns each batch of event
        rows into records."""
        t = t_from
        pending = False
        while t < t_to:
            if pending:
                self.ensure_room(hist)
            status, t = run_core(t, t_to, t_out, self.cfg, self.state(xbuf, hist, act), self.ev,
                                 node_prob, map_node,
                                 pending)
            c = self.cnt
            if c[C_EV]:
                ev = self.ev
                make_events(ev[0][:c[C_EV]], ev[1][:c[C_AL]], ev[2][:c[C_CAND]],
                            ev[3][:c[C_KEEP]], ev[4][:c[C_SP]], ev[5][:c[C_MG]])
            c[C_EV:] = 0
            pending = status == FULL
            self._t_event = t


@numba.njit(cache=True)
def _compact(snode, sstart, sprev, pseg, n_seg):  # pragma: no cover - compiled
    """Renumber the segments reachable from ``pseg`` to the front (order kept)."""
    mark = np.zeros(n_seg, np.bool_)
    for p in range(pseg.shape[0]):
        g = pseg[p]
        while g >= 0 and not mark[g]:
            mark[g] = True
            g = sprev[g]
    new = np.full(n_seg, -1, np.int64)
    n = 0
    for g in range(n_seg):
        if mark[g]:
            new[g] = n
            snode[n] = snode[g]
            sstart[n] = sstart[g]
            sprev[n] = new[sprev[g]] if sprev[g] >= 0 else -1
            n += 1
    out = np.empty(pseg.shape[0], np.int64)
    for p in range(pseg.shape[0]):
        out[p] = new[pseg[p]]
    return out, n
