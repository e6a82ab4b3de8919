"""Recognition over an archive (``contactlab recognize``, 7.3.1-7.3.3).

Per trial: the observer of 6.4 (:class:`~contactlab.observer.Observer`) over
the trial's measurement streams (:func:`contactlab.signals.trial_signals`,
with the models file's channel reduction); the per-sample node probabilities,
the on-line MAP node, the final MAP path with its event times and the
path/change history are written to ``results/recognize``.

With ground truth (labels named like the graph's nodes): the point-level
confusion of the final MAP path's labels (the thesis's "points marked
correctly", 7.3.2), its accuracy, the on-line accuracy (MAP node after each
sample), and the table of detection delays of 7.3.2.

Choices where 7.3 is silent (also in the report):

* Points are the 250 Hz conditioned samples; a point's truth is the label of
  its newest input sample; unlabelled points (-1, or a label not in the
  graph) are left out of the confusion.
* Delays: every truth transition (label change, unlabelled gaps skipped) is
  matched to the nearest change of the merged MAP path into the same node
  within ``delay_window`` samples; the table counts |delay| 0, 1, 2, 3, >3
  samples, plus missed transitions and extra marks (changes matching none).
* Action-dependent graphs read the trial's ``action`` channel; a trial
  without one but with a ``command`` gets ``move`` where the commanded
  position changes and ``rest`` elsewhere (the simulator records no action
  channel), if the graph declares those two actions.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from contactlab import defaults as D
from contactlab.archive.results import TrialResults
from contactlab.errors import DataError
from contactlab.observer.fit import PathFit, path_fit
from contactlab.observer.graph import FeatureGraph, load_graph
from contactlab.observer.kinematics import check_map_sources, trial_label_names
from contactlab.observer.models.composite import build_models
from contactlab.observer.observer import Observer, ObserverResult, observe
from contactlab.observer.paths import count_changes
from contactlab.metrics import confusion_matrix
from contactlab.observer.training import GraphModels
from contactlab.payload import MIN_FREE_S, Payload, fit_payload, free_mask, sensor_force
from contactlab.signals import CONTACT_SIGNALS, relabel, trial_signals, truth_codes
from contactlab.stages import Stage, TrialOutcome, run_stage

__all__ = ["recognize_archive", "recognize_trial", "TrialRecognition", "observe_trial",
           "ObservedTrial", "payload_line",
           "detection_delays", "merge_path", "trial_actions", "DELAY_BINS", "STAGE"]

STAGE = "recognize"
#: the most passes of :func:`observe_trial` (the first as recorded, then with the payload
#: fitted on the free space the pass before found)
PAYLOAD_PASSES = 4
#: a pass whose free space adds at most this share of the samples the payload was fitted
#: on ends the passes
PAYLOAD_GROWTH = 0.05
DELAY_BINS = ("0", "1", "2", "3", ">3")


@dataclass(frozen=True)
class TrialRecognition:
    """One trial's recognition: the observer result, the time base, truth (or None)."""

    trial_id: str
    result: ObserverResult
    times: np.ndarray
    truth: np.ndarray | None
    fs: float
    #: how well the final MAP path's models fit the measurements (:mod:`contactlab.observer.fit`)
    fit: PathFit | None = None
    #: the payload correction of the kept pass (:func:`observe_trial`), or None
    payload: Payload | None = None
    #: why it was or was not corrected (:attr:`ObservedTrial.payload_status`)
    payload_status: str | None = None
    #: :attr:`ObservedTrial.payload_check`
    payload_check: dict | None = None


def merge_path(path) -> list[tuple[str, int]]:
    """A path ``[(node, start), ...]`` with consecutive segments of one node merged."""
    out: list[tuple[str, int]] = []
    for node, s in path:
        if not out or out[-1][0] != node:
            out.append((node, int(s)))
    return out


def detection_delays(truth, path, node_names, *, window: int = 50, min_run: int = 0) -> dict:
    """Delay table of 7.3.2 for one trial (see the module notes).  ``min_run``: labelled
    runs shorter than this many samples are taken as the run before them (a label's
    flicker is no transition to detect; 0 counts every label change).

    Returns ``{"counts": {bin: n}, "missed": n, "extra": n, "delays": [signed],
    "transitions": n, "missed_at": [sample of each missed true transition]}``.
    """
    names = list(node_names)
    t = np.asarray(truth, np.int64)
    idx = np.flatnonzero(t >= 0)
    lab = _debounced(t[idx], min_run) if min_run > 1 else t[idx]
    ch = np.flatnonzero(np.diff(lab) != 0) + 1
    true_tr = [(int(lab[c]), int(idx[c])) for c in ch]
    marks = [(names.index(n), s) for n, s in merge_path(path)[1:]]
    # each node's marks in time order (merge_path's order), to find a transition's
    # candidates within the window by bisection rather than by a scan of every mark
    by_node: dict[int, tuple[np.ndarray, np.ndarray]] = {}
    for k, (mn, ms) in enumerate(marks):
        by_node.setdefault(mn, ([], []))[0].append(ms)
        by_node[mn][1].append(k)
    by_node = {mn: (np.asarray(ts, np.int64), np.asarray(ks, np.int64))
               for mn, (ts, ks) in by_node.items()}
    used = set()
    counts = dict.fromkeys(DELAY_BINS, 0)
    delays, missed_at = [], []
    for node, s in true_tr:
        best = None
        ts, ks = by_node.get(node, (np.zeros(0, np.int64), np.zeros(0, np.int64)))
        lo, hi = np.searchsorted(ts, s - window), np.searchsorted(ts, s + window, side="right")
        for ms, k in zip(ts[lo:hi].tolist(), ks[lo:hi].tolist()):
            if k not in used and (best is None or abs(ms - s) < abs(marks[best][1] - s)):
                best = k
        if best is None:
            missed_at.append(int(s))
            continue
        used.add(best)
        d = marks[best][1] - s
        delays.append(int(d))
        counts[str(abs(d)) if abs(d) <= 3 else ">3"] += 1
    return {"counts": counts, "missed": len(missed_at), "extra": len(marks) - len(used),
            "delays": delays, "transitions": len(true_tr), "missed_at": missed_at}


def _debounced(lab: np.ndarray, min_run: int) -> np.ndarray:
    """``lab`` with each run shorter than ``min_run`` samples given the label of the run
    before it as that run stands after its own merge (the first run kept); one pass over
    the runs."""
    lab = lab.copy()
    starts = np.r_[0, np.flatnonzero(np.diff(lab) != 0) + 1]
    stops = np.r_[starts[1:], len(lab)]
    for a, b in zip(starts[1:], stops[1:]):
        if b - a < min_run:
            lab[a:b] = lab[a - 1]
    return lab


def trial_actions(trial, graph: FeatureGraph, index, *, path=None) -> np.ndarray | None:
    """Action code per conditioned sample for an action-dependent graph (None otherwise)."""
    if not graph.action_dependent:
        return None
    act = trial.action
    if act is not None:
        a = np.asarray(act, np.int64)[np.asarray(index)]
        names = trial.dataset_attrs("action").get("names")
        if names:                          # archive codes -> the graph's action codes
            names = [str(n) for n in names]
            table = np.array([graph.actions.index(n) if n in graph.actions else -1
                              for n in names] + [-1])
            a = table[np.where((a >= 0) & (a < len(names)), a, -1)]
        return a
    cmd = trial.command
    if cmd is not None and {"rest", "move"} <= set(graph.actions):
        c = np.asarray(cmd, np.float64).reshape(len(cmd), -1)
        moving = np.r_[False, np.any(np.diff(c, axis=0) != 0, axis=1)]
        code = np.where(moving, graph.actions.index("move"), graph.actions.index("rest"))
        return code[np.asarray(index)]
    if len(graph.actions) == 1:            # one action (a learned graph's task): every sample's
        return np.zeros(len(index), np.int64)
    raise DataError(f"graph {graph.name!r} has action-dependent edges but the trial has no "
                    "action channel (pass --action)", file=str(path) if path else None,
                    field=f"/trials/{trial.id}/measurements/action")


def recognize_trial(trial, graph: FeatureGraph, models: dict, *, reduce: str = "none",
                    action=None, observer_kw: dict | None = None, chunk: int = 4096,
                    path=None, label_map: dict | None = None,
                    payload: bool = True) -> TrialRecognition:
    """Run the observer over one archive trial (``models``: built model objects;
    ``label_map``: the trial's label names -> node names for the truth; ``payload``:
    correct a turning tool's payload, :func:`observe_trial`)."""
    if getattr(trial, "labels", None) is not None:
        check_map_sources(label_map, getattr(trial, "label_names", None),
                          file=str(path) if path else None,
                          field=f"/trials/{trial.id}/ground_truth/labels")
    run = observe_trial(trial, graph, models, reduce=reduce, action=action,
                        observer_kw=observer_kw, chunk=chunk, path=path, payload=payload)
    truth = truth_codes(relabel(trial, label_map), run.index, graph.node_names)
    times = np.asarray(trial.time, np.float64)[run.index]
    fit = path_fit(graph, run.models, run.data, run.result.map_path, n=len(run.index))
    return TrialRecognition(trial.id, run.result, times, truth, run.fs, fit, run.payload,
                            run.payload_status, run.payload_check)


@dataclass(frozen=True)
class ObservedTrial:
    """One trial through the observer: its result, the streams it read (``data`` on the
    points whose newest raw sample is ``index``, at ``fs``), the models as the observer
    weighed them, and the payload correction of the kept pass (or None)."""

    result: ObserverResult
    data: dict
    index: np.ndarray
    fs: float
    models: dict
    observer: Observer
    payload: Payload | None
    #: why the payload was or was not corrected (None for a graph with no free-space node
    #: on the contact signals): ``applied``, ``disabled ...``, ``no orientation ...``,
    #: ``free space too short ...``, ``not kept ...``
    payload_status: str | None = None
    #: the last pass against the first: ``{"passes", "gain_nats", "bic_nats"}`` (or None)
    payload_check: dict | None = None


def observe_trial(trial, graph: FeatureGraph, models: dict, *, reduce: str = "none",
                  action=None, observer_kw: dict | None = None, chunk: int = 4096,
                  path=None, payload: bool = True) -> ObservedTrial:
    """The observer over one trial, again where the payload needs it.

    A trial that carries the tool's orientation (its wrench measured in the sensor's
    axes, or imported in the base frame), read by a graph with a free-space node on the
    contact signals, is observed as recorded; the payload's weight and the sensor's offset
    (:func:`contactlab.payload.fit_payload`) are fitted on the samples the MAP path puts
    in free space, and the trial is observed again with the force drift they explain
    removed; and so on while the free space found grows (it grows when the first
    passes read a drift as contact), at most :data:`PAYLOAD_PASSES` passes.  The last
    pass is kept only when its most probable path's log-likelihood exceeds the first's
    by more than the payload's six parameters cost by BIC, ``3 log n`` (``n`` points):
    the same models explaining the corrected force better (a payload that changes
    within the trial, an object picked up, is fitted by no one ``w``); else the first.
    (The passes between are not compared: one fitted on the little free space a drift
    left the first pass can be worse than the first, and the next, on the free space it
    found, better.)  Other trials,
    and every trial with ``payload=False``, are observed once."""
    run = _observe_once(trial, graph, models, reduce, action, observer_kw, chunk, path,
                        None)
    free = _free_nodes(graph, models)
    if not free:                 # nothing to correct: no free space read on a force
        return run
    if not payload:
        return replace(run, payload_status="disabled (--no-payload)")
    q = getattr(trial, "orientation", None)
    if q is None:
        return replace(run, payload_status="no orientation (import the tool's orientation "
                                           "to correct a turning tool's payload)")
    q = np.asarray(q, np.float64)
    n_raw = min(len(q), len(trial.time))
    q = q[:n_raw]
    force = sensor_force(trial, q)
    fs_raw = float(trial.rate_hz)
    first, first_ll = replace(run, data=None, observer=None), _path_ll(run)
    fitted_on, status, passes = None, None, 1
    for _ in range(PAYLOAD_PASSES - 1):
        mask = free_mask(run.result.map_path, run.index, free, n_raw, fs_raw=fs_raw)
        if fitted_on is not None and (mask & ~fitted_on).sum() \
                <= PAYLOAD_GROWTH * fitted_on.sum():
            break
        fitted = fit_payload(q, force, mask, fs=fs_raw)
        if fitted is None:
            if fitted_on is None:
                status = (f"free space too short ({mask.sum() / fs_raw:.2f} s after the "
                          f"margins; {MIN_FREE_S:g} s needed)")
            break
        del run                  # the last pass's streams: not held through the next
        run = _observe_once(trial, graph, models, reduce, action, observer_kw, chunk, path,
                            fitted)
        fitted_on, passes = mask, passes + 1
    if run.payload is None:
        return replace(run, payload_status=status)
    gain, cost = _path_ll(run) - first_ll, 3.0 * np.log(max(len(run.index), 2))
    check = {"passes": passes, "gain_nats": float(gain), "bic_nats": float(cost)}
    if gain > cost:
        return replace(run, payload_status="applied", payload_check=check)
    # the payload does not explain the data better: the first pass, with its streams
    # conditioned again and its observer as it was set up
    del run
    kw, data, _, _ = observer_setup(trial, graph, models, observer_kw, reduce, path)
    return replace(first, data=data, observer=Observer(graph, models, **kw),
                   payload_status=f"not kept: the corrected force's path gains {gain:.1f} "
                                  f"nats, BIC asks {cost:.1f}", payload_check=check)


def payload_line(payload: dict | None, status: str | None) -> str | None:
    """One text line on a trial's payload correction (``to_dict`` of the fit and the
    status of :func:`observe_trial`); None where there is nothing to say (a graph with
    no free-space node on the contact signals, or the correction turned off)."""
    if payload is not None:
        return Payload.from_dict(payload).text()
    if status is None or status.startswith("disabled"):
        return None
    return f"payload not corrected: {status}"


def _path_ll(run: ObservedTrial) -> float:
    """The log-likelihood of a pass's most probable path."""
    paths = run.result.paths
    return float(paths[0].loglik) if paths else -np.inf


def _observe_once(trial, graph, models, reduce, action, observer_kw, chunk, path,
                  payload) -> ObservedTrial:
    kw, data, index, fs = observer_setup(trial, graph, models, observer_kw, reduce, path,
                                         payload=payload)
    obs = Observer(graph, models, **kw)
    act = action if action is not None else trial_actions(trial, graph, index, path=path)
    if act is not None and not isinstance(act, str) and np.ndim(act) == 1 \
            and np.any(np.asarray(act) < 0):
        raise DataError("action codes not declared by the graph", file=str(path) if path
                        else None, field=f"/trials/{trial.id}/measurements/action")
    res = observe(obs, data if len(data) > 1 else next(iter(data.values())), action=act,
                  chunk=chunk)
    return ObservedTrial(res, data, index, fs, obs.models, obs, payload)


def _free_nodes(graph: FeatureGraph, models: dict) -> set[str]:
    """The nodes of ``graph`` whose constraint model is free space (degree 0) on a
    contact signal: where the payload's fit takes its samples."""
    out = set()
    for node in graph.nodes:
        for m in node.model_names:
            mod = models.get(m)
            if getattr(mod, "degree", None) == 0 and getattr(mod, "signal", None) \
                    in CONTACT_SIGNALS:
                out.add(node.name)
    return out


def observer_setup(trial, graph: FeatureGraph, models: dict, observer_kw: dict | None,
                   reduce: str, path=None, *, payload: Payload | None = None):
    """``(observer keywords, data, index, fs)`` of one trial: its streams for the graph's
    models (the contact signals' force less ``payload``'s correction, if given), and
    ``observer_kw`` with ``transient_max_s`` (seconds; 0 or None: no limit) turned into
    :class:`Observer`'s ``transient_max`` in samples at the trial's rate and the trial's
    recorded rate as its ``rate_hz``."""
    signals = sorted({models[m].signal for m in graph.models})
    data, index, fs = trial_signals(trial, signals, reduce=reduce, path=path, payload=payload)
    kw = observer_keywords(observer_kw, fs)
    kw["rate_hz"] = float(trial.rate_hz)
    return kw, data, index, fs


def transient_limits(graph, models) -> dict | None:
    """Per transient node of ``graph``, the longest it is held (seconds): the longest
    labelled run of it in the trials the models were trained on (``transient_longest_s``
    of their provenance), else :data:`~contactlab.defaults.OBSERVER_TRANSIENT_MAX_S`
    where training had none.  None for a graph without transient nodes."""
    seen = (getattr(models, "provenance", None) or {}).get("transient_longest_s") or {}
    out = {n.name: float(seen.get(n.name) or D.OBSERVER_TRANSIENT_MAX_S)
           for n in graph.nodes if n.transient}
    return out or None


def change_dwell(graph, models) -> dict | None:
    """Per node, ``[labelled seconds, labelled changes out of it]`` in the trials the
    models were trained on (``node_dwell`` of their provenance), for a graph whose edges
    carry no probabilities and whose ``change_prior`` is ``"trained"``; else None (the
    observer then prices no change, as 6.4)."""
    if not graph.trained_change_prior:
        return None
    seen = (getattr(models, "provenance", None) or {}).get("node_dwell") or {}
    out = {n: [float(v[0]), int(v[1])] for n, v in seen.items() if n in graph.node_names}
    return out or None


def trained_initial(graph, models) -> dict | None:
    """For a graph whose ``initial`` is ``"trained"``: per node, ``(n_k + 1) / (N + K)``,
    n_k the training recordings whose first labelled node is k (``node_first`` of the
    models' provenance), N their number, K the nodes (the supervised HMM's start
    probabilities, add-one smoothed); else None (the graph's own initial probabilities)."""
    if not graph.initial_trained:
        return None
    first = (getattr(models, "provenance", None) or {}).get("node_first") or {}
    n = sum(int(v) for k, v in first.items() if k in graph.node_names)
    if not n:
        return None
    K = graph.n_nodes
    return {name: (int(first.get(name, 0)) + 1.0) / (n + K) for name in graph.node_names}


def _grouped_notes(path, outcomes) -> list[str]:
    """One note per distinct reason a trial has no accuracy, naming its trials."""
    by_text: dict[str, list[str]] = {}
    for tid, o in outcomes.items():
        if o.entry.get("no_accuracy"):
            by_text.setdefault(o.entry["no_accuracy"], []).append(str(tid))
    out = []
    for text, ids in by_text.items():
        who = (f"trial {ids[0]}" if len(ids) == 1 else
               f"{len(ids)} trials ({', '.join(ids[:3])}{', ...' if len(ids) > 3 else ''})")
        out.append(f"{path}: {who}: {text}")
    return out


def untrained_priors_note(graph, models) -> list[str]:
    """A note (in a list, empty when none) for a graph that asks for priors learned in
    training (:attr:`~contactlab.observer.graph.FeatureGraph.trained_change_prior`, or
    ``initial = "trained"``) with models whose training counted none: changes are then
    free and the start uniform.  ``train`` and ``recognize`` both give it."""
    prov = getattr(models, "provenance", None) or {}
    asked, missing = [], []
    if graph.trained_change_prior:
        asked.append("the price of a change")
        if change_dwell(graph, models) is None:
            missing.append("changes are free")
    if graph.initial_trained:
        asked.append("the start")
        if trained_initial(graph, models) is None:
            missing.append("the start is uniform")
    if not missing:
        return []
    why = ("they were trained before training counted them" if "node_dwell" not in prov
           else f"no training label names a node ({', '.join(graph.node_names)})")
    return [f"{getattr(models, 'source', None) or 'the models'}: graph {graph.name!r} takes "
            f"{' and '.join(asked)} from the training labels, but {why}: "
            f"{' and '.join(missing)}; train with labels named like the nodes (--label-map)"]


def change_priors(dwell: dict | None, fs: float) -> dict | None:
    """Per node, the probability per sample at ``fs`` of a change out of it: the rule of
    succession over its labelled samples, ``(changes + 1) / (samples + 2)`` (a node seen
    briefly and never left is not made permanent)."""
    if not dwell:
        return None
    return {n: (c + 1.0) / (s * fs + 2.0) for n, (s, c) in dwell.items()}


def observer_keywords(observer_kw: dict | None, fs: float) -> dict:
    """:class:`Observer`'s keywords from a stage's ``observer_kw`` at the conditioned rate
    ``fs``: ``transient_max_s`` (seconds; 0 or None: no limit) becomes ``transient_max``
    in samples, ``node_dwell`` (:func:`change_dwell`) the ``change_prior`` per sample."""
    kw = dict(observer_kw or {})
    kw["change_prior"] = change_priors(kw.pop("node_dwell", None), fs)
    secs = kw.pop("transient_max_s", None)
    if isinstance(secs, dict):          # per transient node
        kw["transient_max"] = {n: max(1, int(round(v * fs))) for n, v in secs.items() if v}
    else:
        kw["transient_max"] = max(1, int(round(secs * fs))) if secs else None
    return kw


def bind_models(graph, models):
    """``(graph, models, built)``: a graph (or graph file), its trained models (a
    :class:`GraphModels` or models file) and the model objects the graph's declarations
    build from them (:func:`build_models`), with a one-line DataError naming the models
    file when the graph names a model it lacks."""
    if not isinstance(graph, FeatureGraph):
        graph = load_graph(graph)
    if not isinstance(models, GraphModels):
        models = GraphModels.load(models)
    try:
        built = build_models(graph, models.trained, source=models.source)
    except DataError as err:
        if "no trained model" in err.message:
            raise DataError(f"{err.message}: graph {graph.source or graph.name} names a "
                            f"model the models file {models.source} lacks",
                            file=models.source, field=err.field) from None
        raise
    return graph, models, built


def _trial_datasets(rec: TrialRecognition, graph: FeatureGraph) -> tuple[dict, dict]:
    r = rec.result
    t = rec.times
    tt = lambda s: float(t[min(max(s, 0), len(t) - 1)]) if len(t) else 0.0  # noqa: E731
    merged = merge_path(r.map_path)
    ev = [e for e in r.events if e.model is not None]
    ds = {
        "time_s": t, "node_prob": r.node_prob, "map_node": r.map_node, "labels": r.labels,
        "path/node": np.array([n for n, _ in r.map_path], dtype=object),
        "path/start_s": np.array([tt(s) for _, s in r.map_path]),
        "path/start": np.array([s for _, s in r.map_path], dtype=np.int64),
        "events/time_s": np.array([tt(e.time) for e in ev]),
        "events/change_time_s": np.array([tt(e.change_time) for e in ev]),
        "events/node": np.array([e.node for e in ev], dtype=object),
        "events/model": np.array([e.model for e in ev], dtype=object),
        "events/n_spawned": np.array([len(e.spawned) for e in ev], dtype=np.int64),
        "events/n_kept": np.array([len(e.kept) for e in ev], dtype=np.int64),
    }
    if rec.truth is not None:
        ds["truth"] = rec.truth
    attrs = {"nodes": ",".join(graph.node_names), "n_changes": len(ev),
             "merged_path": ";".join(f"{n}@{tt(s):.4f}" for n, s in merged)}
    if rec.payload_status is not None:
        attrs["payload_status"] = rec.payload_status
    if rec.payload is not None:
        import json

        attrs["payload"] = json.dumps(rec.payload.to_dict())
    return ds, attrs


class RecognizeStage(Stage):
    """``contactlab recognize`` as a stage: the parameters of :func:`recognize_archive`."""

    name = STAGE

    def __init__(self, *, graph, models, action=None,
                 threshold: float = D.OBSERVER_THRESHOLD,
                 change_size: float = D.OBSERVER_CHANGE_SIZE,
                 p_prune: float | None = None, gap: float = D.OBSERVER_GAP,
                 sides: str | None = None, delay_window: int = 50, write: bool = True,
                 keep: bool = False, label_map: dict | None = None,
                 transitions: str = D.OBSERVER_TRANSITIONS,
                 transient_max_s: float | None = None, payload: bool = True):
        self.graph, self.models, self.built = bind_models(graph, models)
        self.payload = bool(payload)
        sides = sides or self.graph.sides or D.OBSERVER_SIDES
        p_prune = p_prune or self.graph.p_prune or D.OBSERVER_PRUNE
        self.label_map = label_map if label_map is not None else self.models.label_map
        self.map_given = label_map is not None
        self.observer_kw = dict(threshold=threshold, change_size=change_size,
                                p_prune=p_prune, gap=gap, sides=sides, transitions=transitions)
        try:
            Observer(self.graph, self.built, **self.observer_kw)
            if transient_max_s is not None and not transient_max_s >= 0:
                raise ValueError(f"transient_max_s must be >= 0; got {transient_max_s!r}")
        except ValueError as exc:
            from contactlab.errors import UsageError
            raise UsageError(str(exc)) from None
        self.observer_kw["transient_max_s"] = (transient_limits(self.graph, self.models)
                                               if transient_max_s is None
                                               else transient_max_s or None)
        self.observer_kw["node_dwell"] = change_dwell(self.graph, self.models)
        self.observer_kw["initial"] = trained_initial(self.graph, self.models)
        self.action, self.delay_window, self.write, self.keep = action, delay_window, write, keep
        self.parameters = {**self.observer_kw, "graph": self.graph.source or self.graph.name,
                           "models": self.models.source, "reduce": self.models.reduce,
                           "action": action, "delay_window": delay_window,
                           "label_map": self.label_map, "payload": self.payload}

    def run_trial(self, trial) -> TrialOutcome:
        """Observe one trial; its MAP path, confusion counts, delays and results."""
        graph, K = self.graph, self.graph.n_nodes
        label_map, no_accuracy = self._trial_label_map(trial)
        rec = recognize_trial(trial, graph, self.built, reduce=self.models.reduce,
                              action=self.action, observer_kw=self.observer_kw,
                              label_map=label_map, payload=self.payload)
        r = rec.result
        entry = {"path": [[n, float(rec.times[max(s, 0)]) if len(rec.times) else s / rec.fs]
                          for n, s in r.map_path],
                 "merged_path": [[n, float(rec.times[max(s, 0)]) if len(rec.times)
                                  else s / rec.fs] for n, s in merge_path(r.map_path)],
                 "n_changes": count_changes(r.events),
                 "accuracy": None, "accuracy_online": None, "fit": rec.fit.to_dict(),
                 "payload": rec.payload.to_dict() if rec.payload is not None else None,
                 "payload_status": rec.payload_status, "payload_check": rec.payload_check}
        if no_accuracy:
            entry["no_accuracy"] = no_accuracy
        extra = {"confusion": np.zeros((K, K), np.int64),
                 "confusion_online": np.zeros((K, K), np.int64), "delays": None,
                 "rec": rec if self.keep else None,
                 "label_names": trial_label_names(trial)}
        if rec.truth is not None and (rec.truth >= 0).any():
            c = confusion_matrix(rec.truth, r.labels, K)[0]
            con = confusion_matrix(rec.truth, r.map_node, K)[0]
            extra.update(confusion=c, confusion_online=con)
            entry["accuracy"] = float(np.trace(c) / c.sum())
            entry["accuracy_online"] = float(np.trace(con) / con.sum())
            entry["confusion"] = c.tolist()
            entry["delays"] = extra["delays"] = detection_delays(
                rec.truth, r.map_path, graph.node_names, window=self.delay_window)
        results = None
        if self.write:
            ds, attrs = _trial_datasets(rec, graph)
            if entry["accuracy"] is not None:
                attrs["accuracy"] = entry["accuracy"]
            results = TrialResults(ds, attrs, self.parameters)
        return TrialOutcome(entry, results, extra)

    def _trial_label_map(self, trial) -> tuple[dict | None, str | None]:
        """The label map for ``trial``'s truth, and why it gives no accuracy (or None).

        A map from the models file (not given for this run) that names none of the
        trial's labels is left out: a recording labelled otherwise is recognised without
        an accuracy, not refused; a map given for this run is checked in
        :func:`recognize_trial` (an error).
        """
        own = getattr(trial, "label_names", None) if trial.labels is not None else None
        if own is None:
            return self.label_map, None
        own = [str(n) for n in own]
        lmap = self.label_map
        if lmap and not self.map_given and not any(str(s) in own for s in lmap):
            lmap = None
            shown = ",".join(f"{k}={v}" for k, v in self.label_map.items())
            why = f"the models' label map ({shown}) names none of its labels ({', '.join(own)})"
        else:
            why = "its labels name none of the graph's nodes"
        targets = [lmap.get(n) for n in own] if lmap else own
        if any(t in self.graph.node_names for t in targets):
            return lmap, None
        return lmap, f"{why}; no accuracy (map them onto nodes with --label-map)"

    def _map_notes(self, path, outcomes: dict[str, TrialOutcome]) -> list[str]:
        """Notes on the label map: a given map's entries that no trial's label carries
        (:func:`unmatched_map_note`), or the models' own map read into trials with labels
        their training never saw (a recording labelled otherwise: its codes may mean
        something else there)."""
        from contactlab.observer.kinematics import unmatched_map_note

        seen = {n for o in outcomes.values() for n in (o.extra.get("label_names") or [])}
        if not self.label_map or not seen:
            return []
        if self.map_given:
            return unmatched_map_note(self.label_map, seen, Path(path).name)
        prov = self.models.provenance or {}
        new = sorted(seen - set(prov.get("labels_read") or seen))
        if new:
            shown = ",".join(f"{k}={v}" for k, v in self.label_map.items())
            where = Path(prov.get("archive") or "the training archive").name
            return [f"{path}: labels read through the models' label map ({shown}) from "
                    f"training on {where}, whose trials had no label "
                    f"{', '.join(new)}; give --label-map if this recording's labels mean "
                    "something else"]
        return []

    def summarize(self, path, outcomes: dict[str, TrialOutcome]) -> dict:
        """Confusion matrices and delay table summed over the archive's trials."""
        names = list(self.graph.node_names)
        K = len(names)
        total = sum((o.extra["confusion"] for o in outcomes.values()),
                    np.zeros((K, K), np.int64))
        total_on = sum((o.extra["confusion_online"] for o in outcomes.values()),
                       np.zeros((K, K), np.int64))
        delays = {"counts": dict.fromkeys(DELAY_BINS, 0), "missed": 0, "extra": 0,
                  "transitions": 0}
        for o in outcomes.values():
            d = o.extra["delays"]
            if d is None:
                continue
            for b in DELAY_BINS:
                delays["counts"][b] += d["counts"][b]
            for k in ("missed", "extra", "transitions"):
                delays[k] += d[k]
        has_truth = total.sum() > 0
        summary = {
            "archive": str(path), "graph": self.graph.name, "labels": names,
            "accuracy": float(np.trace(total) / total.sum()) if has_truth else None,
            "accuracy_online": float(np.trace(total_on) / total_on.sum()) if has_truth
            else None,
            "confusion": {"labels": names, "matrix": total.tolist()},
            "confusion_online": {"labels": names, "matrix": total_on.tolist()},
            "delays": delays if has_truth else None,
            "trials": {tid: o.entry for tid, o in outcomes.items()},
            "parameters": self.parameters, "written": bool(self.write),
            "warnings": [misfit_warning(path, tid, o.entry["fit"])
                         for tid, o in outcomes.items() if o.entry["fit"]["misfit"]],
            "notes": _grouped_notes(path, outcomes) + self._map_notes(path, outcomes)
            + untrained_priors_note(self.graph, self.models),
        }
        if self.keep:
            summary["_runs"] = [o.extra["rec"] for o in outcomes.values()]
        return summary


def misfit_warning(archive, trial_id: str, fit: dict) -> str:
    """The one-line warning for a trial whose data fit none of the graph's models
    (``fit``: :meth:`PathFit.to_dict`)."""
    worst = fit["worst_model"]
    level = (fit.get("by_model") or {}).get(worst)
    return (f"{archive}: trial {trial_id}: the measurements fit none of the graph's models "
            f"(chi-square per degree of freedom {fit['chi2_per_dof']:.3g} along the "
            f"recognised path, model {worst} worst at "
            f"{level if level is None else format(level, '.3g')}; about 1 when they fit): the "
            "recording is noisier than, or offset from, the data the models were trained on; "
            "train on recordings like it, or zero the force sensor")


def recognize_archive(archive, *, graph, models, action=None,
                      threshold: float = D.OBSERVER_THRESHOLD,
                      change_size: float = D.OBSERVER_CHANGE_SIZE,
                      p_prune: float | None = None, gap: float = D.OBSERVER_GAP,
                      sides: str | None = None, trials=None, delay_window: int = 50,
                      write: bool = True, quiet: bool = True, keep: bool = False,
                      workers: int = 1, scheduler: str | None = None,
                      transitions: str = D.OBSERVER_TRANSITIONS,
                      transient_max_s: float | None = None) -> dict:
    """Recognise every trial of ``archive`` with ``graph`` and ``models`` (paths or objects).

    Returns a JSON-able summary: ``accuracy`` (final MAP path, labelled points),
    ``accuracy_online``, ``confusion`` ``{"labels", "matrix"}``, ``delays``,
    ``trials`` ``{id: {"path": [[node, start_s], ...], "merged_path", "accuracy",
    "n_changes", "fit"}}`` (``fit``: :meth:`PathFit.to_dict`, how well the path's models
    fit the data), ``warnings`` (one line per trial whose data fit none of the models)
    and the parameters.  Accuracy entries are None without
    ground truth.  ``write``: results to each trial's ``results/recognize``, all
    trials in one atomic step (:func:`contactlab.stages.run_stage`; ``workers``
    / ``scheduler`` as there).  ``keep``: also return the
    :class:`TrialRecognition` objects under ``"_runs"``.  ``transient_max_s``: the
    longest a path stays in a transient node, in seconds (0: no limit, as in 6.4); None
    holds each transient node at most its longest labelled run in the models' training
    (:func:`transient_limits`).
    """
    stage = RecognizeStage(graph=graph, models=models, action=action, threshold=threshold,
                           change_size=change_size, p_prune=p_prune, gap=gap, sides=sides,
                           delay_window=delay_window, write=write, keep=keep,
                           transitions=transitions, transient_max_s=transient_max_s)
    return run_stage(stage, [archive], trials=trials, workers=workers, scheduler=scheduler,
                     quiet=quiet)[Path(archive)]


def typical_run(archive, summary: dict) -> dict:
    """The measurements beside the recognition of one run of a kept stage ``summary``
    (:class:`RecognizeStage` with ``keep=True``): the first run whose ``score`` is
    ``correct`` (else the first run).  ``{"id", "t" (s from its start), "position",
    "force", "velocity" (at the conditioned rate), "rec"}``."""
    from contactlab.archive import open_archive
    from contactlab.signals import trial_signals

    recs = {r.trial_id: r for r in summary["_runs"]}
    tid = next((t for t, e in summary["trials"].items()
                if e.get("score", {}).get("correct")), next(iter(recs)))
    with open_archive(archive) as arch:
        trial = arch.trial(tid)
        data, index, _ = trial_signals(trial, ["contact", "velocity"], path=archive)
        t = np.asarray(trial.time, np.float64)[index]
    return {"id": tid, "t": t - t[0], "position": data["contact"][:, :3],
            "force": data["contact"][:, 3:6], "velocity": data["velocity"], "rec": recs[tid]}
