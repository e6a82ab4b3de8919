"""Monte Carlo forward projection of the maze (thesis 5.3.5, 9.2, 10.1.1) into a feature graph.

5.3.5 proposes, and 9.2 and 10.1.1 repeat, computing the feature graph by simulation:
"randomly select a representative point ... and do the forward simulation.  Record which
features come into contact and which feature models become active.  Every simulation
produce[s] one possible forward projection trace ... Repeat the simulation until the
features produced and the chance of hitting each feature becomes stably estimated."

Here: for every partition (:mod:`.partitions`) and every one of the eight force commands,
``samples`` starts drawn uniformly in the partition are moved by the generalized damper
(:mod:`.damper`) with the command turned by a per-trial angle drawn uniformly in
``+-angle_spread_deg`` (the misalignment of the command to the maze).  Every step is
classified into a partition and marked moving or fixed; the trace becomes a sequence of
feature nodes as 9.2 builds them:

- each partition is doubled (9.2: "one feature is for being in the configuration partition
  and not moving, and one feature is for being in the partition and moving"): node ``p`` is
  partition p fixed, node ``P + p`` partition p moving (P partitions; fig 9.8 numbers its
  features the same way, 57 and 5 fixed, 108, 109, 90 ... moving);
- an impact node (``2P + q``) precedes a partition q entered with a new contact (9.2:
  "impacts were introduced when the motion from one partition to a second partition would
  involve an abrupt change in constraint") or entered by leaving a wall, over its end edge
  or out of a corner (the loss impact of 4.3.2, which the simulator's finger makes and a
  rigid disc rolling round the arc would not); its models are the constraint and velocity
  of the node it terminates in.

Every change of node is counted per action; the transition probability of ``i -> j`` under
``a`` is its count over all changes out of ``i`` under ``a``.  The counts, not just the
edges, go into the graph file (``probabilities`` of an edge set).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from contactlab.maze.damper import LEXAN_MU, damper_paths
from contactlab.maze.partitions import ACTION_ANGLES_DEG, MazePartitions

__all__ = ["ForwardProjection", "forward_project", "feature_traces", "measured_trace", "with_missed_impacts", "with_traces", "graph_document", "node_kind", "maze_graph"]

#: spread of the command's direction per trial, deg: the PHANToM's kinematic error, about
#: 1 deg over its workspace (8.1.1.2); datasets_spec/maze.toml turns its trials' forces by
#: up to 0.5 deg for the maze's placement
ANGLE_SPREAD_DEG = 1.0
#: a step shorter than this fraction of the free step is "not moving" (a stuck disc moves 0)
MOVING_FRACTION = 0.05
#: free partitions crossed in fewer steps (1 mm at the default step) are not features of a trace
MIN_DWELL_STEPS = 4
#: a measured run's free partition held for less than this is not a feature of its trace
#: (9.3; as :data:`contactlab.maze.tracking.MIN_FEATURE_S`, the features a run is scored on)
MIN_DWELL_S = 0.1


@dataclass
class ForwardProjection:
    """Transition counts between feature nodes per action (``counts[a][i, j]``, node numbers
    as in the module docstring, index = number - 1), the partitions, and how many traces ran."""

    partitions: MazePartitions
    counts: dict[int, np.ndarray]
    n_traces: int
    impact_of: dict[int, int] = field(default_factory=dict)    # impact node number -> partition number

    @property
    def n_partitions(self) -> int:
        return len(self.partitions)

    def probabilities(self, action: int) -> np.ndarray:
        c = self.counts[action].astype(float)
        out = c.sum(axis=1, keepdims=True)
        return np.divide(c, out, out=np.zeros_like(c), where=out > 0)

    def edges(self, action: int) -> list[tuple[int, int]]:
        """(from, to) node numbers of the counted transitions under ``action``."""
        i, j = np.nonzero(self.counts[action])
        return [(int(a) + 1, int(b) + 1) for a, b in zip(i, j)]

    def visited(self) -> set[int]:
        out: set[int] = set()
        for c in self.counts.values():
            i, j = np.nonzero(c)
            out |= set((i + 1).tolist()) | set((j + 1).tolist())
        return out


def feature_traces(parts: MazePartitions, paths: np.ndarray, step_m: float, *,
                   impact_number: dict[int, int], min_dwell: int = MIN_DWELL_STEPS) -> list[list[int]]:
    """Feature-node sequences (module docstring) of damper trajectories ``(T + 1, N, 2)``.

    ``impact_number`` (partition number -> its impact node number) collects the impacts seen."""
    P = len(parts)
    n_t, n = paths.shape[:2]
    part = np.empty((n_t, n), np.int64)
    for k in range(0, n_t, 64):
        blk = paths[k:k + 64]
        part[k:k + len(blk)] = parts.classify(blk.reshape(-1, 2)).reshape(len(blk), n)
    step = np.linalg.norm(np.diff(paths, axis=0), axis=2)
    moving = np.concatenate([np.zeros((1, n), bool), step > MOVING_FRACTION * step_m])
    impact, loss = _impact_table(parts)
    is_free = np.array([False] + [p.kind == "free" for p in parts.partitions])
    traces = []
    for s in range(n):
        state = part[:, s] * 2 + moving[:, s]
        start = np.concatenate([[0], np.flatnonzero(state[1:] != state[:-1]) + 1])
        lens = np.diff(np.concatenate([start, [n_t]]))
        # a free partition crossed in under min_dwell steps cannot be observed (9.3: features
        # "visited for only a short time ... can be missed"): it joins the run before it
        short = (lens < min_dwell) & is_free[part[start, s]]
        traces.append(_node_trace(part[start, s], moving[start, s], short, impact, loss, P,
                                  impact_number))
    return traces


def _node_trace(rp, rm, short, impact, loss, P: int, impact_number: dict) -> list[int]:
    """Feature nodes of runs of (partition ``rp``, moving ``rm``), runs marked ``short``
    joining the run before them (module docstring)."""
    keep = ~np.asarray(short, bool)
    keep[0] = keep[-1] = True
    rp, rm = np.asarray(rp)[keep], np.asarray(rm)[keep]
    out = [int(rp[0] + P * rm[0])]
    for k in range(1, len(rp)):
        if rp[k] == rp[k - 1] and rm[k] == rm[k - 1]:
            continue
        if (impact[rp[k - 1], rp[k]] and rm[k - 1]) or loss[rp[k - 1], rp[k]]:
            impact_number[int(rp[k])] = 2 * P + int(rp[k])
            out.append(2 * P + int(rp[k]))
        out.append(int(rp[k] + P * rm[k]))
    return out


def measured_trace(parts: MazePartitions, xy: np.ndarray, moving: np.ndarray, fs: float, *,
                   impact_number: dict[int, int], min_dwell_s: float = MIN_DWELL_S) -> list[int]:
    """The feature-node sequence of one measured run (9.2: the extra connections "can really
    only be gleaned either from a really good simulation or from actual measurements"): the
    finger's planar position ``xy`` ((T, 2), m, the c-space of :mod:`.cspace`) classified into
    partitions, ``moving`` (T,) whether it moves, at ``fs`` Hz; nodes and impacts as for the
    forward projection's traces, a free partition held under ``min_dwell_s`` joining the run
    before it."""
    part = parts.classify(np.asarray(xy, float)[:, :2])
    mv = np.asarray(moving, bool)
    state = part * 2 + mv
    start = np.concatenate([[0], np.flatnonzero(state[1:] != state[:-1]) + 1])
    lens = np.diff(np.concatenate([start, [len(part)]]))
    is_free = np.array([False] + [p.kind == "free" for p in parts.partitions])
    short = (lens < min_dwell_s * fs) & is_free[part[start]]
    impact, loss = _impact_table(parts)
    return _node_trace(part[start], mv[start], short, impact, loss, len(parts), impact_number)


def with_missed_impacts(fp: ForwardProjection) -> ForwardProjection:
    """``fp`` with every impact also missed (9.1.2: "The impacts in the sequence could be
    missed which is accounted for in the feature graph"): each count ``i -> m`` into an impact
    ``m`` is also counted past it, ``i -> j`` for each successor ``j`` of ``m`` in proportion
    to ``m``'s probabilities (at least once), so a path may go on without the impact."""
    counts = {}
    P = fp.n_partitions
    for a, c in fp.counts.items():
        out = c.copy()
        p = fp.probabilities(a)
        for m in range(2 * P, c.shape[0]):
            for i in np.flatnonzero(c[:, m]):
                for j in np.flatnonzero(p[m]):
                    if j != i:
                        out[i, j] += max(1, int(round(c[i, m] * p[m, j])))
        counts[a] = out
    return ForwardProjection(fp.partitions, counts, fp.n_traces, dict(fp.impact_of))


def with_traces(fp: ForwardProjection, traces: dict[int, list[list[int]]],
                impact_number: dict[int, int]) -> ForwardProjection:
    """``fp`` with the transitions of further node ``traces`` (per action) counted in."""
    counts = {a: c.copy() for a, c in fp.counts.items()}
    for a, trs in traces.items():
        for tr in trs:
            for i, j in zip(tr[:-1], tr[1:]):
                counts[a][i - 1, j - 1] += 1
    impact_of = dict(fp.impact_of)
    impact_of.update({v: k for k, v in impact_number.items()})
    return ForwardProjection(fp.partitions, counts, fp.n_traces, impact_of)


def _impact_table(parts: MazePartitions) -> tuple[np.ndarray, np.ndarray]:
    """Two (P + 1, P + 1) booleans (index = partition number): going from i into j while
    moving is an impact (a new contact), and going from i into j at all is one (a wall left:
    breaking away from a corner too)."""
    P = len(parts)
    new = np.zeros((P + 1, P + 1), bool)
    loss = np.zeros((P + 1, P + 1), bool)
    for j in range(1, P + 1):
        for i in range(1, P + 1):
            if i != j:
                new[i, j] = _new_contact(parts, i, j)
                loss[i, j] = _lost_wall(parts, i, j)
    return new, loss


def _lost_wall(parts: MazePartitions, p_old: int, p_new: int) -> bool:
    """Entering ``p_new`` from ``p_old`` leaves a wall: the finger crosses the wall's end edge
    or backs out of a corner, and the wrench the wall carried is released at once (4.3.2: "When
    the orientation of the surface discontinuously changes (i.e. we cross an edge) ... a loss
    impact results"; 4.52).  Leaving an arc is not: its normal has already turned away."""
    old = set(parts.by_number(p_old).surfaces)
    new = set(parts.by_number(p_new).surfaces)
    surf = parts.cspace.surfaces
    return any(surf[k].kind == "segment" for k in old - new)


def _new_contact(parts: MazePartitions, p_old: int, p_new: int) -> bool:
    """Entering ``p_new`` from ``p_old`` brings a surface the disc did not touch (an abrupt
    change of constraint; sliding from a wall onto the arc tangent to it is smooth)."""
    old = set(parts.by_number(p_old).surfaces)
    new = set(parts.by_number(p_new).surfaces)
    if not new - old:
        return False
    surf = parts.cspace.surfaces

    def tangent(s, t):   # a segment and the arc at its end share a tangent: no impact between them
        return {s.kind, t.kind} == {"segment", "arc"} and (
            np.allclose(s.a, t.b, atol=1e-9) or np.allclose(s.b, t.a, atol=1e-9))

    return any(not any(tangent(surf[k], surf[j]) for j in old) for k in new - old)


def forward_project(parts: MazePartitions, *, samples: int = 40, steps: int = 600,
                    step_m: float = 2.5e-4, angle_spread_deg: float = ANGLE_SPREAD_DEG,
                    mu: float = LEXAN_MU, actions=None, seed: int = 0) -> ForwardProjection:
    """Run the Monte Carlo forward projection (module docstring) from every partition under
    every action (or ``actions``, a subset of 1..8)."""
    rng = np.random.default_rng(seed)
    P = len(parts)
    starts = np.concatenate([parts.sample(p.number, samples, rng) for p in parts.partitions])
    n_nodes = 3 * P
    counts = {}
    impact_number: dict[int, int] = {}
    acts = sorted(ACTION_ANGLES_DEG) if actions is None else list(actions)
    for a in acts:
        turn = rng.uniform(-angle_spread_deg, angle_spread_deg, len(starts))
        ang = np.radians(ACTION_ANGLES_DEG[a] + turn)
        paths = damper_paths(parts.cspace, starts, ang, steps=steps, step_m=step_m, mu=mu)
        c = np.zeros((n_nodes, n_nodes), np.int64)
        for tr in feature_traces(parts, paths, step_m, impact_number=impact_number):
            for i, j in zip(tr[:-1], tr[1:]):
                c[i - 1, j - 1] += 1
        counts[a] = c
    return ForwardProjection(parts, counts, len(starts) * len(acts),
                             {v: k for k, v in impact_number.items()})


def node_kind(fp: ForwardProjection, number: int) -> tuple[str, int]:
    """``("fixed" | "moving" | "impact", partition number)`` of a feature node."""
    P = fp.n_partitions
    if number <= P:
        return "fixed", number
    if number <= 2 * P:
        return "moving", number - P
    return "impact", fp.impact_of[number]


_CONSTRAINT = {"free": ("CZ", "Z", "on the floor, no wall"),
               "segment": ("CW", "XZ", "floor and one wall (normal in the plane, frame estimated)"),
               "arc": ("CW", "XZ", "floor and one convex corner (9.2 approximates the arc by linear constraints)"),
               "corner": ("CC", "XYZ", "floor and two walls: no planar freedom")}


def graph_document(fp: ForwardProjection, *, title: str | None = None, min_count: int = 1) -> dict:
    """A feature-graph document (``datasets_spec/GRAPHS.md``) from the projection: every
    visited node, an edge set per action with the counted probabilities (edges seen fewer
    than ``min_count`` times dropped), the initial probability spread evenly over the fixed
    nodes (the projection's starts: the disc at rest anywhere; a task sets its own start
    with :meth:`FeatureGraph.with_initial`)."""
    parts = fp.partitions
    P = fp.n_partitions
    visited = sorted(fp.visited() | set(range(1, P + 1)))
    names = {n: str(n) for n in visited}
    nodes = []
    for n in visited:
        kind, p = node_kind(fp, n)
        part = parts.by_number(p)
        cname, _, _ = _CONSTRAINT[part.kind]
        where = f"partition {p} ({part.kind}" + (", " + ", ".join(parts.cspace.surfaces[k].name
                                                                 for k in part.surfaces) if part.surfaces else "") + ")"
        node = {"name": names[n], "label": f"{kind}: {where}",
                "models": {"hf": "I" if kind == "impact" else "S", "constraint": cname,
                           "velocity": "F" if kind == "fixed" else "M"}}
        if kind == "impact":
            node["transient"] = True
        if kind == "fixed":
            node["initial"] = 1.0 / P
        nodes.append(node)
    edge_sets = []
    for a in sorted(fp.counts):
        c = fp.counts[a]
        prob = fp.probabilities(a)
        edges, probs = [], []
        for i, j in zip(*np.nonzero(c >= min_count)):
            if (i + 1) in names and (j + 1) in names:
                edges.append(f"{names[i + 1]} -> {names[j + 1]}")
                probs.append(round(float(prob[i, j]), 4))
        edge_sets.append({"actions": [f"action-{a}"], "edges": edges, "probabilities": probs})
    models = {
        "S": {"kind": "temporal", "trained": "moving"},
        "I": {"kind": "impact", "trained": "impact"},
        "F": {"kind": "velocity-fixed", "sigma": 0.0005, "signal": "velocity"},
        "M": {"kind": "velocity-moving", "low": -0.01, "high": 0.01, "sigma": 0.0005, "signal": "velocity"},
    }
    for cname, form, _ in _CONSTRAINT.values():
        models[cname] = {"kind": "constraint", "constraint": form}
    return {"name": "maze", "title": title or "Gear-shift maze (9.2): Monte Carlo forward projection",
            "thesis": "9.2",
            "actions": ["hold"] + [f"action-{k}" for k in sorted(ACTION_ANGLES_DEG)],
            "models": models, "nodes": nodes, "edge_sets": edge_sets}


#: the shipped graph (datasets_spec/graphs/maze.toml) is this projection
SHIPPED = {"samples": 40, "steps": 600, "seed": 0}

GRAPH_HEADER = """The gear-shift maze (thesis 9.2, figs 9.6-9.8), computed by the Monte Carlo forward
projection the thesis proposed (5.3.5, 10.1.1): contactlab.maze.projection.maze_graph()
with {samples} starts per partition, {steps} steps of 0.25 mm, seed {seed} ({traces} traces).
Partitions (contactlab.maze.partitions): 1-16 the walls' c-space segments (wall_NN = edge NN
of maze_outline()), 17-22 the arcs about the convex corners, 23-32 the concave corners,
33-{P} free space divided by back-projection under the 8 commands.  Nodes: p = partition p
fixed (velocity F), {P} + p = partition p moving (M), {P2} + q an impact into
partition q.  Edge sets: one per force command, with the counted transition probabilities."""


def maze_graph(*, samples: int = SHIPPED["samples"], steps: int = SHIPPED["steps"],
               seed: int = SHIPPED["seed"], actions=None, parts: MazePartitions | None = None):
    """``(document, header, projection)``: the maze's feature graph by forward projection."""
    from contactlab.maze.partitions import build_partitions

    parts = parts if parts is not None else build_partitions()
    fp = forward_project(parts, samples=samples, steps=steps, seed=seed, actions=actions)
    header = GRAPH_HEADER.format(samples=samples, steps=steps, seed=seed, traces=fp.n_traces,
                                 P=len(parts), P2=2 * len(parts))
    return graph_document(fp), header, fp
