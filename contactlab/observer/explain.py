"""Why recognition went wrong on one trial (``contactlab recognize --explain TRIAL``).

For every true transition of a labelled trial (a change of its ground-truth node) the
observer of 6.4 is asked the questions that separate its failure modes:

* **Detectors at the change.**  The final MAP path's segment that covers the true
  change is re-scored by fresh instances of its node's models from the segment's start
  (as the observer scored it, 6.4) and every detector test of the observer (6.18 on the
  increments of :meth:`Observer._side_tables`) is run over the segment up to ``window``
  samples after the change, without the resets the observer's alarms make: the
  statistic at the change, its largest value in the window and the first sample it
  crossed ``T^2``.  A statistic that never rose means the path's model absorbed the new
  regime (its estimator adapted); one that crossed means the observer did spawn.
* **Hypotheses.**  The observer's events in the window: the alarms (path node, model,
  estimated change time), the successors started (node, start) and which of them the
  pruning dropped, and why (``gap``: more than ``gap`` below the best path; ``mass``:
  outside the ``P_prune`` mass).
* **Innovations afterwards.**  Over the window after the change, the log-likelihood of
  a fresh instance of each node's models started at the true change, beside the MAP
  path's own node continuing: whether the true node explains the new samples better at
  all (``margin``: the true node's log-likelihood minus the best other node's).
* **The models alone.**  Every true segment labelled by the node whose fresh instance
  explains it best, with the true boundaries given: the accuracy no path search over
  these models can exceed by much.  When it is low, the errors are the models'
  confusions, not missed changes.

Each transition gets a verdict: ``detected`` (the merged MAP path changes into the true
node within ``window``), ``models confuse`` (a fresh instance of the true node does not
explain the window better than the best other node), ``pruned`` (a successor into the
true node was started near the change and dropped), ``no alarm`` (no detector of the
path crossed) or ``not kept`` (otherwise).
"""

from __future__ import annotations

import numpy as np

from contactlab.observer.observer import Observer
from contactlab.observer.recognize import (detection_delays, merge_path, observe_trial,
                                          payload_line)
from contactlab.signals import relabel, truth_codes

__all__ = ["explain_trial", "format_explanation", "EXPLAIN_WINDOW_S"]

#: how long after a true change the explanation looks (s): the 0.25 s of the detection goal
EXPLAIN_WINDOW_S = 0.25


def _fresh(model, x: np.ndarray, a: int, b: int):
    """Per-sample log-likelihood (n,) and statistics (n, 2) of a fresh instance of
    ``model`` started at ``a`` over samples ``a .. b-1`` (``x``: its signal)."""
    a0 = max(a, int(model.lag))
    if b <= a0:
        return np.zeros(0), np.zeros((0, 2))
    starts = np.array([a0])
    state = model.init_state(starts, x.shape[1])
    ll, stat = model.run(state, x[a0 - int(model.lag):b], t0=a0, starts=starts)
    ll = np.asarray(ll, np.float64).reshape(b - a0, -1)[:, 0]
    stat = np.asarray(stat, np.float64)
    if stat.ndim == 2:      # a model that gives the chi-square only: no innovation sum,
        stat = np.stack([stat, np.zeros_like(stat)], axis=-1)   # as the observer's banks
    return ll, stat.reshape(b - a0, -1, 2)[:, 0]


def _node_ll(graph, models, data, node: str, a: int, b: int) -> float:
    """Log-likelihood of samples ``a .. b-1`` under fresh instances of ``node``'s models."""
    nd = graph.nodes[graph.node_names.index(node)]
    tot = 0.0
    for name in nd.model_names:
        m = models[name]
        tot += float(_fresh(m, data[m.signal], a, b)[0].sum())
    return tot


def _detectors(obs: Observer, graph, models, data, node: str, seg_start: int, change: int,
               end: int) -> list[dict]:
    """The observer's detector tests on fresh instances of ``node``'s models from
    ``seg_start``, read at ``change .. end-1`` (no resets)."""
    names = list(obs._model_names)
    tests = obs.tests_
    out = []
    nd = graph.nodes[graph.node_names.index(node)]
    for name in nd.model_names:
        m = models[name]
        k = names.index(name)
        a0 = max(seg_start, int(m.lag))
        _, stat = _fresh(m, data[m.signal], a0, end)
        if not len(stat):
            continue
        for s, side in enumerate(tests):
            inc = obs._side_a[k, s] + obs._side_b[k, s] * stat[:, obs._side_src[s]]
            df = np.empty(len(inc))
            v = 0.0
            for i, x in enumerate(inc):             # 6.18: integration reset at 0
                v = max(0.0, v + x) if np.isfinite(x) else 0.0
                df[i] = v
            w = df[max(change - a0, 0):]
            if not len(w):
                continue
            over = np.flatnonzero(w > obs.threshold)
            out.append({"model": name, "test": side,
                        "at_change": float(df[max(change - a0, 0)]),
                        "max": float(w.max()),
                        "crossed": int(max(change, a0) + over[0]) if len(over) else None})
    return out


def _events(res, graph, gap: float, a: int, b: int) -> list[dict]:
    """The observer's change events at samples ``a .. b-1`` with what the pruning did to
    the paths each started."""
    out = []
    for e in res.events:
        if e.model is None or not (a <= e.time < b):
            continue
        cand = np.asarray(e.candidates_loglik, np.float64)
        kept = set(np.asarray(e.kept).tolist())
        first_new = len(cand) - len(e.spawned)
        best = float(cand.max()) if len(cand) else -np.inf
        spawned = []
        for i, (node, r) in enumerate(e.spawned):
            idx = first_new + i
            if idx in kept:
                fate = "kept"
            elif cand[idx] < best - gap:
                fate = "pruned: gap"
            else:
                fate = "pruned: mass"
            spawned.append({"node": node, "start": int(r), "fate": fate})
        out.append({"time": int(e.time), "path_node": e.node, "model": e.model,
                    "change_time": int(e.change_time), "spawned": spawned,
                    "merged": [[n, int(r)] for n, r in e.merged]})
    return out


def explain_trial(trial, graph, models: dict, *, reduce: str = "none", action=None,
                  observer_kw: dict | None = None, label_map: dict | None = None,
                  window_s: float = EXPLAIN_WINDOW_S, path=None, payload: bool = True) -> dict:
    """The explanation of one trial's recognition (module notes) as a JSON-able dict."""
    run = observe_trial(trial, graph, models, reduce=reduce, action=action,
                        observer_kw=observer_kw, path=path, payload=payload)
    obs, res, index, fs = run.observer, run.result, run.index, run.fs
    models = run.models                     # as the observer weighs them
    data = {s: np.asarray(v, np.float64).reshape(len(v), -1) for s, v in run.data.items()}
    n = len(index)
    names = list(graph.node_names)
    truth = truth_codes(relabel(trial, label_map), index, names)
    win = max(1, int(round(window_s * fs)))
    # sample s is at t0 + s / fs on the trial's own clock (as recognize's path times)
    t0 = float(np.asarray(trial.time, np.float64)[index[0]]) if n else 0.0
    out = {"trial": trial.id, "samples": n, "rate_hz": float(fs), "t0_s": t0,
           "window_samples": win,
           "threshold": obs.threshold, "sides": obs.sides, "gap": obs.gap,
           "path": [[nd, int(s)] for nd, s in merge_path(res.map_path)],
           "payload": run.payload.to_dict() if run.payload is not None else None,
           "payload_status": run.payload_status,
           "accuracy": None, "transitions": [], "segments": [], "segment_accuracy": None}
    if truth is None or not (truth >= 0).any():
        out["note"] = "the trial has no ground truth named like the graph's nodes"
        return out
    lab = truth >= 0
    out["accuracy"] = float(np.mean(res.labels[lab] == truth[lab]))
    delays = detection_delays(truth, res.map_path, names, window=win)
    idx = np.flatnonzero(lab)
    ch = np.flatnonzero(np.diff(truth[idx]) != 0) + 1
    bounds = [int(idx[0])] + [int(idx[c]) for c in ch] + [int(idx[-1]) + 1]
    # the models alone: each true segment labelled by the best fresh instance
    right = 0
    for a, b in zip(bounds[:-1], bounds[1:]):
        true = names[truth[a]]
        lls = {nd: _node_ll(graph, models, data, nd, a, b) for nd in names}
        best = max(lls, key=lls.get)
        right += (b - a) * (best == true)
        out["segments"].append({"node": true, "start": a, "end": b, "best": best,
                                "margin": lls[true] - max(v for k, v in lls.items()
                                                          if k != true)})
    out["segment_accuracy"] = right / float(bounds[-1] - bounds[0])
    marks = merge_path(res.map_path)
    for a, b in zip(bounds[1:-1], bounds[2:]):
        prev, true = names[truth[a - 1]], names[truth[a]]
        end = min(a + win, b, n)
        seg = max((m for m in res.map_path if m[1] <= a), key=lambda m: m[1],
                  default=res.map_path[0])
        at = res.labels[min(a, n - 1)]
        hit = [s for nd, s in marks[1:] if nd == true and abs(s - a) <= win]
        lls = {nd: _node_ll(graph, models, data, nd, a, end) for nd in names}
        margin = lls[true] - max(v for k, v in lls.items() if k != true)
        dets = _detectors(obs, graph, models, data, seg[0], int(seg[1]), a, end)
        evs = _events(res, graph, obs.gap, a, end)
        into = [s for e in evs for s in e["spawned"] if s["node"] == true]
        if hit:
            verdict = "detected"
        elif margin <= 0:
            verdict = "models confuse"
        elif into and all(s["fate"] != "kept" for s in into):
            verdict = "pruned"
        elif not any(d["crossed"] is not None for d in dets) and not evs:
            verdict = "no alarm"
        else:
            verdict = "not kept"
        out["transitions"].append({
            "from": prev, "to": true, "sample": a, "time_s": t0 + a / fs,
            "delay": int(min(hit, key=lambda s: abs(s - a)) - a) if hit else None,
            "verdict": verdict, "path_node": names[at], "path_segment": [seg[0], int(seg[1])],
            "detectors": dets, "events": evs,
            "window_loglik": {k: float(v) for k, v in lls.items()}, "margin": float(margin)})
    out["delays"] = {k: delays[k] for k in ("counts", "missed", "extra", "transitions")}
    return out


#: alarms of one transition's window listed one by one in the text (the rest summed up;
#: ``--json`` keeps every one)
TEXT_EVENTS = 3


def _event_lines(events: list, fs: float, t0: float = 0.0) -> list[str]:
    """Text of a window's alarms: one line per alarm time (an alarm crossed by several
    tests of one path is one event), the first :data:`TEXT_EVENTS` in full and the rest
    as counts of what they started and how it fared."""
    by_time: dict = {}
    for e in events:
        key = (e["time"], e["path_node"], e["model"], e["change_time"])
        by_time.setdefault(key, []).extend(e["spawned"])
    out = []
    items = list(by_time.items())
    for (t, node, model, r), spawned in items[:TEXT_EVENTS]:
        sp = ", ".join(f"{s['node']}@{t0 + s['start'] / fs:.3f}s {s['fate']}"
                       for s in spawned) or "none new"
        out.append(f"    alarm at {t0 + t / fs:.3f}s on {node}/{model} (change "
                   f"{t0 + r / fs:.3f}s): started {sp}")
    rest = items[TEXT_EVENTS:]
    if rest:
        fates: dict = {}
        for _, spawned in rest:
            for s in spawned:
                k = f"{s['node']} {s['fate']}"
                fates[k] = fates.get(k, 0) + 1
        what = ", ".join(f"{k} x{v}" for k, v in fates.items()) or "none new"
        out.append(f"    {len(rest)} more alarms until {t0 + rest[-1][0][0] / fs:.3f}s: "
                   f"started {what}")
    return out


def format_explanation(ex: dict) -> list[str]:
    """Text lines of :func:`explain_trial`'s result."""
    fs, t0 = ex["rate_hz"], ex.get("t0_s", 0.0)
    lines = [f"{ex['trial']}: recognised "
             + " -> ".join(f"{nd}@{t0 + s / fs:.3f}s" for nd, s in ex["path"])]
    line = payload_line(ex.get("payload"), ex.get("payload_status"))
    if line:
        lines.append(f"  {line}")
    if ex["accuracy"] is None:
        return lines + [f"  {ex.get('note', 'no ground truth')}"]
    lines.append(f"  points marked correctly {100 * ex['accuracy']:.1f} %; with the true "
                 f"boundaries given, the models alone label {100 * ex['segment_accuracy']:.1f} "
                 "% (each true segment by the node whose fresh instance explains it best"
                 + ("; far below the path's share: a node's models misfit its long true "
                    "segments, which the path splits into changes (see the fit check)"
                    if ex["segment_accuracy"] < ex["accuracy"] - 0.2 else "") + ")")
    lines.append("  true segments: " + ", ".join(
        f"{s['node']}@{t0 + s['start'] / fs:.2f}s->{s['best']}({s['margin']:+.1f})"
        for s in ex["segments"]) + "  (best node, true minus best other, nats)")
    w = ex["window_samples"]
    for tr in ex["transitions"]:
        lines.append(f"  {tr['from']} -> {tr['to']} at {tr['time_s']:.3f}s: {tr['verdict']}"
                     + (f" (delay {tr['delay']} samples)" if tr["delay"] is not None else "")
                     + f"; the path is in {tr['path_node']} (segment {tr['path_segment'][0]}"
                     f"@{t0 + tr['path_segment'][1] / fs:.3f}s)")
        for d in tr["detectors"]:
            cr = "never crossed" if d["crossed"] is None else \
                f"crossed at {t0 + d['crossed'] / fs:.3f}s"
            lines.append(f"    detector {d['model']}/{d['test']}: {d['at_change']:.1f} at the "
                         f"change, max {d['max']:.1f} (T^2 {ex['threshold']:g}), {cr}")
        lines.extend(_event_lines(tr["events"], fs, t0))
        if not tr["events"]:
            lines.append(f"    no alarm within {w} samples")
        ll = tr["window_loglik"]
        lines.append(f"    next {w} samples, fresh instance log-likelihood: "
                     + ", ".join(f"{k} {v:.1f}" for k, v in ll.items())
                     + f"; true node's margin {tr['margin']:+.1f} nats")
    return lines
