"""Following simulated maze trials with the observer of 6.4 over the forward-projected graph.

9.2 tracks the maze with feature triples: every partition's node carries the constraint of
the surfaces it touches and a fixed or moving velocity model, impacts an impact model.
:func:`observer_graph` turns the forward projection's graph (:mod:`.projection`) into that
graph for the simulator's wrench and position:

- a wall's partition: the floor and that wall, a degree-2 constraint whose normals are z and
  the wall's horizontal normal (the ``XZ`` frame turned about z onto the wall; the wall's
  edge force is inclined, but the floor's and the edge's normals span the same plane);
- an inside corner: floor and two walls, degree 3 (``XYZ``);
- free space: the floor alone (``Z``); so is an arc about a convex corner, because the
  simulated maze has no contact with the corner itself (:func:`contactlab.sim.environment.maze`):
  the disc passes it touching neither wall;
- an impact node: the floor alone too, with the impact model I.  Our choice where 9.2 gives
  an impact the models of the partition it enters: an impact is a bounce train (4.3.2), in
  and out of contact with the wall, so no wall's constraint holds during it, and a wall's
  constraint (its normal motion at the encoder's few micrometres) started a few samples
  before the contact -- where the detectors date the change -- costs hundreds of nats and
  loses the right path.  Measured over the 20 action-1 trials of ``reproduce maze`` (seed
  1, hf reduced as trained, no self-transitions, measured edges, no missed-impact edges):
  feature sequences exact 17, points right 0.85 (the entered partition's constraint: 1,
  0.52; a free-space constraint trained on the impact samples,
  ``impact_constraint="trained"``: 7, 0.57);
- the velocity models F and M, the constraints' noise and the high-frequency models S
  (sliding) and I (impact) trained on the simulator's labels, pooled (:func:`observer_graph`);
  :func:`track_trial` reduces the high-frequency channels as training did (their mean);
- no node self-transitions: a node is a partition of the fixed maze, its constraint's
  surface point the wall's, so 6.1's new draw of the parameters is no event here.  Allowed,
  a draw re-estimates the surface point, and a wall's model follows motion along its own
  normal piecewise: in trial maze-002 of seed 1 the crossbar's top wall, drawn 152 times,
  stood in for the slide up the tail's right wall.

:func:`feature_of_nodes` maps every node onto the simulator's label vocabulary
(:func:`contactlab.acquire.sim.labels_maze`: ``tail-right-moving``,
``right-leg-outer+right-leg-top-fixed``, ``channel-moving``, ``impact``) so that a decoded
path is scored against the simulator's truth feature by feature; free partitions are one
feature there (``channel``), as are arcs.
"""

from __future__ import annotations

import copy
import math
from pathlib import Path

import numpy as np

from contactlab import defaults as D
from contactlab.acquire.sim import MAZE_WALLS
from contactlab.maze.projection import (ForwardProjection, graph_document, node_kind, with_missed_impacts,
                                        with_traces)

#: the tail's end corner ("57") and the right leg's end corner ("5"): where action 1 and the
#: return under action 5 start (9.2)
START, GOAL = 25, 29
#: the dataset spec of the maze's trials (datasets_spec/maze.toml)
SPEC = "maze"
#: datasets_spec/maze.toml: action 1 (or 5) starts at 1.5 s
ACTION_START_S = 1.5
#: simulated training runs (action 1) for the observer's models: the drive's vibration in
#: free motion differs from run to run (the brushes' friction ripple,
#: contactlab.sim.constants.BRUSH_WAVELENGTH_MIN; the force's rms in the channel 1.6x between
#: runs of seed 1), and 4 runs left the louder ones outside the trained free model (seed 1: 3
#: trials lost at the start, read as the tail's left wall)
TRAIN_TRIALS = 8
#: and of the return under action 5 (the spec's last group)
TRAIN_RETURNS = 1

#: a feature held for less than this is not counted in a run's feature sequence (9.3:
#: features "visited for only a short time ... can be missed"; the impacts are left out)
MIN_FEATURE_S = 0.1

__all__ = ["tracking_setup", "track_from_action", "START", "GOAL", "IMPACT_CONSTRAINTS", "observer_graph", "feature_of_nodes", "wall_rotation_deg", "labels_present", "track_trial",
           "feature_runs", "measured_traces", "MIN_FEATURE_S"]


def wall_rotation_deg(parts, k: int) -> float:
    """Angle (deg) about z that turns the x axis onto wall ``k``'s horizontal normal (into
    the channel)."""
    n = np.asarray(parts.cspace.surfaces[k].normal, float)
    return math.degrees(math.atan2(n[1], n[0]))


def _constraint_model(parts, part) -> tuple[str, dict]:
    if part.kind == "segment":
        k = int(part.surfaces[0])
        return f"C{k:02d}", {"kind": "constraint", "constraint": "XZ", "mode": "fixed",
                             "rotate_deg": [0.0, 0.0, round(wall_rotation_deg(parts, k), 6)]}
    if part.kind == "corner":
        return "CC", {"kind": "constraint", "constraint": "XYZ", "mode": "fixed"}
    return "CZ", {"kind": "constraint", "constraint": "Z", "mode": "fixed"}


#: what an impact node's constraint is (module notes): the floor's (default), the entered
#: partition's (9.2), or a free-space model trained on the impact samples
IMPACT_CONSTRAINTS = ("floor", "entered", "trained")


def observer_graph(doc: dict, fp: ForwardProjection, labels, *,
                   impact_constraint: str = "floor") -> dict:
    """The forward-projection graph ``doc`` (:func:`~contactlab.maze.projection.graph_document`)
    with per-wall constraint models and models trained on the simulator's maze ``labels``
    (those with samples in the training archive; module notes): a graph document for
    :func:`contactlab.observer.graph.parse_graph`.

    Training pools labels: F on every ``*-fixed`` label, M on every ``*-moving`` one, the
    floor's constraint on ``channel-*``, the corners' on the inside corners' labels, S on
    ``channel-moving`` (the disc sliding on the floor), I on ``impact``; a wall's constraint
    on that wall's labels in its own frame, or, for a wall the training runs never touched,
    the floor model's variances (one material, one noise).
    """
    if impact_constraint not in IMPACT_CONSTRAINTS:
        raise ValueError(f"impact_constraint must be one of {IMPACT_CONSTRAINTS}; "
                         f"got {impact_constraint!r}")
    parts = fp.partitions
    labels = [str(x) for x in labels if not str(x).startswith("lifted")]
    fixed = [x for x in labels if x.endswith("-fixed")]
    moving = [x for x in labels if x.endswith("-moving")]
    floor = [x for x in labels if x.startswith("channel-")]
    corner = [x for x in labels if "+" in x]
    need = {"fixed": fixed, "moving": moving, "channel": floor, "corner": corner,
            "channel-moving": [x for x in labels if x == "channel-moving"],
            "impact": [x for x in labels if x == "impact"]}
    missing = [k for k, v in need.items() if not v]
    if missing:
        raise ValueError(f"the training labels have no {missing[0]!r} samples")
    out = copy.deepcopy(doc)
    # the floor's model first: a trained label set is fitted in the frame of the first
    # declaration naming it, and walls without samples of their own share the floor's set
    models = {"CZ": {"kind": "constraint", "constraint": "Z", "mode": "fixed", "trained": floor},
              "S": {"kind": "temporal", "trained": "channel-moving"},
              "I": {"kind": "impact", "trained": "impact"},
              "F": {"kind": "velocity-fixed", "trained": fixed, "signal": "velocity"},
              "M": {"kind": "velocity-moving", "trained": moving, "signal": "velocity"}}
    for node in out["nodes"]:
        kind, p = node_kind(fp, int(node["name"]))
        if kind == "impact" and impact_constraint == "floor":   # no wall's constraint (notes)
            node["models"] = dict(node["models"], constraint="CZ")
            continue
        if kind == "impact" and impact_constraint == "trained":
            models.setdefault("CI", {"kind": "constraint", "constraint": "0", "mode": "fixed",
                                     "trained": "impact"})
            node["models"] = dict(node["models"], constraint="CI")
            continue
        part = parts.by_number(p)
        cname, spec = _constraint_model(parts, part)
        if cname not in models:
            if part.kind == "segment":
                wall = MAZE_WALLS[int(part.surfaces[0])]
                own = [x for x in labels if x in (f"{wall}-fixed", f"{wall}-moving")]
                spec = dict(spec, trained=own or floor)
            else:
                spec = dict(spec, trained=corner)
            models[cname] = spec
        node["models"] = dict(node["models"], constraint=cname)
    for node in out["nodes"]:
        # a node is a partition of the fixed maze: its constraint's surface point is the
        # wall's, so a new draw of its parameters (6.1's self-transition) is no event here;
        # allowed, it lets a wall's model follow motion along its own normal piecewise
        node["self_transition"] = False
    out["models"] = models
    out["name"] = "maze-observer"
    out["sides"] = "both"            # an impact ends when its energy falls back (as guarded-move)
    out["p_prune"] = 1.0             # 9.1.1's rule for chapter 9: the gap of 20 alone rejects paths
    return out


def feature_of_nodes(fp: ForwardProjection, node_names) -> list[str]:
    """The simulator's label (:func:`contactlab.acquire.sim.labels_maze`) each node stands for."""
    parts = fp.partitions
    out = []
    for name in node_names:
        kind, p = node_kind(fp, int(name))
        if kind == "impact":
            out.append("impact")
            continue
        part = parts.by_number(p)
        if part.kind == "segment":
            feat = MAZE_WALLS[int(part.surfaces[0])]
        elif part.kind == "corner":
            a, b = sorted(int(s) for s in part.surfaces)
            if (a, b) == (0, len(MAZE_WALLS) - 1):
                a, b = b, a
            feat = f"{MAZE_WALLS[a]}+{MAZE_WALLS[b]}"
        else:
            feat = "channel"
        out.append(f"{feat}-{kind}")
    return out


def labels_present(archive, *, min_samples: int = 50) -> list[str]:
    """Label names with at least ``min_samples`` samples in any trial of ``archive``."""
    from contactlab.archive import open_archive

    out: set[str] = set()
    with open_archive(archive) as arch:
        for tid in arch.trial_ids:
            t = arch.trial(tid)
            codes = np.asarray(t.labels)
            n = np.bincount(codes[codes >= 0], minlength=len(t.label_names))
            out |= {str(name) for name, k in zip(t.label_names, n) if k >= min_samples}
    return sorted(out)


def measured_traces(archive, parts) -> tuple[dict[int, list[list[int]]], dict[int, int]]:
    """Feature-node sequences of the labelled runs in ``archive`` under each force command
    (:func:`contactlab.maze.projection.measured_trace`; 9.2 added the graph's extra
    connections from measurements): ``({action k: [trace per run and span of command k]},
    {partition: impact node})``.  Position is the finger's; moving is the simulator's label
    (an impact counts as moving, 9.1.1: "the trailing edge of the impact occurs while
    moving")."""
    from contactlab.archive import open_archive
    from contactlab.maze.projection import measured_trace

    out: dict[int, list[list[int]]] = {}
    impact_number: dict[int, int] = {}
    with open_archive(archive) as arch:
        for tid in arch.trial_ids:
            t = arch.trial(tid)
            names = [str(n) for n in t.label_names]
            moving = np.array([n.endswith("-moving") or n == "impact" for n in names] + [False])
            codes = np.asarray(t.labels, np.int64)
            mv = moving[np.where(codes >= 0, codes, len(names))]
            act_names = [str(n) for n in t.dataset_attrs("action").get("names", [])]
            act = np.asarray(t.action, np.int64)
            xy = np.asarray(t.position, float)[:, :2]
            edges = np.flatnonzero(act[1:] != act[:-1]) + 1
            for a, b in zip(np.r_[0, edges], np.r_[edges, len(act)]):
                name = act_names[act[a]] if 0 <= act[a] < len(act_names) else ""
                if not name.startswith("action-") or b - a < 2:
                    continue
                out.setdefault(int(name[7:]), []).append(
                    measured_trace(parts, xy[a:b], mv[a:b], float(t.rate_hz),
                                   impact_number=impact_number))
    return out, impact_number


def feature_runs(features, fs: float, *, min_s: float = MIN_FEATURE_S) -> list[str]:
    """The sequence of features held for at least ``min_s`` (impacts and ``lifted`` left
    out), consecutive repeats merged."""
    x = np.asarray(features)
    if not len(x):
        return []
    edges = np.flatnonzero(x[1:] != x[:-1]) + 1
    starts = np.r_[0, edges]
    stops = np.r_[edges, len(x)]
    out: list[str] = []
    for a, b in zip(starts, stops):
        f = str(x[a])
        if f == "impact" or f.startswith("lifted") or f == "?" or (b - a) < min_s * fs:
            continue
        if not out or out[-1] != f:
            out.append(f)
    return out


def track_trial(trial, graph, models, fp: ForwardProjection, *, start_s: float,
                start_node: str, reduce: str, sides: str | None = None, **observer_kw) -> dict:
    """The observer (6.4) over one simulated maze trial from ``start_s`` (the action's
    start; the path starts in ``start_node``), its signals reduced as the models were
    trained (``reduce``, :attr:`contactlab.observer.training.GraphModels.reduce`): the
    decoded and true features per point
    (``feature_of_nodes``; the truth is the simulator's label), the point accuracy, the two
    feature sequences (:func:`feature_runs`) and the observer result."""
    from contactlab.observer.observer import Observer, observe
    from contactlab.observer.recognize import trial_actions
    from contactlab.signals import trial_signals, truth_codes

    g = graph.with_initial({start_node: 1.0})
    observer_kw.setdefault("p_prune", g.p_prune or D.OBSERVER_PRUNE)
    obs = Observer(g, models, sides=sides or g.sides or D.OBSERVER_SIDES, **observer_kw)
    data, index, fs = trial_signals(trial, obs.signals, reduce=reduce)
    keep = np.asarray(trial.time, np.float64)[index] >= start_s
    act = trial_actions(trial, g, index)
    res = observe(obs, {k: v[keep] for k, v in data.items()}, action=act[keep])
    names = [str(n) for n in trial.label_names]
    codes = truth_codes(trial, index[keep], names)
    truth = np.array(names + ["?"])[codes]
    feats = np.array(feature_of_nodes(fp, g.node_names))
    decoded = feats[res.labels]
    known = truth != "?"
    return {"id": trial.id, "fs": fs, "result": res, "decoded": decoded, "truth": truth,
            "times": np.asarray(trial.time, np.float64)[index][keep],
            "accuracy": float(np.mean(decoded[known] == truth[known])) if known.any() else math.nan,
            "decoded_features": feature_runs(decoded, fs), "true_features": feature_runs(truth, fs),
            "online_features": feature_runs(feats[res.map_node], fs)}


def tracking_setup(doc, fp, tmp: Path, seed: int, *, n_trials: int | None = None,
                   impact_constraint: str = "floor"):
    """Simulate the maze spec's trials (seed ``seed``) into ``tmp/test.h5`` and training
    runs (``seed + 1``), and train the observer graph (:func:`observer_graph`): ``(graph, models, trained, test,
    fp)``, the models built for the observer, the trained :class:`GraphModels`, the test
    archive's path and the projection with the training runs' edges added."""
    from contactlab.acquire.record import record
    from contactlab.acquire.sim import SimSource
    from contactlab.acquire.simulated import record_spec
    from contactlab.acquire.spec import load_spec
    from contactlab.observer.graph import parse_graph
    from contactlab.observer.recognize import bind_models
    from contactlab.observer.training import train_graph

    train = record_spec(SPEC, tmp / "train.h5", seed=seed + 1, n_trials=TRAIN_TRIALS)
    # 9.2 added connections from measurements of the routes it tracked, the return
    # too: the spec's action-5 run, simulated with the training seed
    spec = load_spec(SPEC)
    back = sum(g.trials for g in spec.groups[:-1])
    record(SimSource(spec, first=back), out=train, n_trials=TRAIN_RETURNS, seed=seed + 1,
           append=True, quiet=True, log=lambda m: None)
    test = record_spec(SPEC, tmp / "test.h5", seed=seed, n_trials=n_trials)
    # 9.2's extra connections from measurements: the training runs' own node sequences;
    # and impacts that may be missed (9.1.2)
    traces, impacts = measured_traces(train, fp.partitions)
    fp = with_missed_impacts(with_traces(fp, traces, impacts))
    graph = parse_graph(observer_graph(graph_document(fp), fp, labels_present(train),
                                       impact_constraint=impact_constraint))
    graph, trained, models = bind_models(graph, train_graph(train, graph))
    return graph, models, trained, test, fp


def track_from_action(trial, graph, models, trained, fp, **kw) -> dict:
    """:func:`track_trial` from the trial's action start (:data:`ACTION_START_S`), in the node
    its action starts from (:data:`START` under action 1, :data:`GOAL` back under action 5)."""
    back = str(trial.attrs.get("group", "")).startswith("action-5")
    rec = track_trial(trial, graph, models, fp, start_s=ACTION_START_S,
                      start_node=str(GOAL if back else START), reduce=trained.reduce, **kw)
    rec["back"] = back
    return rec
