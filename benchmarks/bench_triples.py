"""bench: the observer over feature triples (9.1: high frequency, constraint, velocity).

The guarded move of 9.1.1: ten runs of ``datasets_spec/guarded-move.toml`` simulated with
seed 1 train the graph's models (``train --graph guarded-move``), ten more (seed 2) are
recognised with the defaults (``recognize --graph guarded-move``), every node a triple
of models over y_h, position and force, and velocity.  Timed: the recognition stage over
the test archive (reading, conditioning and the observer of 6.4), against the runs'
duration (goal >= 100x real time).
"""

from __future__ import annotations

import tempfile
import time
from pathlib import Path


def _recognise(test, graph, gm):
    from contactlab.observer.recognize import recognize_archive

    t0 = time.perf_counter()
    out = recognize_archive(test, graph=graph, models=gm, write=False, keep=True)
    dt = time.perf_counter() - t0
    runs = out["_runs"]
    dur = sum(len(r.times) / r.fs for r in runs)
    events = sum(sum(e.model is not None for e in r.result.events) for r in runs)
    return dt, dur, events


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
    return [{"name": f"guarded-move triples, {dur:.0f} s of 10 runs",
             "ours_s": t_ours, "peer": "real time", "peer_s": dur, "ratio": dur / t_ours,
             "notes": f"observer {dur / t_ours:.0f}x real time (goal >= 100x, reading and "
                      f"conditioning included); {events} detected changes"}]


if __name__ == "__main__":
    for row in run():
        print(row)
