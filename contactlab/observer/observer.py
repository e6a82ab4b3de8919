"""The contact feature observer of section 6.4 (figures 1.3, 6.1).

One module on purpose: the observer of 6.4 -- path
search, change-triggered spawning with catch-up, merging, probability-mass and gap
pruning, buffer trimming -- is one algorithm over one shared mutable state; split
across modules its invariants would have to be read in several places.

Per active path: an estimator instance for each model of its node and
Page-Hinkley detectors (6.15-6.18, threshold ``T^2``, change size ``q``) on
each instance's innovations; the path log-likelihood is ``log pi(0)`` plus the
sum of the per-sample log-likelihoods (6.10).  When a detector crosses, the
path spawns one successor per node the graph allows (its own node too, if it
self-transitions: a new draw of the parameters, 6.1), started at the
estimated change time (the detector's last zero + 1, the maximiser of 6.15)
with the log-likelihood, just before it, of the best tracked path that may
go to that node, and caught up on the buffered measurements.  A successor whose (node, start) is already tracked replaces the
tracked path only if its initial log-likelihood is higher (the maximisation
of 6.4, step 2; the later increments of the two are identical).  Then the
paths are ranked and kept until their probability mass reaches ``P_prune``.
Paths whose log-likelihood falls more than ``gap`` below the best are
dropped at every sample (9.1.1, gap 20).  The measurement and
log-likelihood buffers are trimmed to the earliest change time any detector
could still report.  Node probabilities are sums of path probabilities (6.5).

Processing is incremental: :meth:`Observer.update` takes a chunk of any
length (one sample from a live source, or a whole trace), and any split of a
stream into chunks gives identical results.

Two forms run it.  When every model runs in the compiled core
(:meth:`FeatureModel.core_spec`: the temporal and impact models as Kalman filters
whose regressors the core forms itself, the constraint and velocity models of
9.1's triples by their compiled steps), all of the above -- per sample the
models' steps, detectors and path sums, per event the alarms, candidates,
maximisation, catch-up and pruning -- runs in :mod:`contactlab.observer.engine`'s
compiled loop over flat arrays, and an event costs microseconds.  Otherwise (a
model with only a ``run``) the general form below runs the models through their
``run``; the two give the same events, paths and path log-likelihoods (tests
compare them).  Both take an event's decisions -- the alarms, the candidates and their
best predecessors, the pruning's kept set -- from one place,
:mod:`contactlab.observer.events`, and apply them to their own paths.

In the general form, models whose instances advance by
the same arithmetic from their own state (equal
:meth:`~contactlab.observer.models.base.FeatureModel.batch_key`, e.g. AR
models of one order and structure) share one bank.  Within a chunk every bank
runs all its instances over a window of the chunk in one vectorised call, and the
successors one event spawns are caught up to the event in one call per bank and
start time (only those that survive the pruning run on to the window's end, one
call per bank); the detectors and path sums then advance in a compiled loop that
stops at the first event (a detector crossing or a gap prune), which is handled in
Python before the loop resumes.  An event involves a handful of paths, so its
bookkeeping (best predecessors, unit and bank rows) is done in plain lists.

Choices where 6.4 is silent or where we extend it (also in the report; each
measured on the switching suite of ``benchmarks/bench_observer.py``):

* Detector tests (``sides``, default ``"mean"``): the covariance increase of
  6.14 plus a two-sided change of the normalised innovation's mean,
  ``Xi = +-delta z - delta^2 / 2`` with ``z = sum_c alpha_c / sqrt(C)`` and
  ``delta = sqrt(q - 1)`` (one innovation sd at the thesis's q = 2, 7.3.1's
  reading of q).  6.3.1 says the covariance alternative "seems to suffice" and
  points to direction-estimating tests for more sensitivity: a level change of
  y_h moves the innovation's mean by about one sd, which the covariance test
  accumulates at ~0.15 a sample while the estimator absorbs the shift into its
  parameters (then no test fires again).  ``"increase"`` keeps the thesis's test.
* Every test that crosses is a detected change with its own change time (6.4:
  "for every model in which a change is detected"); at a level jump several
  cross, and the one with the largest statistic may date from an old
  excursion, so each distinct estimate spawns.
* A successor ``(j, r)`` starts from the best tracked path into it: the highest
  path log-likelihood after ``r - 1`` among tracked paths started before ``r``
  whose node may go to ``j`` (the maximisation over an instance's predecessors,
  6.1/6.5; every instance explains at least one sample, fig 6.2), not only the
  spawning path's: each path's detector places the
  change differently, and at an impact one misplaced sample costs tens of nats.

* Before the first ``lag`` samples (the largest AR order) no model can
  predict; those samples are buffered and not scored.
* A successor's detector also runs over its catch-up samples (its statistic
  starts at the change time); a crossing during catch-up fires at the next
  sample.
* Only the detector that fired is reset (6.4, step 4: "the change test
  statistic for the spawning model").
* With an action-dependent graph, the edges active at the estimated change
  time are used.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numba
import numpy as np

from contactlab import defaults as D
from contactlab.detection.cusum import all_finite, cusum_step
from contactlab.observer.engine import Core
from contactlab.observer.events import best_candidates, collect_alarms, gap_drops, keep_set
from contactlab.observer.graph import FeatureGraph
from contactlab.observer.models.base import FeatureModel, ModelBank
from contactlab.observer.models.composite import node_models
from contactlab.observer.paths import (ChangeEvent, EventLog, PathInfo, RowBuffer, Segment,
                                      history)

__all__ = ["Observer", "ObserverStep", "ObserverResult", "observe", "labels_from_path"]

#: the detector tests per model instance, by ``sides``: the covariance tests of 6.14
#: (``increase``: ``q V``, the thesis's; ``decrease``: ``V / q``) and the mean tests
#: (``up``/``down``: the normalised innovation's mean moves by ``+-sqrt(q - 1)``)
SIDE_TESTS = {"increase": ("increase",), "both": ("increase", "decrease"),
              "mean": ("increase", "up", "down"), "all": ("increase", "decrease", "up", "down")}
SIDES = D.OBSERVER_SIDE_CHOICES
#: how transitions weigh a successor's start (:class:`Observer` ``transitions``)
TRANSITIONS = D.OBSERVER_TRANSITION_CHOICES
#: samples the model banks advance at a time within a chunk: the new paths that survive
#: an event's pruning run to the end of its window, so events cost O(WINDOW) (results do
#: not depend on it up to the rounding of the node-probability sums)
WINDOW = 128
assert set(SIDES) == set(SIDE_TESTS)


@numba.njit(cache=True, inline="always")
def _detector_row(df, last_zero, x, t):  # pragma: no cover
    """One sample of every detector side (6.18, :func:`contactlab.detection.cusum_step`), noting the
    last zero at ``t``; returns the largest statistic."""
    U, S = df.shape
    top = 0.0
    for u in range(U):
        for s in range(S):
            df[u, s] = cusum_step(df[u, s], x[u, s])
            if df[u, s] == 0.0:
                last_zero[u, s] = t
            if df[u, s] > top:
                top = df[u, s]
    return top


@numba.njit(cache=True)
def _advance(inc, xi, unit_path, df, last_zero, thr, path_ll, trace, t0, gap, p_start,
             p_tmax, p_node, survivors):  # pragma: no cover
    """Advance detectors (6.18) and path sums from row 0; stop at the first event.

    Returns the row of the first event (a crossing, a path ``gap`` below the
    best that the pruning would drop, :func:`~contactlab.observer.events.gap_drops` with
    the paths' nodes ``p_node``, or a transient path held ``p_tmax`` samples since
    ``p_start``) after
    completing it, or ``n`` if none.  ``trace[i, p]`` receives the path
    log-likelihoods after row i.
    """
    n, U, S = xi.shape
    P = path_ll.shape[0]
    for i in range(n):
        event = _detector_row(df, last_zero, xi[i], t0 + i) > thr
        for u in range(U):
            path_ll[unit_path[u]] += inc[i, u]
        best = -np.inf
        for p in range(P):
            if path_ll[p] > best:
                best = path_ll[p]
        for p in range(P):
            trace[i, p] = path_ll[p]
            if gap_drops(path_ll, p_node, P, p, best, gap, survivors):
                event = True
            if p_tmax[p] > 0 and t0 + i - p_start[p] >= p_tmax[p]:
                event = True
        if event:
            return i
    return n


@numba.njit(cache=True)
def _catch_up(inc, stat, kinds, a, b, src, unit_path, ll0, t_first):  # pragma: no cover
    """New paths' log-likelihood trajectories and detector states over their catch-up rows.

    ``inc`` (n, U) and ``stat`` (n, U, 2) of units of model kinds ``kinds`` (U,) and
    paths ``unit_path`` (U,) started at ``t_first`` with initial log-likelihoods ``ll0``
    (P,).  Same arithmetic and order as :func:`_increments` then :func:`_advance` (no
    thresholding).
    """
    n, k = inc.shape
    S = src.shape[0]
    P = ll0.shape[0]
    traj = np.empty((n, P))
    df = np.zeros((k, S))
    lz = np.full((k, S), t_first - 1, dtype=np.int64)
    ll = ll0.copy()
    x = np.empty((k, S))
    for i in range(n):
        for u in range(k):
            for s in range(S):
                x[u, s] = a[kinds[u], s] + b[kinds[u], s] * stat[i, u, src[s]]
        _detector_row(df, lz, x, t_first + i)
        for u in range(k):
            ll[unit_path[u]] += inc[i, u]
        for p in range(P):
            traj[i, p] = ll[p]
    return traj, df, lz


@numba.njit(cache=True)
def _increments(stat, kinds, a, b, src):  # pragma: no cover
    """(N, U, S) detector increments ``a[k, s] + b[k, s] * stat[n, u, src[s]]`` of the
    units of model kinds ``kinds`` (the tables of :meth:`Observer._side_tables`)."""
    N, U = stat.shape[0], stat.shape[1]
    S = src.shape[0]
    out = np.empty((N, U, S))
    for n in range(N):
        for u in range(U):
            k = kinds[u]
            for s in range(S):
                out[n, u, s] = a[k, s] + b[k, s] * stat[n, u, src[s]]
    return out


def _with_rivals(graph: FeatureGraph, models: dict) -> dict:
    """``models`` with each Gaussian model given the Gaussian models (on its signal) of
    the nodes that may follow a node it belongs to, under any action: the alternatives of
    its ``rival`` test (:class:`~contactlab.observer.models.gaussian.GaussianFeature`)."""
    from contactlab.observer.models.gaussian import GaussianFeature

    if not any(isinstance(m, GaussianFeature) for m in models.values()):
        return models
    rivals: dict = {}
    for i, node in enumerate(graph.nodes):
        follow = set()
        for a in (None,) + tuple(graph.actions):
            follow.update(j for j in graph.successors(i, a) if j != i)
        for _, name in node.models:
            if isinstance(models[name], GaussianFeature):
                rivals.setdefault(name, [])
                for j in sorted(follow):
                    for _, other in graph.nodes[j].models:
                        r = models[other]
                        if (other != name and isinstance(r, GaussianFeature)
                                and r.signal == models[name].signal
                                and other not in rivals[name]):
                            rivals[name].append(other)
    return {k: (m.with_rivals([models[r] for r in rivals[k]]) if rivals.get(k) else m)
            for k, m in models.items()}


def _mixture(ll: np.ndarray, nodes: np.ndarray, M: np.ndarray):
    """(rows, K) node probabilities (6.5: sums of the paths' probabilities, ``M`` the (P, K)
    one-hot node matrix) and (rows,) MAP node from (rows, P) path log-likelihoods."""
    w = np.exp(ll - ll.max(axis=1, keepdims=True))
    w /= w.sum(axis=1, keepdims=True)
    return w @ M, nodes[np.argmax(ll, axis=1)]


@dataclass(eq=False)
class _Path:
    id: int
    node: int
    start: int
    init: float            # initial path log-likelihood (at start - 1)
    seg: Segment
    slot: int              # column in the log-likelihood history


@dataclass(frozen=True)
class ObserverStep:
    """What :meth:`Observer.update` returns for one chunk.

    t0 : global index of the chunk's first sample.
    node_prob : (n, K) node probabilities after each sample (6.5).
    map_node : (n,) node of the most probable path after each sample.
    events : changes detected / pruning steps during the chunk.
    """

    t0: int
    node_prob: np.ndarray
    map_node: np.ndarray
    events: list = field(default_factory=list)


@dataclass(frozen=True)
class ObserverResult:
    """A whole trace: per-sample arrays, the events, and the final paths.

    Attributes
    ----------
    map_path : ``[(node name, start sample), ...]`` of the most probable path at
        the end (the MAP path with its event times).
    labels : (n,) node index per sample along ``map_path`` (retrospective).
    events : the run's :class:`~contactlab.observer.paths.ChangeEvent` records, a
        sequence whose records are made when read.
    """

    node_names: tuple[str, ...]
    node_prob: np.ndarray
    map_node: np.ndarray
    events: Sequence
    map_path: list
    labels: np.ndarray
    paths: list

    def to_dict(self, *, rate_hz: float | None = None) -> dict:
        scale = (1.0 / rate_hz) if rate_hz else 1.0
        return {"nodes": list(self.node_names),
                "path": [[n, s * scale] for n, s in self.map_path],
                "events": [e.to_dict() for e in self.events if e.model is not None]}


class Observer:
    """Contact-state observer over a feature graph (6.4).

    Parameters
    ----------
    graph : the :class:`~contactlab.observer.graph.FeatureGraph`.
    models : model objects by the names the graph declares
        (:func:`~contactlab.observer.models.build_models`).
    threshold : ``T^2``, the detectors' decision threshold (6.16); 7.3.1 uses 8.0.
    change_size : ``q``, the covariance change of the alternative (6.14); 7.3.1 uses 2.0.
    p_prune : probability mass kept when pruning (``P_prune``, 6.4).
    gap : drop paths whose log-likelihood is more than this below the best (9.1.1: 20.0).
    sides : the detector tests (:data:`SIDE_TESTS`): ``"increase"`` (the thesis's test
        for ``N(0, qV)``), ``"both"`` (also a decrease to ``V/q``), ``"mean"`` (the
        increase plus a two-sided change of the normalised innovation's mean by
        ``sqrt(q - 1)``; the default, best on the switching suite) or ``"all"``.
    max_paths : the beam width: at most this many paths kept after an event's pruning,
        the most probable (:data:`contactlab.defaults.OBSERVER_MAX_PATHS`; None: no cap,
        as in 6.4).
    initial : optional initial probabilities replacing the graph's ((K,) or {name: p}).
    transient_max : the longest a path stays in a transient node (samples; a mapping
        gives it per node name, nodes it leaves out have no limit), or None (no
        limit, as in 6.4).  A path held that long ends there: the samples after it go to
        fresh successors of every other node the graph allows (started at the end of the
        duration from their best predecessor, as for a detected change) and the transient
        path is dropped.  The limit is per segment: a detected change on the transient
        path may still restart it (a second impact; on the switching suite forbidding
        that cost 3 points).  An impact (5.1) is a transition feature of finite duration; a
        decay model whose level the estimator can track would otherwise hold a later
        contact indefinitely.
    transitions : ``"graph"`` (default): where the graph's edge set for the current action
        carries transition probabilities (a forward projection's counts, 5.3.5, or EM's,
        10.1.3), a successor starts from its predecessor's log-likelihood plus
        ``log p(i -> j | a)``; ``"none"``: every allowed transition is free, as in 6.4
        (the thesis had no probabilities, 6.2).  Graphs without probabilities are the same
        either way.
    change_prior : per node name, the probability per sample of a change out of it (the
        rate of its labelled changes in training, :func:`~contactlab.observer.recognize.change_priors`),
        or None.  Where the graph's edge set carries no probabilities and its
        ``change_prior`` is ``"trained"``, a change out of node i to any of its R_i
        other successors costs ``log(h_i / R_i)``: the supervised HMM's transition
        matrix with the graph's edges split evenly (a restart is free, as with edge
        probabilities).  Without it a change of
        models with fixed trained parameters is free, so two that overlap trade the lead
        at every alarm (the thesis's models re-estimate their parameters at each start,
        whose prior predictive already pays for a change; its graphs say ``"none"``).
        Nodes missing from the mapping change freely.
    rate_hz : the rate the data were recorded at (Hz), or None.  Given, each Gaussian
        model weighs a sample by the share of an independent one it carries at that rate
        (:func:`~contactlab.observer.models.gaussian.rate_weighted`); None: every sample
        counts fully, as the models came.

    State: ``n_seen_`` samples processed; ``events_`` all events so far (an
    :class:`~contactlab.observer.paths.EventLog`);
    ``buffer_len_`` samples in the measurement buffer; :meth:`paths` the
    active paths; :meth:`map_path` the best path's history.
    """

    def __init__(self, graph: FeatureGraph, models: Mapping[str, FeatureModel], *,
                 threshold: float = D.OBSERVER_THRESHOLD,
                 change_size: float = D.OBSERVER_CHANGE_SIZE, p_prune: float = D.OBSERVER_PRUNE,
                 gap: float = D.OBSERVER_GAP, sides: str = D.OBSERVER_SIDES,
                 max_paths: int | None = D.OBSERVER_MAX_PATHS,
                 initial=None, transitions: str = D.OBSERVER_TRANSITIONS,
                 transient_max: "int | Mapping[str, int] | None" = None,
                 change_prior: "Mapping[str, float] | None" = None,
                 rate_hz: float | None = None):
        if not (threshold > 0 and math.isfinite(threshold)):
            raise ValueError(f"threshold (T^2) must be a finite number > 0; got {threshold!r}")
        if not change_size > 1:
            raise ValueError(f"change_size (q) must be > 1; got {change_size!r}")
        if not 0 < p_prune <= 1:
            raise ValueError(f"p_prune must be in (0, 1]; got {p_prune!r}")
        if not gap > 0:
            raise ValueError(f"gap must be > 0 (math.inf disables it); got {gap!r}")
        if sides not in SIDES:
            raise ValueError(f"sides must be one of {SIDES}; got {sides!r}")
        if max_paths is not None and int(max_paths) < 1:
            raise ValueError(f"max_paths must be >= 1; got {max_paths!r}")
        if transitions not in TRANSITIONS:
            raise ValueError(f"transitions must be one of {TRANSITIONS}; got {transitions!r}")
        limits = (dict(transient_max) if isinstance(transient_max, Mapping)
                  else None if transient_max is None else {None: transient_max})
        for v in (limits or {}).values():
            if int(v) < 1:
                raise ValueError(f"transient_max must be >= 1 sample; got {transient_max!r}")
        self.transitions = transitions
        self.graph = graph if initial is None else graph.with_initial(initial)
        prior = dict(change_prior or {})
        for k, v in prior.items():
            if k not in self.graph.node_names:
                raise ValueError(f"change_prior names {k!r}, not a node of the graph")
            if not 0 < v < 1:
                raise ValueError(f"change_prior[{k!r}] must be a probability in (0, 1); got {v!r}")
        #: per node, the probability per sample of a change out of it (used where the
        #: graph's edges carry no probabilities and its ``change_prior`` is "trained")
        self.change_prior = (prior if self.graph.trained_change_prior and transitions == "graph"
                             else {})
        unknown = [k for k in (limits or {}) if k is not None and k not in self.graph.node_names]
        if unknown:
            raise ValueError(f"transient_max names {unknown[0]!r}, not a node of the graph")
        self.transient_max = (None if limits is None else int(limits[None]) if None in limits
                              else {k: int(v) for k, v in limits.items()})
        #: per node, the longest a transient node is held (samples; 0: no limit)
        self._tmax = np.array([int((limits or {}).get(n.name, (limits or {}).get(None, 0)))
                               if n.transient else 0 for n in self.graph.nodes], dtype=np.int64)
        models = {name: models[name] for name in self.graph.models}
        if rate_hz is not None:
            from contactlab.observer.models.gaussian import rate_weighted

            models = rate_weighted(models, float(rate_hz))
        models = _with_rivals(self.graph, models)
        self.nodes = node_models(self.graph, models)
        self.models = models
        self.threshold = float(threshold)
        self.change_size = float(change_size)
        self.p_prune = float(p_prune)
        self.gap = float(gap)
        #: keep, beside the pruning's set, the best path ending in each node (a Viterbi
        #: survivor per node) where the graph asks for it (``survivors``, as graphs learned
        #: from labels do) and its changes carry probabilities: a change then costs its
        #: prior, and a node whose path fell behind while its model fitted poorly (a
        #: phase's first samples through the lowpass) takes the lead back when its
        #: evidence comes (our choice; without costs, survivors of overlapping models
        #: trade the lead sample by sample, and on a graph of hundreds of nodes each keeps
        #: alarming)
        self.survivors = bool(self.graph.survivors and self.graph.edge_probabilities)
        self.sides = sides
        #: the detector tests run: those of ``sides``, and Page's test against the known
        #: successors (``rival``) where a model has rivals
        self.tests_ = SIDE_TESTS[sides] + (
            ("rival",) if any("rival" in (m.tests or ()) for m in self.models.values())
            else ())
        self.max_paths = None if max_paths is None else int(max_paths)
        self.lag = max(m.lag for m in self.models.values())
        self.signals = tuple(sorted({m.signal for m in self.models.values()}))
        self._model_names = list(self.models)
        #: model indices (into ``_model_names``) of each node's models
        self._node_kinds = [[self._model_names.index(m.name) for m in self.nodes[j].models]
                            for j in range(self.graph.n_nodes)]
        #: models whose instances may share one run (:meth:`FeatureModel.batch_key`)
        self._batch_of = [(k,) if m.batch_key() is None else m.batch_key()
                          for k, m in enumerate(self.models.values())]
        self._membership = np.zeros((0, self.graph.n_nodes))
        self._succ: dict = {}
        self._log_edge: dict = {}
        self.reset()

    # -- state -----------------------------------------------------------------------
    def reset(self) -> "Observer":
        """Start over (6.4, initialisation steps 1-6)."""
        self.n_seen_ = 0
        self.events_ = EventLog(self.graph.node_names, self._model_names)
        self._started = False
        self._core = None
        self._next_id = 0
        self._paths: list[_Path] = []
        self._arrays = None                     # cached arrays of _paths (_path_arrays)
        self._free_slots: list[int] = []
        self._n_slots = 0
        init = self.graph.initial
        order = np.argsort(-init, kind="stable")
        mass = 0.0
        L = self.lag
        self._hist = RowBuffer(1, t0=L)           # row t+1: path log-likelihoods after sample t
        self._hist.extend_to(L + 1)
        for k in order:                         # steps 2-3: largest first until mass > P_prune
            if init[k] <= 0:
                break
            p = self._new_path(int(k), 0, math.log(init[k]), None)
            self._hist.widen(self._n_slots)
            self._hist.rows(L, L + 1)[0, p.slot] = p.init
            mass += init[k]
            if mass > self.p_prune:
                break
        self._ll = np.array([p.init for p in self._paths])
        return self

    def _new_path(self, node: int, start: int, init: float, prev: Segment | None) -> _Path:
        slot = self._free_slots.pop() if self._free_slots else self._n_slots
        if slot == self._n_slots:
            self._n_slots += 1
        p = _Path(self._next_id, node, start, init, Segment(node, start, prev), slot)
        self._next_id += 1
        self._paths.append(p)
        self._arrays = None
        return p

    def _path_arrays(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(P,) node and history slot of the active paths, and the (P, K) one-hot node matrix."""
        if self._arrays is None:
            nodes = np.array([p.node for p in self._paths], dtype=np.int64)
            M = np.zeros((len(nodes), self.graph.n_nodes))
            M[np.arange(len(nodes)), nodes] = 1.0
            self._arrays = (nodes, np.array([p.slot for p in self._paths], dtype=np.int64), M)
        return self._arrays

    def _start(self, data: dict[str, np.ndarray]) -> None:
        """First data: channel counts are known; build the banks and the initial instances
        (or the compiled core, :meth:`_start_core`)."""
        S = len(self.tests_)
        self._channels = {s: data[s].shape[1] for s in self.signals}
        self._core = None
        if self._start_core():
            return
        # one bank per batch of models (equal ``batch_key``): their instances advance in one run
        self._banks: list[ModelBank] = []
        first: dict = {}
        bank_of = []
        for k, (name, m) in enumerate(self.models.items()):
            try:
                if self._batch_of[k] in first:
                    m.check_channels(self._channels[m.signal])
                else:
                    first[self._batch_of[k]] = len(self._banks)
                    self._banks.append(ModelBank(m, self._channels[m.signal]))
            except ValueError as exc:
                raise ValueError(f"model {name!r}: {exc}") from None
            bank_of.append(first[self._batch_of[k]])
        self._bank_of = np.array(bank_of, dtype=np.int64)          # bank of each model
        self._buf = {s: RowBuffer(self._channels[s], t0=0) for s in self.signals}
        self._act = RowBuffer(1, t0=0, dtype=np.int64)
        self._u_path = np.empty(0, dtype=np.int64)
        self._u_model = np.empty(0, dtype=np.int64)
        self._df = np.zeros((0, S))
        self._lz = np.zeros((0, S), dtype=np.int64)
        ms = [self.models[k] for k in self._model_names]
        self._model_dim = np.array([m.dim(self._channels[m.signal]) for m in ms], dtype=float)
        self._model_q = np.array([m.change_size or self.change_size for m in ms], dtype=float)
        self._side_tables()
        # the prior state of one instance of each model, stacked per bank (``_prior_row[k]``:
        # model k's row in its bank's stack); new instances are rows of it
        self._prior_row = np.zeros(len(ms), dtype=np.int64)
        stacks: list[list] = [[] for _ in self._banks]
        for k, m in enumerate(ms):
            b = bank_of[k]
            self._prior_row[k] = len(stacks[b])
            stacks[b].append(self._banks[b].new(np.zeros(1, dtype=np.int64), model=m)[1])
        self._prior = [{key: np.concatenate([st[key] for st in sts]) for key in sts[0]}
                       for sts in stacks]
        self._prior_cache: dict = {}
        self._bank_list = self._bank_of.tolist()
        self._started = True
        L = self.lag
        for i, p in enumerate(self._paths):
            for k in self._node_kinds[p.node]:
                bank = self._banks[self._bank_of[k]]
                bank.extend(*bank.new([p.start], model=self.models[self._model_names[k]]))
                self._append_units([i], [k],
                                   np.zeros((1, S)), np.full((1, S), L - 1, dtype=np.int64))

    def _start_core(self) -> bool:
        """The compiled core (:mod:`contactlab.observer.engine`) when every model runs in it:
        one measurement buffer of all signals' channels, the initial paths as arrays."""
        specs, col, first = [], 0, {}
        for s in self.signals:
            first[s] = col
            col += self._channels[s]
        for name in self._model_names:
            m = self.models[name]
            try:
                m.check_channels(self._channels[m.signal])
            except ValueError as exc:
                raise ValueError(f"model {name!r}: {exc}") from None
            spec = m.core_spec(self._channels[m.signal])
            if spec is None:
                return False
            specs.append(dict(spec, col=first[m.signal]))
        ms = [self.models[k] for k in self._model_names]
        self._model_dim = np.array([m.dim(self._channels[m.signal]) for m in ms], dtype=float)
        self._model_q = np.array([m.change_size or self.change_size for m in ms], dtype=float)
        self._side_tables()
        succ, n_succ, log_t = self._tables()
        self._core = Core(specs=specs, node_kinds=self._node_kinds, side_a=self._side_a,
                          side_b=self._side_b, side_src=self._side_src,
                          threshold=self.threshold, gap=self.gap,
                          p_keep=self._p_keep(), max_paths=self.max_paths,
                          succ=succ, n_succ=n_succ, log_t=log_t, tmax=self._tmax,
                          survivors=self.survivors)
        self._buf = {"*": RowBuffer(col, t0=0)}
        self._act = RowBuffer(1, t0=0, dtype=np.int64)
        self._started = True
        for p in self._paths:
            self._core.add_path(p.id, p.node, p.start, p.init, p.slot, self._node_kinds[p.node],
                                self.lag - 1)
        self._paths = []
        return True

    def _core_tables(self) -> tuple:
        """Per action code (none first): each node's successors, their count, and
        ``log p(i -> j)`` (:meth:`_log_transition`, ``-inf`` off the edges)."""
        K = self.graph.n_nodes
        codes = [None] + list(range(len(self.graph.actions or ())))
        succ = np.zeros((len(codes), K, K), dtype=np.int64)
        n_succ = np.zeros((len(codes), K), dtype=np.int64)
        log_t = np.full((len(codes), K, K), -np.inf)
        for a1, a in enumerate(codes):
            for i in range(K):
                js = self._successors(i, a)
                n_succ[a1, i] = len(js)
                if js:
                    succ[a1, i, :len(js)] = js
                    log_t[a1, i, list(js)] = [self._log_transition(i, j, a) for j in js]
        return succ, n_succ, log_t

    def _append_units(self, paths, models, df, lz) -> None:
        models = np.asarray(models, dtype=np.int64)
        self._u_path = np.concatenate([self._u_path, np.asarray(paths, dtype=np.int64)])
        self._u_model = np.concatenate([self._u_model, models])
        self._df = np.concatenate([self._df, df])
        self._lz = np.concatenate([self._lz, lz])

    @property
    def buffer_len_(self) -> int:
        """Samples held in the measurement buffer."""
        if not self._started:
            return 0
        return max(len(b) for b in self._buf.values())

    # -- input -----------------------------------------------------------------------
    def _as_chunk(self, chunk) -> tuple[dict[str, np.ndarray], int]:
        if not isinstance(chunk, Mapping):
            if len(self.signals) != 1:
                raise ValueError(f"this graph's models read {list(self.signals)}: pass a dict "
                                 "{signal: array}")
            chunk = {self.signals[0]: chunk}
        out, n = {}, None
        for s in self.signals:
            if s not in chunk:
                raise ValueError(f"chunk has no {s!r} signal (needed by the graph's models)")
            a = np.asarray(chunk[s], dtype=np.float64)
            if a.ndim == 0:
                a = a.reshape(1, 1)
            elif a.ndim == 1:
                a = a[:, None] if (not self._started or self._channels[s] == 1) else a[None, :]
            if a.ndim != 2:
                raise ValueError(f"signal {s!r} must be (n,) or (n, C); got shape {a.shape}")
            if self._started and a.shape[1] != self._channels[s]:
                raise ValueError(f"signal {s!r} has {a.shape[1]} channels; earlier chunks had "
                                 f"{self._channels[s]}")
            if not all_finite(a.reshape(-1)):
                raise ValueError(f"signal {s!r} has NaN or infinite values")
            if n is not None and a.shape[0] != n:
                raise ValueError(f"signals have different lengths ({n} and {a.shape[0]})")
            n = a.shape[0]
            out[s] = a
        return out, n

    def _as_action(self, action, n: int) -> np.ndarray:
        if action is None:
            if self.graph.action_dependent:
                raise ValueError(f"graph {self.graph.name!r} has action-dependent edges: "
                                 "pass action=")
            return np.full(n, -1, dtype=np.int64)
        if isinstance(action, str) or np.ndim(action) == 0:
            return np.full(n, self.graph.action_index(action if isinstance(action, str)
                                                      else int(action)), dtype=np.int64)
        a = np.asarray(action)
        if a.shape != (n,):
            raise ValueError(f"action must be a scalar or one code per sample ({n}); got {a.shape}")
        return a.astype(np.int64)

    # -- processing ------------------------------------------------------------------
    def update(self, chunk, *, action=None) -> ObserverStep:
        """Absorb ``n`` new samples; return the per-sample node probabilities and events.

        ``chunk``: ``{signal: (n, C) or (n,)}`` or, when all models read one
        signal, that array.  ``action``: the commanded action (name, code, or
        one code per sample) for action-dependent graphs.
        """
        data, n = self._as_chunk(chunk)
        acts = self._as_action(action, n)
        if not self._started:
            self._start(data)
        t0 = self.n_seen_
        end = t0 + n
        if self._core is not None:
            return self._update_core(data, acts, t0, end, action is not None)
        for s in self.signals:
            self._buf[s].append(data[s])
        self._act.append(acts[:, None])
        n_events = len(self.events_)
        node_prob, map_node, w0 = self._chunk_outputs(
            t0, end, lambda: self._probabilities(self._ll[None, :]))
        if w0 < end:
            self._hist.extend_to(end + 1)
        for ws in range(w0, end, WINDOW):
            we = min(ws + WINDOW, end)
            self._open_window(ws, we)
            cur = ws
            while cur < we:
                r0 = cur - ws
                trace = np.empty((we - cur, len(self._paths)))
                stop = _advance(self._inc[r0:], self._xi[r0:], self._u_path, self._df, self._lz,
                                self.threshold, self._ll, trace, cur, self.gap,
                                *self._path_limits(), self._path_arrays()[0], self.survivors)
                last = cur + min(stop + 1, we - cur)
                self._write_hist(cur, trace[:last - cur])
                upto = last if stop >= we - cur else last - 1
                if upto > cur:
                    np_, mn = self._probabilities(trace[:upto - cur])
                    node_prob[cur - t0:upto - t0] = np_
                    map_node[cur - t0:upto - t0] = mn
                if stop < we - cur:
                    ta = cur + stop
                    self._handle_event(ta, we)
                    np_, mn = self._probabilities(self._ll[None, :])
                    node_prob[ta - t0] = np_[0]
                    map_node[ta - t0] = mn[0]
                cur = last
        self.n_seen_ = end
        self._trim()
        return ObserverStep(t0, node_prob, map_node, self.events_[n_events:])

    def _update_core(self, data, acts, t0: int, end: int, given: bool) -> ObserverStep:
        """:meth:`update` in the compiled core (``given``: an action was passed)."""
        n = end - t0
        n_act = len(self.graph.actions or ())
        if given and not n_act:
            acts = np.full(n, -1, dtype=np.int64)    # a graph without actions ignores them
        elif n and given and (acts.min() < -1 or acts.max() >= n_act):
            raise ValueError(f"action codes must be in 0..{n_act - 1} (graph {self.graph.name!r})")
        self._buf["*"].append(np.concatenate([data[s] for s in self.signals], axis=1)
                              if len(self.signals) > 1 else data[self.signals[0]])
        self._act.append(acts[:, None])
        n_events = len(self.events_)
        node_prob, map_node, w0 = self._chunk_outputs(t0, end, self._core_probabilities)
        if w0 < end:
            # the core writes each path's row before reading it: no zero fill (a chunk's
            # rows times every slot ever used, several megabytes per 4096 samples)
            self._hist.extend_to(end + 1, zero=False)
            self._core.run(w0, end, t0, self._buf["*"], self._hist, self._act, node_prob,
                           map_node, self.events_.add_tables)
        self.n_seen_ = end
        self._trim()
        return ObserverStep(t0, node_prob, map_node, self.events_[n_events:])

    def _chunk_outputs(self, t0: int, end: int, probabilities):
        """A chunk's (n, K) node probabilities and (n,) MAP nodes, the warm-up rows before
        the first scored sample (``lag``) filled from ``probabilities()``, and that sample."""
        n = end - t0
        node_prob = np.empty((n, self.graph.n_nodes))
        map_node = np.empty(n, dtype=np.int64)
        w0 = min(max(t0, self.lag), end)
        if w0 > t0:                              # warm-up: nothing scored yet
            np_, mn = probabilities()
            node_prob[:w0 - t0] = np_
            map_node[:w0 - t0] = mn
        return node_prob, map_node, w0

    def _core_probabilities(self):
        """(1, K) node probabilities and (1,) MAP node of the core's paths."""
        p = self._core.paths_
        nP = int(self._core.cnt[0])
        nodes = p["node"][:nP]
        M = np.zeros((nP, self.graph.n_nodes))
        M[np.arange(nP), nodes] = 1.0
        return _mixture(p["ll"][None, :nP], nodes, M)

    def _path_limits(self) -> tuple[np.ndarray, np.ndarray]:
        """(P,) start and longest hold (samples; 0: none) of the active paths."""
        return (np.array([p.start for p in self._paths], dtype=np.int64),
                self._tmax[self._path_arrays()[0]])

    def _probabilities(self, ll: np.ndarray):
        """(rows, K) node probabilities and (rows,) MAP node from path log-likelihoods."""
        nodes, _, M = self._path_arrays()
        return _mixture(ll, nodes, M)

    def _write_hist(self, t_first: int, trace: np.ndarray) -> None:
        if len(trace):
            self._hist.rows(t_first + 1, t_first + 1 + len(trace))[:, self._path_arrays()[1]] = trace

    def _x(self, model: FeatureModel, a: int, b: int) -> np.ndarray:
        return self._buf[model.signal].rows(a - model.lag, b)

    def _side_tables(self) -> None:
        """Per model and side, the increment ``a + b * x`` of each detector test:
        (6.14) on the chi-square of 6.11 (``x = stat[..., 0]``) for a covariance
        ``q V`` (``a = -m log(q) / 2``, ``b = (1 - 1/q) / 2``) and ``V / q``; on the
        normalised innovation sum z (``x = stat[..., 1]``) ``+-delta z - delta^2 / 2``
        for a mean change of ``delta = sqrt(q - 1)`` innovation standard deviations."""
        tests = self.tests_
        dim, q = self._model_dim, self._model_q
        a = np.empty((len(dim), len(tests)))
        b = np.empty_like(a)
        for k, side in enumerate(tests):
            if side == "increase":
                a[:, k], b[:, k] = 0.5 * (-dim * np.log(q)), 0.5 * (1.0 - 1.0 / q)
            elif side == "decrease":
                a[:, k], b[:, k] = 0.5 * (dim * np.log(q)), 0.5 * (1.0 - q)
            elif side == "rival":
                # Page's test against the best of a model's R known successors: the
                # increment is its rival margin z (weighted already), scaled by
                # T / (T + log R), so the statistic reaches T when the unscaled one reaches
                # T + log R: the maximum of R tests, each with false alarms every ~e^T
                # samples, alarms about R times as often (the union bound), and log R on
                # the threshold keeps one test's false-alarm time (Siegmund's
                # approximation, 6.3.1).  Scaling commutes with 6.18's max(0, .), so the
                # last zeros, and so the change times, are the unscaled test's.
                n_riv = np.array([max(len(getattr(self.models[n], "rivals", ())), 1)
                                  for n in self._model_names], dtype=np.float64)
                a[:, k] = 0.0
                b[:, k] = self.threshold / (self.threshold + np.log(n_riv))
            else:
                # a change size of 1 or less has no mean alternative: that test never
                # accumulates (increments of -inf, as for a side the model does not test)
                d = np.sqrt(np.maximum(q - 1.0, 0.0)) * (1.0 if side == "up" else -1.0)
                a[:, k], b[:, k] = np.where(q > 1.0, -(0.5 * d * d), -np.inf), d
        # a model whose samples carry less than an independent sample's evidence (the
        # lowpassed phase stream, GaussianFeature.weight) weighs its covariance tests'
        # log-likelihood ratios as it weighs its log-likelihood
        wts = np.array([float(getattr(self.models[n], "weight", 1.0))
                        for n in self._model_names])
        cov = [k for k, side in enumerate(tests) if side in ("increase", "decrease")]
        a[:, cov] *= wts[:, None]
        b[:, cov] *= wts[:, None]
        # a side a model does not test (``FeatureModel.tests``) never accumulates:
        # increments of -inf keep its statistic at 0 (6.18)
        for k, name in enumerate(self._model_names):
            allowed = self.models[name].tests
            if allowed is not None:
                a[k, [side not in allowed for side in tests]] = -np.inf
        self._side_a, self._side_b = a, b
        self._side_src = np.array([0 if t in ("increase", "decrease") else 1 for t in tests],
                                  dtype=np.int64)

    def _xi_of(self, stat: np.ndarray, kinds: np.ndarray) -> np.ndarray:
        """(N, U, S) increments of every side for units of model kinds ``kinds``."""
        return _increments(np.ascontiguousarray(stat), np.ascontiguousarray(kinds, dtype=np.int64),
                           self._side_a, self._side_b, self._side_src)

    def _open_window(self, w0: int, end: int) -> None:
        """Run every bank over the chunk: per-unit log-likelihoods and increments."""
        U = len(self._u_path)
        n = end - w0
        self._w0 = w0
        self._inc = np.zeros((n, U))
        stat = np.zeros((n, U, 2))
        u_bank = self._bank_of[self._u_model]
        for b, bank in enumerate(self._banks):
            cols = np.flatnonzero(u_bank == b)
            if cols.size == 0:
                continue
            ll, st = bank.run(self._x(bank.model, w0, end), t0=w0)
            self._inc[:, cols] = ll
            stat[:, cols] = st
        self._xi = self._xi_of(stat, self._u_model)

    # -- events ----------------------------------------------------------------------
    def _handle_event(self, ta: int, end: int) -> None:
        """6.4, "if a change in any model is detected": the alarms and candidates with
        their best predecessors (:mod:`~contactlab.observer.events`, the compiled core's
        own), then the merges, the new paths and the pruning on the banks."""
        nodes, slots, _ = self._path_arrays()
        starts = np.array([p.start for p in self._paths], dtype=np.int64)
        succ, n_succ, log_t = self._tables()
        U, S = self._df.shape
        n_al = U * (S + 1)                      # each test's time, and transients' ends
        n_c = n_al * max(1, int(n_succ.max()))  # an alarm's successors
        al_p, al_k, al_r = (np.empty(n_al, np.int64) for _ in range(3))
        n_alarms, n_det = collect_alarms(ta, self.threshold, self._tmax, self._df, self._lz,
                                         self._u_path, self._u_model, U, nodes, starts,
                                         len(self._paths), al_p, al_k, al_r,
                                         np.empty(S, np.int64))
        c_j, c_r, c_from, c_found = (np.empty(n_c, np.int64) for _ in range(4))
        c_init = np.empty(n_c)
        act = self._act
        n_c = best_candidates(n_alarms, n_det, al_p, al_r, nodes, starts, slots, len(self._paths),
                              self._hist.a, self._hist.t0 - self._hist.off, act.a[:, 0],
                              act.t0 - act.off, succ, n_succ, log_t, c_j, c_r, c_init, c_from,
                              c_found)
        alarms = [(int(p), self._model_names[k], int(r))
                  for p, k, r in zip(al_p[:n_alarms], al_k[:n_alarms], al_r[:n_alarms])]
        # the predecessors' segments, taken before any merge changes them
        prevs = [self._paths[f].seg if f >= 0 else None for f in c_from[:n_c].tolist()]
        spawned, merged, new = [], [], []
        for j, r, init, prev, f in zip(c_j[:n_c].tolist(), c_r[:n_c].tolist(),
                                       c_init[:n_c].tolist(), prevs, c_found[:n_c].tolist()):
            if f >= 0:                          # step 2: a tracked instance, a better start
                p = self._paths[f]
                if init > p.init:
                    delta = init - p.init
                    self._ll[f] += delta
                    self._hist.rows(r, ta + 2)[:, p.slot] += delta
                    p.init = init
                    p.seg = Segment(j, r, prev)
                    merged.append((self.graph.nodes[j].name, r))
            elif prev is not None:
                new.append((j, r, init, prev))
        for pi, _, _ in alarms[n_det:]:         # the ended transients leave
            self._ll[pi] = -math.inf
        n_units = len(self._u_path)
        if new:
            self._spawn(new, ta)
            spawned = [(self.graph.nodes[j].name, r) for j, r, _, _ in new]
        kept = self._prune(ta, alarms, spawned, merged)
        # the new instances that survived the pruning run on to the window's end
        n_new = len(self._u_path) - n_units if kept is None else int(kept[n_units:].sum())
        self._run_on(n_new, ta + 1, end)

    def _tables(self) -> tuple:
        """The graph's successor and ``log p(i -> j)`` tables (:meth:`_core_tables`), one
        build per graph and transitions setting."""
        key = (self.transitions, tuple(sorted(self.change_prior.items())))
        tables = self.graph._tables.get(key)
        if tables is None:
            tables = self.graph._tables[key] = self._core_tables()
        return tables

    def _successors(self, node: int, action) -> tuple[int, ...]:
        key = (node, action)
        if key not in self._succ:
            self._succ[key] = self.graph.successors(node, action)
        return self._succ[key]

    def _log_transition(self, i: int, j: int, action) -> float:
        """``log p(i -> j | action)`` from the graph's edge probabilities (0 where the graph
        gives none, for self-transitions, or with ``transitions="none"``); where the
        action's edges carry none, the trained change prior's ``log(h_i / R_i)`` (see
        ``change_prior``)."""
        key = (i, j, action)
        if key not in self._log_edge:
            probs = (self.graph.edge_probabilities.get(action)
                     if self.transitions == "graph" and action is not None else None)
            h = self.change_prior.get(self.graph.node_names[i])
            if probs:
                p = probs.get((i, j)) if i != j else None
                self._log_edge[key] = math.log(p) if p else 0.0
            elif h is not None and i != j:
                others = sum(1 for k in self._successors(i, action) if k != i)
                self._log_edge[key] = math.log(h / others)
            else:
                self._log_edge[key] = 0.0
        return self._log_edge[key]

    def _spawn(self, new: list, ta: int) -> None:
        """Step 3: new paths initialised at their best predecessor's log-likelihood and
        caught up to ``ta``: one bank run per (start, bank), one compiled catch-up per
        start.  Their rows after ``ta`` are left for :meth:`_run_on` (the survivors of
        the pruning)."""
        S = self._df.shape[1]
        first_path = len(self._paths)
        u_path, u_kind, u_start = [], [], []          # new units: path, model index, start
        groups: dict = {}                             # start -> [units, {bank: (units, columns)}]
        for j, r, init, prev in new:
            self._new_path(j, r, init, prev)
            g = groups.setdefault(r, [[], {}])
            for k in self._node_kinds[j]:
                i = len(u_path)
                cols, pos = g[1].setdefault(self._bank_list[k], ([], []))
                cols.append(i)
                pos.append(len(g[0]))
                g[0].append(i)
                u_path.append(len(self._paths) - 1)
                u_kind.append(k)
                u_start.append(r)
        self._hist.widen(self._n_slots)
        n_new = len(u_path)
        df = np.zeros((n_new, S))
        lz = np.zeros((n_new, S), dtype=np.int64)
        lls = np.empty(len(new))
        parts: dict = {}                                 # bank -> [(unit indices, state)]
        for r, (us, by_bank) in groups.items():
            inc = np.empty((ta + 1 - r, len(us)))
            stat = np.empty((ta + 1 - r, len(us), 2))
            for b, (cols, pos) in by_bank.items():
                if pos[-1] - pos[0] == len(pos) - 1:      # consecutive columns: a slice
                    pos = slice(pos[0], pos[-1] + 1)
                ks = [u_kind[i] for i in cols]
                bank = self._banks[b]
                state = self._prior_state(b, ks)
                ll, st = bank.run(self._x(bank.model, r, ta + 1), t0=r,
                                  starts=np.full(len(cols), r, dtype=np.int64), state=state)
                inc[:, pos] = ll
                stat[:, pos] = st
                parts.setdefault(b, []).append((cols, state))
            # detectors and path log-likelihoods over the catch-up samples r..ta; a
            # path's units are consecutive, so its local index grows along ``us``
            pis, unit_path = [], []
            for i in us:
                if not pis or pis[-1] != u_path[i]:
                    pis.append(u_path[i])
                unit_path.append(len(pis) - 1)
            init = np.array([self._paths[pi].init for pi in pis])
            slots = [self._paths[pi].slot for pi in pis]
            traj, d, z = _catch_up(inc, stat, np.array([u_kind[i] for i in us], dtype=np.int64),
                                   self._side_a, self._side_b, self._side_src,
                                   np.array(unit_path, dtype=np.int64), init, r)
            df[us], lz[us] = d, z
            self._hist.rows(r, r + 1)[0, slots] = init
            self._hist.rows(r + 1, ta + 2)[:, slots] = traj
            lls[[pi - first_path for pi in pis]] = traj[-1]
        for b, ps in parts.items():                      # bank rows appended in unit order
            if len(ps) == 1:
                idx, state = ps[0]
            else:
                idx = np.concatenate([cols for cols, _ in ps])
                perm = np.argsort(idx, kind="stable")
                idx = idx[perm]
                state = {key: np.concatenate([st[key] for _, st in ps])[perm] for key in ps[0][1]}
            self._banks[b].extend(np.array(u_start, dtype=np.int64)[idx], state)
        self._ll = np.concatenate([self._ll, lls])
        self._append_units(u_path, u_kind, df, lz)
        n = len(self._inc)
        self._inc = np.concatenate([self._inc, np.zeros((n, n_new))], axis=1)
        self._xi = np.concatenate([self._xi, np.zeros((n, n_new, S))], axis=1)

    def _prior_state(self, b: int, kinds: list) -> dict:
        """Prior state of new instances of models ``kinds`` in bank ``b`` (a fresh copy)."""
        key = (b, tuple(kinds))
        if key not in self._prior_cache:
            if len(self._prior_cache) >= 256:
                self._prior_cache.clear()
            self._prior_cache[key] = {k: v[self._prior_row[kinds]] for k, v in self._prior[b].items()}
        return {k: v.copy() for k, v in self._prior_cache[key].items()}

    def _run_on(self, n: int, a: int, end: int) -> None:
        """Run the last ``n`` units (new instances: the last rows of their banks) over
        samples ``a .. end-1`` of the window, from the state :meth:`_spawn` left."""
        if n == 0 or a >= end:
            return
        U = len(self._u_path)
        us = np.arange(U - n, U)
        u_bank = self._bank_of[self._u_model[us]]
        rows = slice(a - self._w0, end - self._w0)
        for b in dict.fromkeys(u_bank.tolist()):
            cols = us[u_bank == b]
            bank = self._banks[b]
            first = len(bank) - len(cols)
            state = {key: v[first:] for key, v in bank.state.items()}
            ll, st = bank.run(self._x(bank.model, a, end), t0=a, starts=bank.starts[first:],
                              state=state)
            for key, v in state.items():        # in place already unless the model replaced it
                bank.state[key][first:] = v
            self._inc[rows, cols] = ll
            self._xi[rows, cols] = self._xi_of(st, self._u_model[cols])

    def _p_keep(self) -> float:
        """The mass the pruning keeps: ``P_prune`` just under itself (a share summed in
        floating point may never reach it exactly), or 1 for ``P_prune = 1``: then no
        path is dropped by its share, only by ``gap`` (a share of 1 - 1e-12 would drop
        every path some 28 nats below the best whatever the gap)."""
        return 1.0 if self.p_prune >= 1.0 else self.p_prune * (1 - 1e-12)

    def _prune(self, ta: int, alarms: list, spawned: list, merged: list) -> np.ndarray | None:
        """Rank paths, keep mass P_prune, drop those ``gap`` below the best; record events.
        Returns the mask of the units kept (None: all)."""
        ll = self._ll
        n = len(ll)
        keep = np.empty(n, np.int64)
        nk = keep_set(ll, self._path_arrays()[0], n,
                      self._p_keep(), self.gap,
                      -1 if self.max_paths is None else self.max_paths, self.survivors,
                      np.empty(n, np.int64), np.empty(n), keep)
        keep = keep[:nk]
        cand_ll = ll.copy()
        if alarms:
            for k, (pi, model, r) in enumerate(alarms):
                p = self._paths[pi]
                self.events_.append(ChangeEvent(
                    ta, p.id, self.graph.nodes[p.node].name, model, r,
                    spawned if k == 0 else [], merged if k == 0 else [], cand_ll, keep))
        else:
            self.events_.append(ChangeEvent(ta, None, None, None, None, [], [], cand_ll, keep))
        if len(keep) == len(self._paths):
            return None
        remap = [-1] * len(self._paths)
        for n, i in enumerate(keep.tolist()):
            remap[i] = n
        for i, p in enumerate(self._paths):
            if remap[i] < 0:
                self._free_slots.append(p.slot)
        self._paths = [self._paths[i] for i in keep]
        self._arrays = None
        self._ll = self._ll[keep]
        # units kept, per bank in bank-row order (a handful: plain lists)
        u_new = [remap[p] for p in self._u_path.tolist()]
        kept = [i for i, p in enumerate(u_new) if p >= 0]
        rows: list[list] = [[] for _ in self._banks]
        dropped = [False] * len(self._banks)
        counts = [0] * len(self._banks)
        for b, p in zip(self._bank_of[self._u_model].tolist(), u_new):
            if p >= 0:
                rows[b].append(counts[b])
            else:
                dropped[b] = True
            counts[b] += 1
        for b, bank in enumerate(self._banks):
            if dropped[b]:
                bank.keep(rows[b])
        kept = np.array(kept, dtype=np.int64)
        self._u_path = np.array([u_new[i] for i in kept.tolist()], dtype=np.int64)
        self._u_model = self._u_model[kept]
        self._df = self._df[kept]
        self._lz = self._lz[kept]
        self._inc = np.ascontiguousarray(self._inc[:, kept])
        self._xi = np.ascontiguousarray(self._xi[:, kept])
        umask = np.zeros(len(u_new), dtype=bool)
        umask[kept] = True
        return umask

    def _trim(self) -> None:
        """Shorten the buffers to the earliest change time still possible (6.4)."""
        if self._core is not None:
            min_lz = self._core.min_last_zero()
            if min_lz is None:
                return
        elif not len(self._lz):
            return
        else:
            min_lz = int(self._lz.min())
        for b in self._buf.values():
            b.trim(min_lz + 1 - self.lag)
        self._act.trim(min_lz + 1 - self.lag)
        self._hist.trim(min_lz + 1)

    # -- output ----------------------------------------------------------------------
    def paths(self) -> list[PathInfo]:
        """The active paths, most probable first."""
        if self._started and self._core is not None:
            return self._core_paths()
        if not self._paths:
            return []
        w = np.exp(self._ll - self._ll.max())
        w /= w.sum()
        names = self.graph.node_names
        out = [PathInfo(p.id, names[p.node], p.start, float(ll), float(q),
                        [(names[n], s) for n, s in history(p.seg)])
               for p, ll, q in zip(self._paths, self._ll, w)]
        return sorted(out, key=lambda x: -x.loglik)

    def _core_paths(self) -> list[PathInfo]:
        c = self._core
        nP = int(c.cnt[0])
        p = c.paths_
        ll = p["ll"][:nP]
        w = np.exp(ll - ll.max())
        w /= w.sum()
        names = self.graph.node_names
        out = [PathInfo(int(p["id"][i]), names[p["node"][i]], int(p["start"][i]), float(ll[i]),
                        float(w[i]), [(names[n], s) for n, s in c.history(int(p["seg"][i]))])
               for i in range(nP)]
        return sorted(out, key=lambda x: -x.loglik)

    def node_probabilities(self) -> np.ndarray:
        """(K,) current node probabilities."""
        if self._started and self._core is not None:
            return self._core_probabilities()[0][0]
        return self._probabilities(self._ll[None, :])[0][0]

    def map_path(self) -> list[tuple[str, int]]:
        """The most probable path: ``[(node name, start sample), ...]``."""
        return self.paths()[0].history


def labels_from_path(path: list[tuple[str, int]], n: int, node_names) -> np.ndarray:
    """(n,) node index per sample along a path ``[(node, start), ...]``."""
    names = list(node_names)
    out = np.empty(n, dtype=np.int64)
    for k, (node, start) in enumerate(path):
        stop = path[k + 1][1] if k + 1 < len(path) else n
        out[max(start, 0):max(min(stop, n), 0)] = names.index(node)
    return out


def observe(observer: Observer, data, *, action=None, chunk: int = 4096) -> ObserverResult:
    """Run ``observer`` over a whole trace, ``chunk`` samples at a time (batch = a loop of
    :meth:`Observer.update`).  ``data``/``action`` as for ``update`` with all samples."""
    if isinstance(data, Mapping):
        n = len(next(iter(data.values())))
    else:
        n = len(data)
    if chunk < 1:
        raise ValueError(f"chunk must be >= 1; got {chunk!r}")
    probs, maps = [], []
    n_events = len(observer.events_)
    for a in range(0, n, chunk):
        b = min(a + chunk, n)
        part = ({k: np.asarray(v)[a:b] for k, v in data.items()} if isinstance(data, Mapping)
                else np.asarray(data)[a:b])
        act = action if (action is None or isinstance(action, str) or np.ndim(action) == 0) \
            else np.asarray(action)[a:b]
        step = observer.update(part, action=act)
        probs.append(step.node_prob)
        maps.append(step.map_node)
    # the run's events as a view of the observer's log: records are made when read
    events = observer.events_[n_events:]
    K = observer.graph.n_nodes
    path = observer.map_path()
    return ObserverResult(observer.graph.node_names,
                          np.concatenate(probs) if probs else np.zeros((0, K)),
                          np.concatenate(maps) if maps else np.zeros(0, dtype=np.int64),
                          events, path, labels_from_path(path, n, observer.graph.node_names),
                          observer.paths())
