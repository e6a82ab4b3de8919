"""bench: the observer over feature triples (9.1: high frequency, constraint, velocity).

The guarded move of 9.1.1: ten runs of ``datasets_spec/guarded-move.toml`` simulated with
seed 1 train the graph's models (``train --graph guarded-move``), ten more (seed 2) are
recognised with the defaults (``recognize --graph guarded-move``), every node a triple
of models over y_h, position and force, and velocity.  Timed: the recognition stage over
the test archive (reading, conditioning and the observer of 6.4), against the runs'
duration (goal >= 100x real time).

The same runs on the stick-slip graph (9.1.1's task with 9.1.2's stick-slip transitions
and 8.29's friction compensation, ``datasets_spec/graphs/guarded-move-stick-slip.toml``).

The maze of 9.2: the experiment's observer graph (the forward projection's partitions,
each node a triple over y_h, the wall constraint and velocity) trained on its simulated
training runs, following six simulated trials from their action's start with the
defaults; timed: the observer over the trials (reading and conditioning included).
"""

from __future__ import annotations

import tempfile
import time
from pathlib import Path


def _recognise(test, graph, gm):
    from contactlab.observer.paths import count_changes
    from contactlab.observer.recognize import recognize_archive

    t0 = time.perf_counter()
    out = recognize_archive(test, graph=graph, models=gm, write=False, keep=True)
    dt = time.perf_counter() - t0
    runs = out["_runs"]
    dur = sum(len(r.times) / r.fs for r in runs)
    events = sum(count_changes(r.result.events) for r in runs)
    return dt, dur, events


def _maze(d: Path) -> dict:
    from contactlab.archive import open_archive
    from contactlab.maze import build_partitions
    from contactlab.maze.projection import maze_graph
    from contactlab.maze.tracking import track_from_action, tracking_setup
    from contactlab.observer.paths import count_changes

    doc, _, fp = maze_graph(parts=build_partitions())
    graph, models, trained, test, fp = tracking_setup(doc, fp, d, seed=1, n_trials=6)
    with open_archive(test) as arch:
        trials = [arch.trial(t) for t in arch.trial_ids]
        track_from_action(trials[0], graph, models, trained, fp)                # compiled kernels loaded
        t0 = time.perf_counter()
        recs = [track_from_action(t, graph, models, trained, fp) for t in trials]
        dt = time.perf_counter() - t0
    dur = sum(len(r["times"]) / r["fs"] for r in recs)
    events = sum(count_changes(r["result"].events) for r in recs)
    return {"name": f"maze triples, {dur:.0f} s of {len(recs)} trials",
            "ours_s": dt, "peer": "real time", "peer_s": dur, "ratio": dur / dt,
            "notes": f"observer {dur / dt:.0f}x real time over {graph.n_nodes} nodes (goal >= "
                     f"100x); {events} detected changes"}


def run() -> list[dict]:
    from contactlab.acquire.simulated import record_spec
    from contactlab.observer.training import train_graph

    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp)
        train = record_spec("guarded-move", d / "train.h5", seed=1)
        test = record_spec("guarded-move", d / "test.h5", seed=2)
        gm = train_graph(train, "guarded-move")
        _recognise(test, "guarded-move", gm)                  # compiled kernels loaded
        t_ours, dur, events = _recognise(test, "guarded-move", gm)
        gs = train_graph(train, "guarded-move-stick-slip")
        t_ss, _, events_ss = _recognise(test, "guarded-move-stick-slip", gs)
        maze = _maze(d)
    return [{"name": f"guarded-move triples, {dur:.0f} s of 10 runs",
             "ours_s": t_ours, "peer": "real time", "peer_s": dur, "ratio": dur / t_ours,
             "notes": f"observer {dur / t_ours:.0f}x real time (goal >= 100x, reading and "
                      f"conditioning included); {events} detected changes"},
            {"name": f"guarded-move-stick-slip triples (9.1.2's stick-slip, 8.29), the same "
                     f"{dur:.0f} s", "ours_s": t_ss, "peer": "real time", "peer_s": dur,
             "ratio": dur / t_ss,
             "notes": f"observer {dur / t_ss:.0f}x real time (goal >= 100x); {events_ss} "
                      f"detected changes"}, maze]


if __name__ == "__main__":
    for row in run():
        print(row)
