"""Scoring a recognised path through the corner graphs (9.1.2-9.1.3) by the surfaces it visits.

The bundled graphs guarded-move-multi and guarded-move-actions share their
nodes: free space (0, 1), the table (2, 3 and the impact 8), the wall (4, 5,
9), the corner (6, 10) and, in the XZ-alternative test, the XZ wall (7).  A
run is scored by the sequence of surfaces its final MAP path visits against
the sequence the simulator's contact labels give (contact chatter shorter than
:data:`MIN_RUN` samples dropped), because a simulated finger does not always
go where the thesis's did.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from contactlab.observer.graph import FeatureGraph
from contactlab.observer.recognize import RecognizeStage
from contactlab.stages import run_stage

__all__ = ["CORNER_LABEL_NODES", "CORNER_SURFACES", "MIN_RUN", "recognize_corner_runs",
           "score_surfaces", "surfaces", "truth_nodes"]

#: the simulated archive's labels -> the graph's nodes (truth for point accuracy)
CORNER_LABEL_NODES = {"free-fixed": "0", "free-moving": "1", "floor-fixed": "2",
                      "floor-moving": "3", "floor+wall_y-fixed": "4",
                      "floor+wall_y-moving": "5", "floor+wall_y+wall_x-fixed": "6",
                      "floor+wall_y+wall_x-moving": "6"}
#: node -> the surface it stands for
CORNER_SURFACES = {"0": "free", "1": "free", "8": "table", "2": "table", "3": "table",
                   "9": "wall", "4": "wall", "5": "wall", "10": "corner", "6": "corner",
                   "6t": "corner",
                   "7": "XZ wall"}
#: truth runs shorter than this many samples (50 ms at 250 Hz) are contact chatter
MIN_RUN = 12


def surfaces(nodes, *, stick: bool = False) -> list[str]:
    """The merged sequence of surfaces of a node sequence.  ``stick``: a corner node
    followed later by table or wall nodes is a stick on the surface before it."""
    seq = [CORNER_SURFACES[n] for n in nodes]
    if stick:
        for i, s in enumerate(seq):
            if s == "corner" and any(t in ("table", "wall") for t in seq[i + 1:]):
                seq[i] = seq[i - 1] if i else "free"
    out: list[str] = []
    for s in seq:
        if not out or out[-1] != s:
            out.append(s)
    return out


def truth_nodes(truth: np.ndarray, names, *, min_run: int = 1) -> list[str]:
    """The merged node sequence of a truth code array (codes < 0 dropped; runs shorter
    than ``min_run`` samples -- contact chatter -- dropped)."""
    codes = np.asarray([int(c) for c in truth if c >= 0], dtype=np.int64)
    if not codes.size:
        return []
    edges = np.flatnonzero(np.diff(codes)) + 1
    starts = np.r_[0, edges]
    ends = np.r_[edges, codes.size]
    out: list[str] = []
    for a, b in zip(starts, ends):
        if b - a >= min_run and (not out or out[-1] != names[codes[a]]):
            out.append(names[codes[a]])
    return out


def score_surfaces(ours: list[str], truth: list[str] | None) -> dict:
    """``correct``: the same surfaces in the same order; ``stuck_ok``: correct, or the
    run ended still on the wall and the path ends in (S, 3, F) -- the thesis's own model
    of a stuck finger (9.1.2), which a finger held by friction on the wall is."""
    if truth is None:
        return {"correct": False, "stuck_ok": False}
    correct = ours == truth
    stuck = (len(ours) == len(truth) + 1 and ours[:-1] == truth and ours[-1] == "corner"
             and truth[-1] == "wall")
    return {"correct": correct, "stuck_ok": correct or stuck}


def recognize_corner_runs(archive, graph: FeatureGraph, models, trials, *, stick: bool = False,
                    quiet: bool = True) -> dict:
    """The observer over ``trials`` of ``archive``; each trial scored by :func:`surfaces`
    against its simulator labels (``trials.ID.score``)."""
    stage = RecognizeStage(graph=graph, models=models, write=False, keep=True,
                           label_map=CORNER_LABEL_NODES)
    res = run_stage(stage, [archive], trials=trials, quiet=quiet)[Path(archive)]
    names = list(graph.node_names)
    recs = {r.trial_id: r for r in res["_runs"]}
    for tid, e in res["trials"].items():
        ours = surfaces([n for n, _ in e["merged_path"]], stick=stick)
        rec = recs[tid]
        truth = (surfaces(truth_nodes(rec.truth, names, min_run=MIN_RUN))
                 if rec.truth is not None else None)
        e["score"] = {"ours": ours, "truth": truth, **score_surfaces(ours, truth),
                      "visits_xz": "XZ wall" in ours}
    return res
