"""The observer of 6.4 on a live source (``contactlab watch``).

:func:`watch` runs, per recording of a :class:`~contactlab.live.sources.LiveSource`,
the causal conditioning (:class:`~contactlab.live.conditioner.LiveConditioner`) and
the observer (built as ``recognize`` builds it: :class:`RecognizeStage`'s bound models
and parameters), chunk by chunk as the rows arrive, and reports through ``emit`` one
dict per line:

* ``{"event": "change", ...}`` each change of the most probable node (the on-line MAP
  node): the time of the sample that changed it, the node, its probability, the
  estimated change time (the start of that node's segment on the MAP path when it was
  decided), the detection delay (the difference), and the latency (wall time from the
  arrival of the sample's rows to the decision).  A change printed live may be revised
  later: the observer keeps other paths, and its final path can date or drop a change
  differently;
* ``{"event": "probs", ...}`` every ``probs_every`` seconds of data: the node
  probabilities;
* ``{"event": "path", ...}`` at the end of each recording: its final MAP path (what
  ``recognize`` gives for the same rows) and whether it revises the changes printed;
* ``{"event": "summary", ...}`` at the end: counts, latency and CPU share.

With ``record``, the raw rows go to an archive as they arrive (the acquire writer,
incremental behind its rollback journal) and, once the run ends, each recording's
recognition results to its ``results/recognize`` (the datasets ``recognize`` writes).
Ctrl-C or SIGTERM ends the run: the recording in progress is closed as it stands and
kept with its results; a second signal quits at once keeping the finished recordings.
A fault of the source (a dropped connection, a stalled Net F/T) ends the recording in
progress, kept, says so in one line on stderr and, where the source reconnects, starts
the next.

Memory: the observer trims its buffers and the conditioner keeps only the rows a later
sample needs; without ``record`` nothing grows with the run but the observer's event
log (a few records per change).  With ``record`` the per-sample results are kept until
they are written.
"""

from __future__ import annotations

import math
import time as _time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from contactlab.errors import DataError
from contactlab.live.conditioner import LiveConditioner
from contactlab.live.sources import warn
from contactlab.observer.observer import Observer, ObserverResult, labels_from_path
from contactlab.observer.recognize import merge_path

__all__ = ["watch", "TrialWatch", "LatencyStats"]


class LatencyStats:
    """Latencies (s) in a fixed-size ring (memory flat) with their percentiles."""

    def __init__(self, size: int = 65536):
        self._ring = np.zeros(size)
        self.n = 0
        self.max = 0.0

    def add(self, values) -> None:
        v = np.atleast_1d(np.asarray(values, np.float64))
        if not len(v):
            return
        self.max = max(self.max, float(v.max()))
        size = len(self._ring)
        for part in np.array_split(v[-size:], max(1, math.ceil(len(v[-size:]) / size))):
            i = np.arange(self.n, self.n + len(part)) % size
            self._ring[i] = part
            self.n += len(part)

    def summary(self) -> dict:
        kept = self._ring[:min(self.n, len(self._ring))]
        if not len(kept):
            return {"n": 0}
        return {"n": self.n, "median_ms": 1e3 * float(np.median(kept)),
                "p99_ms": 1e3 * float(np.percentile(kept, 99)), "max_ms": 1e3 * self.max}


@dataclass
class TrialWatch:
    """One recording being watched: its observer, conditioner and what was printed."""

    trial_id: str
    rate_hz: float
    obs: Observer
    cond: LiveConditioner
    keep: bool
    n: int = 0
    last_map: int = -1
    next_probs: float = -math.inf
    changes: list = field(default_factory=list)       # (node, sample) printed live
    probs: list = field(default_factory=list)
    maps: list = field(default_factory=list)
    times: list = field(default_factory=list)
    n_events: int = 0


def _actions(stage, info, act: np.ndarray | None, n: int):
    """The action of each emitted sample for an action-dependent graph (as
    :func:`contactlab.observer.recognize.trial_actions` reads the archive's)."""
    graph = stage.graph
    if not graph.action_dependent:
        return None
    if stage.action is not None:
        return stage.action
    if act is not None and info.action_names:
        names = [str(x) for x in info.action_names]
        table = np.array([graph.actions.index(x) if x in graph.actions else -1
                          for x in names] + [-1])
        return table[np.where((act >= 0) & (act < len(names)), act, -1)]
    if act is not None and {"rest", "move"} <= set(graph.actions):
        return np.where(act > 0, graph.actions.index("move"), graph.actions.index("rest"))
    if len(graph.actions) == 1:
        return np.zeros(n, np.int64)
    raise DataError(f"graph {graph.name!r} has action-dependent edges but the source gives "
                    "no action channel or command (pass --action)", field="--source")


def watch(source, stage, *, emit, probs_every: float | None = None, record: Path | None = None,
          force: bool = False, max_retries: int = 5) -> dict:
    """Watch ``source`` with the observer ``stage`` (a :class:`RecognizeStage`, built with
    ``write=False``) and report through ``emit(dict)``; return the summary (also
    emitted).  See the module notes."""
    from contactlab import interrupt

    lat = LatencyStats()
    stats = {"trials": [], "samples": 0, "changes": 0, "faults": 0, "interrupted": False}
    results: dict = {}
    cpu0, wall0 = _time.process_time(), _time.monotonic()
    writer = None
    with interrupt.signals_as_interrupt():
        if record is not None:
            from contactlab.archive import create_archive

            writer = create_archive(record, force=force, incremental=True,
                                    title=f"contactlab watch {source.name}")
        try:
            retries = 0
            for stream in source.trials():
                tw, ok = _watch_trial(stream, source, stage, emit, lat, stats, results,
                                      writer, probs_every)
                if ok:
                    retries = 0
                    continue
                stats["faults"] += 1
                retries += 1
                if not source.reconnects or retries > max_retries:
                    break
                warn(f"{source.name}: reconnecting ({retries}/{max_retries})")
        except KeyboardInterrupt:
            stats["interrupted"] = True
        except BaseException as err:
            if writer is not None:
                writer.__exit__(type(err), err, err.__traceback__)
            raise
        if writer is not None:
            writer.close()
            if results:
                from contactlab.archive.results import write_stage

                write_stage(record, "recognize", results)
    wall = _time.monotonic() - wall0
    summary = {"event": "summary", "source": source.name, "trials": stats["trials"],
               "samples": stats["samples"], "changes": stats["changes"],
               "faults": stats["faults"], "latency": lat.summary(),
               "cpu_share": (_time.process_time() - cpu0) / wall if wall > 0 else None,
               "record": str(record) if record is not None else None,
               "interrupted": stats["interrupted"]}
    emit(summary)
    return summary


def _watch_trial(stream, source, stage, emit, lat, stats, results, writer, probs_every):
    """Watch one recording; ``(TrialWatch, ended_normally)``.  KeyboardInterrupt passes
    on after the recording is closed (kept)."""
    trial_writer = None
    tw = None
    ok = True
    try:
        chunks = stream.chunks()
        for chunk in chunks:
            arrival = _time.monotonic()
            if tw is None:
                info = stream.info
                from contactlab.observer.recognize import observer_keywords
                from contactlab.signals import factor_for

                fs = info.rate_hz / factor_for(info.rate_hz)
                obs = Observer(stage.graph, stage.built, rate_hz=info.rate_hz,
                               **observer_keywords(stage.observer_kw, fs))
                cond = LiveConditioner(obs.signals, rate_hz=info.rate_hz, fields=source.fields,
                                       reduce=stage.models.reduce, source=source.name)
                tw = TrialWatch(info.trial_id, info.rate_hz, obs, cond, keep=writer is not None)
                stats["trials"].append(info.trial_id)
                if writer is not None:
                    trial_writer = _open_trial(writer, info)
            if trial_writer is not None:
                trial_writer.append(**chunk)
            _step(tw, stage, stream.info, tw.cond.update(chunk), arrival, emit, lat, stats,
                  probs_every)
        if tw is not None:
            _step(tw, stage, stream.info, tw.cond.finish(), _time.monotonic(), emit, lat,
                  stats, probs_every)
    except DataError as err:
        warn(f"{source.name}: {err.message}; the recording so far is kept")
        ok = False
    except KeyboardInterrupt:
        if tw is not None:
            _end_trial(tw, stream, stage, emit, results, trial_writer, ok=False)
        raise
    if tw is not None:
        _end_trial(tw, stream, stage, emit, results, trial_writer, ok=ok)
    return tw, ok


def _open_trial(writer, info):
    return writer.add_trial(
        info.trial_id, rate_hz=info.rate_hz, controller=info.controller,
        environment=info.environment, seed=info.seed, source=info.source,
        description=info.description, calibration=info.calibration,
        command_columns=info.command_columns, action_names=info.action_names,
        strain_units=info.strain_units, command_units=info.command_units)


def _step(tw: TrialWatch, stage, info, out, arrival, emit, lat, stats, probs_every) -> None:
    data, index, times, act = out
    n = len(index)
    if not n:
        return
    step = tw.obs.update(data, action=_actions(stage, info, act, n))
    decided = _time.monotonic()
    lat.add(decided - arrival)
    names = stage.graph.node_names
    fs = tw.rate_hz / tw.cond.factor
    t0 = tw.n
    mp = step.map_node
    ch = np.flatnonzero(np.diff(np.r_[tw.last_map, mp]) != 0)
    if len(ch):
        path = tw.obs.map_path()
        for i in ch:
            j = int(mp[i])
            g = t0 + int(i)
            start = max((s for nd, s in path if nd == names[j] and s <= g), default=g)
            tw.changes.append((names[j], g))
            emit({"event": "change", "trial": tw.trial_id, "time": float(times[i]),
                  "node": names[j], "prob": float(step.node_prob[i, j]),
                  "from": (names[int(mp[i - 1])] if i > 0 else
                           (names[tw.last_map] if tw.last_map >= 0 else None)),
                  "change_time": float(times[i] - (g - start) / fs),
                  "delay_s": (g - start) / fs, "latency_ms": 1e3 * (decided - arrival)})
        stats["changes"] += len(ch)
    tw.last_map = int(mp[-1])
    if probs_every:
        ticks = np.floor(times / probs_every)
        first = np.flatnonzero(np.diff(np.r_[tw.next_probs, ticks]) != 0)
        for i in first:
            emit({"event": "probs", "trial": tw.trial_id, "time": float(times[i]),
                  "p": {nm: float(p) for nm, p in zip(names, step.node_prob[i])}})
        tw.next_probs = float(ticks[-1])
    if tw.keep:
        tw.probs.append(step.node_prob)
        tw.maps.append(step.map_node)
        tw.times.append(times)
    tw.n += n
    stats["samples"] += n


def _end_trial(tw: TrialWatch, stream, stage, emit, results, trial_writer, *, ok: bool) -> None:
    """The recording's final path line; with a recording, close it (kept) and keep its
    results for writing."""
    names = stage.graph.node_names
    fs = tw.rate_hz / tw.cond.factor
    path = tw.obs.map_path() if tw.n else []
    merged = merge_path(path)
    # revised: the final path's nodes are not the changes printed live (their dates
    # differ by construction: a change is printed when decided, the path dates it)
    revised = [n for n, _ in merged] != [n for n, _ in tw.changes]
    times = np.concatenate(tw.times) if tw.times else None
    tt = (lambda s: float(times[min(max(s, 0), len(times) - 1)])) if times is not None \
        and len(times) else (lambda s: max(s, 0) / fs)
    emit({"event": "path", "trial": tw.trial_id, "samples": tw.n, "complete": ok,
          "path": [[n, tt(s)] for n, s in merged], "revised": bool(revised)})
    if trial_writer is None:
        return
    from contactlab.acquire.record import finish_trial

    finish_trial(trial_writer, stream, truth=ok)
    attrs = {**stream.info.attrs, **(stream.final_attrs() or {}), "watch_complete": ok}
    trial_writer.set_attrs(attrs)
    trial_writer.close()
    if tw.n:
        from contactlab.archive.results import TrialResults
        from contactlab.observer.recognize import TrialRecognition, _trial_datasets

        K = stage.graph.n_nodes
        res = ObserverResult(names, np.concatenate(tw.probs) if tw.probs else np.zeros((0, K)),
                             np.concatenate(tw.maps), tw.obs.events_[0:], path,
                             labels_from_path(path, tw.n, names), tw.obs.paths())
        rec = TrialRecognition(tw.trial_id, res, times, None, fs)
        ds, attrs = _trial_datasets(rec, stage.graph)
        results[tw.trial_id] = TrialResults(ds, attrs, {**stage.parameters, "live": True})
