"""A feature graph from labelled recordings (``contactlab graph learn``; 5.3, 6.1, 10.1.3).

The thesis builds its graphs from the task's geometry (5.3, 9.2's forward projection) and
notes that "for repetitive tasks the task itself is a better simulation" (10.1.3).  A
recording whose phases are labelled (a controller's state switches, a demonstrator's
segmentation) states the graph directly:

* **nodes** -- one per node name of the label map (several labels may map onto one
  node: HIRO's rotation and insertion are one "engage" phase), in the map's order;
* **models** -- each node reads a Gaussian of its phase on the ``phase`` stream
  (:class:`~contactlab.observer.models.gaussian.GaussianFeature`: the lowpassed wrench
  and velocity, :func:`contactlab.signals.phase_stream`), trained on that node's labels
  (recognition weighs each sample by the share of an independent one it carries, and
  tests each phase's model against those of the phases that may follow it: the
  model's notes);
  optional extra families (``extra``) add, per node, a constraint of an estimated frame
  on the contact signal (degree 1 where the phase's force departs from the first
  phase's by more than :data:`CONTACT_N`, else 0), the moving-velocity model M and an
  AR(1)-with-mean temporal model of the wrench where the rate reaches 250 Hz;
* **edges** -- every change between two mapped labels seen in a trial's label sequence
  (unmapped samples are skipped: a label outside the task neither starts nor ends a
  phase), with the **transition probabilities** ``p(i -> j) = n_ij / N_i`` per sample,
  ``N_i`` the samples labelled ``i`` at the rate the observer reads (the conditioned
  rate, :func:`contactlab.signals.factor_for`), counted over the trials: the supervised
  HMM peer's off-diagonal transition probabilities, the rest of each node's mass being
  no change.  They are written to the graph's edge set (``probabilities``); the
  observer adds ``log p`` when a path changes node (6.4), so a change costs what it
  costs the HMM, and a path cannot pass through a phase in a few samples for free (a
  per-change ``n_ij / n_i`` of 1 along a chain of phases charged nothing: on Baxter's
  pick-and-place the path ran through a whole phase in 60 ms).  The graph's one action
  ``task`` is every sample's, so a recording without an action channel needs none;
* **initial probabilities** -- the share of trials whose first mapped label is each node;
* labelled samples the map leaves out (Baxter's 0 before and after the task) get a node
  of their own, :data:`OUTSIDE`, so that some model explains them (otherwise the
  first phase's model meets the robot at rest before the task and the path runs ahead);
  the map to train with then maps those labels onto it (the summary's ``label_map``),
  and recognising with the task's own map leaves them out of the score.

Nodes do not restart within themselves (``self_transition = false``): a phase's
Gaussian has no parameters to redraw.

The graph asks the observer to keep each node's best path through the pruning
(``survivors = true``, :attr:`contactlab.observer.Observer.survivors`): a phase whose
first samples, seen through the lowpass, fit the next phase better loses the lead for
a moment, and without its path there is no way back along a chain of phases.  On
Baxter's pick-and-place (one trial trains, the other is recognised) the path entered
"descend and release" 3-6 s early and stayed: 0.672 / 0.758 of points, 0.854 / 0.864
with survivors (supervised HMM 0.731 / 0.875); HIRO's phases 0.948 -> 0.939 and 0.998
(unchanged); the hf graph with learned edges 0.944 / 0.923 / 0.946 / 0.951 -> 0.944 /
0.894 / 0.946 / 0.951 (seeds 3-6).

With a **base graph** (``base``; ``graph learn --models-from GRAPH``) the nodes keep
that graph's models, transient flags and labels -- the label map names its nodes -- and
only the edges, their probabilities and the initial probabilities come from the labels:
the context of 7.3.3 (which transitions a task makes, and how often) learned from the
training runs instead of stated from the action and the geometry.

``train --graph`` fits the models and ``recognize --graph`` runs the result like any
bundled graph.  With ``em``, the models
are trained from the labelled archive and Baum-Welch over every run of the archives
(labels not needed; :func:`contactlab.observer.learning.learn_graph`) adds the edges the
labels never showed and replaces the probabilities by the learned ones (the mean over
the archives, each learned by its own EM).
"""

from __future__ import annotations

from collections import Counter
from pathlib import Path

import numpy as np

from contactlab.errors import DataError
from contactlab.signals import factor_for, relabel

__all__ = ["label_sequences", "count_transitions", "graph_from_labels", "learn_from_labels",
           "small_forces_note",
           "base_document",
           "ACTION", "CONTACT_N", "EXTRA_FAMILIES", "OUTSIDE", "outside_map"]

#: the learned graph's one action: every sample is under it
ACTION = "task"
#: the node of labelled samples the label map leaves out (outside the task)
OUTSIDE = "outside"
#: force change (N) from the first phase's mean force above which a phase is in contact
CONTACT_N = 2.0
#: model families ``extra`` may add to every node
EXTRA_FAMILIES = ("constraint", "velocity", "temporal")
#: lowest input rate (Hz) for a temporal model of the wrench (the conditioned 250 Hz)
TEMPORAL_MIN_HZ = 250.0


def outside_map(trial, label_map: dict, outside: str = OUTSIDE) -> dict:
    """The labels the trial's samples carry and the map leaves out, onto ``outside``."""
    names = list(getattr(trial, "label_names", None) or [])
    used = np.unique(np.asarray(trial.labels, np.int64))
    return {str(names[c]): outside for c in used
            if 0 <= c < len(names) and str(names[c]) not in label_map}


def label_sequences(trial, label_map: dict) -> tuple[list[str], np.ndarray]:
    """``(nodes, runs)`` of one trial: the sequence of mapped labels with repeats merged
    (unmapped samples skipped) and the ``(n, 3)`` runs ``[start, stop, node index into
    nodes]`` in input samples."""
    tr = relabel(trial, label_map)
    names = list(tr.label_names or [])
    raw = np.asarray(tr.labels, np.int64)
    mapped = np.array([n is not None for n in names] + [False])
    code = np.where((raw >= 0) & (raw < len(names)), raw, len(names))
    keep = np.flatnonzero(mapped[code])
    if len(keep) == 0:
        return [], np.zeros((0, 3), np.int64)
    lab = np.array([names[c] for c in code[keep]], dtype=object)
    cut = np.flatnonzero(lab[1:] != lab[:-1]) + 1
    starts = np.r_[0, cut]
    stops = np.r_[cut, len(lab)]
    seq = [str(lab[s]) for s in starts]
    runs = np.array([[keep[a], keep[b - 1] + 1, k] for k, (a, b) in enumerate(zip(starts, stops))],
                    np.int64)
    return seq, runs


def count_transitions(sequences) -> tuple[Counter, Counter]:
    """``(first, pairs)``: how many sequences start in each node, and how many changes
    ``(a, b)`` the sequences show."""
    first, pairs = Counter(), Counter()
    for seq in sequences:
        if seq:
            first[seq[0]] += 1
        pairs.update(zip(seq[:-1], seq[1:]))
    return first, pairs


def _node_order(label_map: dict) -> list[str]:
    return list(dict.fromkeys(label_map.values()))


def _base_nodes(base: dict, nodes: list[str]) -> dict:
    """``{node: its declaration in base}``; DataError naming the first node ``base``
    lacks (the label map must map onto the base graph's node names)."""
    declared = {n["name"]: n for n in base.get("nodes", [])}
    unknown = [n for n in nodes if n not in declared]
    if unknown:
        hint = (" (labels outside the map make a node of their own: map every label onto "
                "one of the graph's nodes)" if unknown[0].startswith(OUTSIDE) else "")
        raise DataError(f"{unknown[0]!r} is not a node of graph {base.get('name')!r} (its "
                        f"nodes: {', '.join(declared)}){hint}", field="--label-map")
    return {n: declared[n] for n in nodes}


def graph_from_labels(sequences, label_map: dict, *, name: str = "learned",
                      families: dict | None = None, sources: str = "",
                      base: dict | None = None, samples: dict | None = None) -> dict:
    """The graph document (``datasets_spec/GRAPHS.md``) of the module notes from label
    sequences; ``families`` maps a node to its extra model declarations
    (``{role: (model name, declaration)}``).  ``base`` (a graph document): the nodes keep
    that graph's models, transient flags and labels, and only the edges, their
    probabilities and the initial probabilities are learned.  ``samples``: each node's
    labelled samples at the rate the observer reads (then each edge's probability is per
    sample, ``n_ij / N_i``; without them ``n_ij / n_i``, per change)."""
    nodes = _node_order(label_map)
    declared = _base_nodes(base, nodes) if base is not None else {}
    first, pairs = count_transitions(sequences)
    seen = {n for seq in sequences for n in seq}
    missing = [n for n in nodes if n not in seen]
    if missing:
        raise DataError(f"no labelled sample of node {missing[0]!r} (labels mapped onto it: "
                        f"{', '.join(k for k, v in label_map.items() if v == missing[0])})",
                        field="ground_truth/labels")
    total = sum(first.values())
    out_n = Counter()
    for (a, _), n in pairs.items():
        out_n[a] += n
    edges = sorted(pairs, key=lambda ab: (nodes.index(ab[0]), nodes.index(ab[1])))
    models: dict = {}
    doc_nodes = []
    for node in nodes:
        labels = [k for k, v in label_map.items() if v == node]
        if node in declared:                # the base graph's models, as it declares them
            decl = declared[node]
            roles = decl["models"]
            used = [roles] if isinstance(roles, str) else list(roles.values())
            models.update({m: base["models"][m] for m in used})
            entry = {"name": node, "label": decl.get("label", f"labels {', '.join(labels)}"),
                     "models": roles}
            if decl.get("transient"):
                entry["transient"] = True
            stateless = all(base["models"][m].get("kind") == "gaussian" for m in used)
            entry["self_transition"] = decl.get("self_transition", not stateless)
        else:
            roles = {"phase": node}
            models[node] = {"kind": "gaussian", "signal": "phase", "trained": node}
            for role, (mname, decl) in (families or {}).get(node, {}).items():
                roles[role] = mname
                models[mname] = decl
            entry = {"name": node, "label": f"labels {', '.join(labels)}", "models": roles,
                     "self_transition": False}
        if first.get(node):
            entry["initial"] = round(first[node] / total, 6)
        doc_nodes.append(entry)
    # initial probabilities that sum to 1 after rounding
    given = [n for n in doc_nodes if "initial" in n]
    if given:
        given[-1]["initial"] = round(1.0 - sum(n["initial"] for n in given[:-1]), 6)
    doc = {"name": name,
           "title": f"Task phases learned from labels ({', '.join(nodes)})",
           "description": sources,
           "actions": [ACTION],
           "sides": "increase",
           "survivors": True,
           "edges": [],
           "models": models,
           "nodes": doc_nodes}
    if base is not None:
        doc["title"] = f"{base.get('title', base.get('name'))}, edges learned from labels"
        for key in ("sides", "thesis"):
            doc.pop(key, None)
            if key in base:
                doc[key] = base[key]
    if edges:
        per = {a: max(samples.get(a, 0), out_n[a]) if samples else out_n[a] for a, _ in edges}
        doc["edge_sets"] = [{"actions": [ACTION],
                             "edges": [f"{a} -> {b}" for a, b in edges],
                             "probabilities": [_prob(pairs[(a, b)] / per[a]) for a, b in edges]}]
    return doc


def _prob(p: float) -> float:
    """A probability as the graph file keeps it: six significant digits."""
    return float(f"{p:.6g}")


def _families(extra, stats: dict, rate_hz: float) -> dict:
    """Per node, the extra model declarations of the module notes."""
    out: dict = {}
    nodes = list(stats)
    f0 = stats[nodes[0]]["force"] if nodes else None
    for node, st in stats.items():
        fam = {}
        if "constraint" in extra and st["has_position"]:
            contact = f0 is not None and np.linalg.norm(st["force"] - f0) > CONTACT_N
            fam["constraint"] = (f"{node}-constraint",
                                 {"kind": "constraint", "constraint": "1" if contact else "0",
                                  "trained": node, "mode": "estimated" if contact else "fixed"})
        if "velocity" in extra and st["has_position"]:
            fam["velocity"] = (f"{node}-velocity", {"kind": "velocity-moving", "trained": node})
        if "temporal" in extra and rate_hz >= TEMPORAL_MIN_HZ:
            fam["hf"] = (f"{node}-temporal", {"kind": "temporal", "signal": "wrench",
                                               "trained": node})
        out[node] = fam
    return out


def learn_from_labels(archives, label_map: dict, *, trials=None, name: str | None = None,
                      extra=(), quiet: bool = True, base=None) -> tuple[dict, dict]:
    """``(document, summary)``: the graph of the module notes from the labelled trials of
    ``archives`` (paths), ``trials`` (ids) if given.  ``base``: a graph (name, file or
    :class:`~contactlab.observer.graph.FeatureGraph`) whose nodes' models the learned
    graph keeps (:func:`graph_from_labels`)."""
    if base is not None:
        base = base_document(base)
        if extra:
            raise ValueError("extra model families go with the phase Gaussians, not with a "
                             "base graph's models")
    from contactlab.archive import open_archive
    from contactlab.progress import progress

    bad = sorted(set(extra) - set(EXTRA_FAMILIES))
    if bad:
        raise ValueError(f"unknown model family {bad[0]!r} (known: {', '.join(EXTRA_FAMILIES)})")
    if not label_map:
        raise ValueError("a label map is needed (the recording's labels -> node names)")
    sequences, used, rates = [], [], []
    outside = OUTSIDE if OUTSIDE not in label_map.values() else f"{OUTSIDE}-task"
    full = dict(label_map)
    with_outside = dict(label_map)
    for path in archives:         # labels outside the task, when the map leaves some out
        with open_archive(Path(path)) as arch:
            for tid in arch.select(trials):
                trial = arch.trial(tid)
                if trial.labels is not None and any(str(n) in label_map
                                                    for n in trial.label_names or []):
                    with_outside.update(outside_map(trial, label_map, outside))
    if len(with_outside) > len(label_map):
        full = with_outside
    nodes = _node_order(full)
    force = {n: [] for n in nodes}
    samples: Counter = Counter()
    has_pos = True
    raw_labels: set = set()
    for path in archives:
        path = Path(path)
        with open_archive(path) as arch:
            for tid in progress(arch.select(trials), desc="labels", quiet=quiet, unit="trial"):
                trial = arch.trial(tid)
                if trial.labels is None:
                    continue
                raw_labels.update(str(n) for n in (trial.label_names or []))
                seq, runs = label_sequences(trial, full)
                if not seq:
                    continue
                factor = factor_for(float(trial.rate_hz))     # the conditioned rate's
                for a, b, k in runs:
                    samples[seq[k]] += (b - a) / factor
                sequences.append(seq)
                used.append(f"{path.name}:{tid}")
                rates.append(float(trial.rate_hz))
                has_pos = has_pos and getattr(trial, "position", None) is not None
                w = getattr(trial, "wrench", None)
                if w is not None:
                    w = np.asarray(w, np.float64)
                    for a, b, k in runs:
                        force[seq[k]].append(w[a:b, :3])
    from contactlab.observer.kinematics import check_map_sources, unmatched_map_note

    if not sequences:
        check_map_sources(label_map, raw_labels, file=str(archives[0]))
        raise DataError("no trial has labels the label map names", file=str(archives[0]),
                        field="/trials/*/ground_truth/labels")
    stats = {n: {"force": np.concatenate(force[n]).mean(axis=0) if force[n] else np.zeros(3),
                 "has_position": has_pos} for n in nodes}
    fam = _families(tuple(extra), stats, min(rates)) if extra else None
    src = ", ".join(Path(a).name for a in archives)
    doc = graph_from_labels(sequences, full, name=name or "learned", families=fam,
                            sources=f"learned from the labels of {len(sequences)} trials of {src}",
                            base=base, samples=samples)
    first, pairs = count_transitions(sequences)
    summary = {"trials": used, "nodes": nodes,
               "label_map": ",".join(f"{k}={v}" for k, v in full.items()),
               "initial": {n["name"]: n.get("initial", 0.0) for n in doc["nodes"]},
               "transitions": {f"{a} -> {b}": n for (a, b), n in sorted(pairs.items())},
               "models": {n["name"]: n["models"] for n in doc["nodes"]},
               "notes": unmatched_map_note(label_map, raw_labels, src)
               + ([] if base is not None else small_forces_note(stats))}
    return doc, summary


def small_forces_note(stats: dict) -> list[str]:
    """A note (in a list, empty when none) when the phases' mean forces differ by less
    than three times the wrench offset between recordings that the phase models allow
    (:data:`contactlab.signals.PHASE_OFFSET_SD`, a wrist sensor's scale): an apparatus
    with forces that small should set its own (``wrench_offset_sd``)."""
    from contactlab.signals import PHASE_OFFSET_SD

    means = np.array([v["force"] for v in stats.values() if np.any(v["force"] != 0)])
    if len(means) < 2:
        return []
    spread = float(np.max(means.max(axis=0) - means.min(axis=0)))
    if spread >= 3.0 * PHASE_OFFSET_SD[0]:
        return []
    return [f"the phases' mean forces differ by at most {spread:.3g} N, beside the "
            f"{PHASE_OFFSET_SD[0]:g} N offset between recordings the phase models allow "
            "(a wrist sensor's scale): for an apparatus with forces this small, set "
            "wrench_offset_sd = [force N, torque N m] in the graph's gaussian models"]


def base_document(graph) -> dict:
    """The TOML document of a graph (a bundled name, a file, or a loaded
    :class:`~contactlab.observer.graph.FeatureGraph`) as its file states it."""
    import tomllib

    from contactlab.observer.graph import FeatureGraph, load_graph

    g = graph if isinstance(graph, FeatureGraph) else load_graph(graph)
    if not g.source:
        raise ValueError(f"graph {g.name!r} has no file to take its models from")
    with open(g.source, "rb") as f:
        return tomllib.load(f)


def refine_with_em(doc: dict, archives, *, label_map: dict, trials=None, quiet: bool = True,
                   source: str | None = None) -> tuple[dict, dict]:
    """``doc`` refined by EM (10.1.3): the models trained from the labelled trials of the
    first archive, Baum-Welch over every run of ``archives``; edges EM adds join the edge
    set and every edge's probability becomes its learned transition probability per
    sample (the off-diagonal of Baum-Welch's transition matrix, averaged over the
    archives): the same measure as the label counts ``n_ij / N_i`` it refines, not the
    probability given a change, which is 1 along a chain of phases and would make every
    change free."""
    from contactlab.observer.graph import parse_graph
    from contactlab.observer.learning import learn_graph
    from contactlab.observer.recognize import bind_models
    from contactlab.observer.training import train_graph

    graph = parse_graph(doc, source=source)
    gm = train_graph(archives[0], graph, trials=trials, quiet=quiet, label_map=label_map)
    graph, gm, built = bind_models(graph, gm)
    out, added, trans, lls = None, [], {}, []
    for path in archives:
        d, s = learn_graph(path, graph, built, reduce=gm.reduce, trials=trials, quiet=quiet)
        out = d if out is None else out
        added += [e for e in s["added"] if e["edge"] not in {x["edge"] for x in added}]
        for e, p in s["transition_probabilities"].get(ACTION, {}).items():
            trans[e] = trans.get(e, 0.0) + p / len(archives)
        lls.append(s["loglik"][-1] if s["loglik"] else None)
    es = next(s for s in doc.get("edge_sets", []) if s["actions"] == [ACTION]) \
        if doc.get("edge_sets") else None
    new = dict(doc)
    if es is not None or added:
        edges = list(es["edges"]) if es else []
        edges += [e["edge"] for e in added if e["edge"] not in edges]
        probs = [trans.get(e, 0.0) for e in edges]
        total: dict = {}
        for e, p in zip(edges, probs):
            a = e.split("->")[0].strip()
            total[a] = total.get(a, 0.0) + p
        probs = [float(f"{p / max(1.0, total[e.split('->')[0].strip()]):.6g}")
                 for e, p in zip(edges, probs)]
        new["edge_sets"] = [{"actions": [ACTION], "edges": edges, "probabilities": probs}]
    return new, {"added": added, "transition_probabilities": trans, "final_loglik": lls}
