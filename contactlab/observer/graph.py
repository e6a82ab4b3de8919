"""Feature graphs (chapter 5.3, 9.1) and their TOML files.

A :class:`FeatureGraph` holds the nodes (each a tuple of measurement models,
9.1.1), the model declarations, the edges -- always-active ones and
action-dependent edge sets (9.1.3) --, the initial probabilities
``pi(0)`` (6.1), which nodes are transient (impacts, 5.1) and which allow
self-transitions (a new draw of the parameters within a node, 6.1).

:func:`load_graph` reads and validates a file; every mistake is one
:class:`~contactlab.errors.DataError` naming the file and the field.  The
format is documented in ``datasets_spec/GRAPHS.md``.
"""

from __future__ import annotations

import difflib
import math
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from contactlab import defaults as D
from contactlab.errors import DataError, UsageError
from contactlab.signals import CONTACT_SIGNALS

__all__ = ["ModelSpec", "Node", "FeatureGraph", "load_graph", "parse_graph", "MODEL_KINDS",
           "UNAVAILABLE_KINDS", "bundled_graphs", "graph_path"]

#: model kinds the observer implements, with the parameters each accepts
#: (name -> required?); see contactlab.observer.models
MODEL_KINDS: dict[str, dict[str, bool]] = {
    "temporal": {"trained": False, "mean_sd": False},
    "impact": {"trained": False, "theta_mean": False, "theta_sd": False, "noise_var": False},
    "velocity-fixed": {"sigma": False, "trained": False},
    "velocity-moving": {"low": False, "high": False, "sigma": False, "trained": False},
    "constraint": {"constraint": True, "trained": False, "mode": False, "rotate_deg": False,
                   "noise_scale": False, "offset_sd": False, "prior_samples": False,
                   "change_size": False, "position_sd": False, "force_sd": False},
    "gaussian": {"trained": False, "wrench_offset_sd": False},
}
#: kinds a graph may name that the observer cannot run, with the reason
UNAVAILABLE_KINDS: dict[str, str] = {}
_UNAVAILABLE_PARAMS: dict[str, dict] = {}

#: Signals a graph model may read (7.1 conditioning, plus the kinematic channels;
#: the contact streams are position then force, what the constraint models read,
#: :data:`contactlab.signals.CONTACT_SIGNALS`).
KNOWN_SIGNALS = ("hf", "strain", "wrench", "velocity", "position", "phase") + CONTACT_SIGNALS

_DEFAULT_SIGNAL = {"temporal": "hf", "impact": "hf", "velocity-fixed": "velocity",
                   "velocity-moving": "velocity", "constraint": "contact", "gaussian": "phase"}
_TOP_KEYS = {"name", "title", "thesis", "description", "actions", "initial", "models", "nodes",
             "edges", "edge_sets", "sides", "p_prune", "survivors", "change_prior"}
_NODE_KEYS = {"name", "label", "models", "initial", "transient", "self_transition"}
_PROB_TOL = 1e-6
#: a graph's ``change_prior`` (:attr:`FeatureGraph.change_prior`)
CHANGE_PRIORS = ("trained", "none")


@dataclass(frozen=True)
class ModelSpec:
    """A model declaration ``[models.NAME]``: its kind, the signal it reads, parameters."""

    name: str
    kind: str
    signal: str
    params: dict = field(default_factory=dict, hash=False, compare=False)

    @property
    def trained(self) -> str:
        """The label of the trained model this declaration uses (default: its name); a
        list of labels (constraint and velocity models) is named by joining them with "+"."""
        return "+".join(self.trained_labels)

    @property
    def trained_labels(self) -> tuple[str, ...]:
        """The ground-truth labels whose samples train this model (``trained`` may be one
        label or, for constraint and velocity models, a list: a free, moving sample
        trains both the free-space constraint and the moving-velocity model)."""
        t = self.params.get("trained", self.name)
        return tuple(str(x) for x in t) if isinstance(t, list) else (str(t),)


@dataclass(frozen=True)
class Node:
    """A feature node: a label and its models, one per role (e.g. hf, constraint, velocity)."""

    name: str
    label: str
    models: tuple[tuple[str, str], ...]      # (role, model name) in file order
    initial: float
    transient: bool
    self_transition: bool

    @property
    def model_names(self) -> tuple[str, ...]:
        return tuple(m for _, m in self.models)


@dataclass(frozen=True)
class FeatureGraph:
    """A validated feature graph.

    ``edges`` are always active; ``action_edges[a]`` are active only while
    the commanded action is ``a`` (an index into ``actions``).  Node indices
    follow file order.
    """

    name: str
    title: str
    nodes: tuple[Node, ...]
    models: dict[str, ModelSpec]
    edges: frozenset[tuple[int, int]]
    action_edges: dict[int, frozenset[tuple[int, int]]]
    actions: tuple[str, ...] = ()
    thesis: str = ""
    source: str | None = None
    sides: str | None = None      # the detectors' sides this graph is meant for (None: default)
    #: transition probabilities per action, ``{action: {(i, j): p}}`` (edge sets'
    #: ``probabilities``; counted by a forward projection or learned by EM)
    edge_probabilities: dict[int, dict[tuple[int, int], float]] = field(default_factory=dict)
    #: the probability mass the observer keeps when pruning for this graph (None: default;
    #: 1.0: paths are rejected by the log-likelihood gap alone, as in 9.1.1)
    p_prune: float | None = None
    #: the pruning also keeps the best path ending in each node (Viterbi's survivors; for
    #: graphs whose changes carry probabilities, as the graphs learned from labels)
    survivors: bool = False
    #: where the edges carry no probabilities: ``"trained"``, a change out of node i costs
    #: ``log(h_i / R_i)``, h_i the node's rate of labelled changes per sample in the
    #: models' training and R_i its other successors (the supervised HMM's transition matrix
    #: with the graph's edges split evenly); ``"none"``: every change is free, as 6.1
    #: wrote it (the thesis had no transition probabilities)
    change_prior: str = "trained"
    #: ``initial = "trained"``: the initial probabilities come from the models' training,
    #: the share of labelled trials whose first labelled node is each (add-one smoothed,
    #: as the supervised HMM counts its start probabilities); uniform until then
    initial_trained: bool = False
    #: successor table per action code (filled on first use; not part of the graph)
    _succ: dict = field(default_factory=dict, compare=False, repr=False)
    #: the observer's compiled-core transition tables per transitions setting (filled on
    #: first use; not part of the graph)
    _tables: dict = field(default_factory=dict, compare=False, repr=False)

    @property
    def trained_change_prior(self) -> bool:
        """Whether the observer prices this graph's changes from the models' training
        (``change_prior = "trained"`` and edges without probabilities)."""
        return self.change_prior == "trained" and not self.edge_probabilities

    # -- lookups -------------------------------------------------------------------
    @property
    def n_nodes(self) -> int:
        return len(self.nodes)

    @property
    def node_names(self) -> tuple[str, ...]:
        return tuple(n.name for n in self.nodes)

    @property
    def initial(self) -> np.ndarray:
        """(K,) the initial probabilities pi(0)."""
        return np.array([n.initial for n in self.nodes])

    @property
    def action_dependent(self) -> bool:
        return bool(self.action_edges)

    def index(self, name: str) -> int:
        try:
            return self.node_names.index(name)
        except ValueError:
            raise KeyError(f"no node {name!r} in graph {self.name!r}") from None

    def action_index(self, action) -> int:
        """The code of ``action`` (an index, or a name from ``actions``)."""
        if isinstance(action, str):
            if action not in self.actions:
                raise KeyError(f"unknown action {action!r}; graph {self.name!r} has "
                               f"{list(self.actions)}")
            return self.actions.index(action)
        return int(action)

    def active_edges(self, action=None) -> frozenset[tuple[int, int]]:
        """Edges active under ``action`` (None: the always-active edges only)."""
        if action is None or not self.action_edges:
            return self.edges
        return self.edges | self.action_edges.get(self.action_index(action), frozenset())

    def successors(self, node: int, action=None) -> tuple[int, ...]:
        """Nodes a path in ``node`` may change to (itself if it self-transitions), sorted."""
        key = None if action is None or not self.action_edges else self.action_index(action)
        table = self._succ.get(key)
        if table is None:                    # one pass over the edges for every node
            out = [set() for _ in self.nodes]
            for i, j in self.active_edges(action):
                out[i].add(j)
            for i, n in enumerate(self.nodes):
                if n.self_transition:
                    out[i].add(i)
            table = self._succ[key] = tuple(tuple(sorted(s)) for s in out)
        return table[node]

    def adjacency(self, action=None) -> np.ndarray:
        """(K, K) boolean: ``[i, j]`` when a path in i may change to j (self-transitions on the diagonal)."""
        a = np.zeros((self.n_nodes, self.n_nodes), dtype=bool)
        for i, j in self.active_edges(action):
            a[i, j] = True
        for i, n in enumerate(self.nodes):
            a[i, i] = n.self_transition
        return a

    def with_initial(self, initial) -> "FeatureGraph":
        """A copy with other initial probabilities: a (K,) array or {node name: p}."""
        if isinstance(initial, Mapping):
            p = np.zeros(self.n_nodes)
            for k, v in initial.items():
                p[self.index(k)] = float(v)
        else:
            p = np.asarray(initial, dtype=float)
            if p.shape != (self.n_nodes,):
                raise ValueError(f"initial must have {self.n_nodes} entries; got {p.shape}")
        if np.any(p < 0) or not math.isclose(p.sum(), 1.0, abs_tol=_PROB_TOL):
            raise ValueError(f"initial probabilities must be >= 0 and sum to 1; got {p.tolist()}")
        nodes = tuple(Node(n.name, n.label, n.models, float(q), n.transient, n.self_transition)
                      for n, q in zip(self.nodes, p))
        # the edges are this graph's: so are the successor and transition tables
        return FeatureGraph(self.name, self.title, nodes, self.models, self.edges,
                            self.action_edges, self.actions, self.thesis, self.source,
                            self.sides, self.edge_probabilities, self.p_prune,
                            self.survivors, self.change_prior, False, _succ=self._succ,
                            _tables=self._tables)

    def to_dict(self) -> dict:
        """A JSON-able description (what ``contactlab graph show --json`` prints)."""
        names = self.node_names

        def pairs(edges):
            return [[names[i], names[j]] for i, j in sorted(edges)]

        return {
            "name": self.name, "title": self.title, "thesis": self.thesis, "source": self.source,
            "actions": list(self.actions), "sides": self.sides, "p_prune": self.p_prune,
            "survivors": self.survivors, "change_prior": self.change_prior,
            "initial_trained": self.initial_trained,
            "models": {k: {"kind": m.kind, "signal": m.signal, **m.params}
                       for k, m in self.models.items()},
            "nodes": [{"name": n.name, "label": n.label, "models": dict(n.models),
                       "initial": None if self.initial_trained else n.initial,
                       "transient": n.transient,
                       "self_transition": n.self_transition} for n in self.nodes],
            "edges": pairs(self.edges),
            "edge_sets": [{"actions": [self.actions[a] if a < len(self.actions) else a],
                           "edges": pairs(e),
                           **({"probabilities": [self.edge_probabilities[a].get(ij, 0.0)
                                                 for ij in sorted(e)]}
                              if a in self.edge_probabilities else {})}
                          for a, e in sorted(self.action_edges.items())],
        }


# -- loading -----------------------------------------------------------------------------

def bundled_graphs() -> dict[str, Path]:
    """The feature graphs shipped with the package: name -> file (found with
    :mod:`importlib.resources`, so they resolve after any install, from any directory)."""
    from importlib.resources import files

    root = files("contactlab.datasets_spec") / "graphs"
    if not root.is_dir():
        return {}
    return {p.name[:-5]: Path(str(p)) for p in root.iterdir() if p.name.endswith(".toml")}


def graph_path(name) -> Path:
    """``name`` as a path if that file exists, else the bundled graph of that name
    (``hf-context``, ``hf-context.toml`` or ``datasets_spec/graphs/hf-context.toml``)."""
    path = Path(name)
    if path.exists():
        return path
    stem = path.name[:-5] if path.name.endswith(".toml") else path.name
    return bundled_graphs().get(stem, path)


def load_graph(path) -> FeatureGraph:
    """Read and validate a feature-graph TOML file (format: ``datasets_spec/GRAPHS.md``);
    a name that is not a file is looked up among the bundled graphs (:func:`graph_path`)."""
    path = graph_path(path)
    try:
        raw = path.read_bytes()
    except FileNotFoundError:
        names = sorted(bundled_graphs())
        if path.parent == Path(".") and path.suffix != ".toml":   # a name, not a file
            near = difflib.get_close_matches(path.name, names, n=1)
            raise UsageError(f"no bundled graph {path.name!r}"
                             + (f" (did you mean {near[0]}?)" if near else "")
                             + f"; bundled: {', '.join(names)}") from None
        raise DataError(f"no such file, nor a bundled graph (bundled: {', '.join(names)})",
                        file=str(path)) from None
    except OSError as exc:
        raise DataError(f"cannot read ({exc.strerror})", file=str(path)) from None
    try:
        doc = tomllib.loads(raw.decode("utf-8"))
    except RecursionError:
        raise DataError("TOML nested too deeply to be a feature graph", file=str(path),
                        field="toml") from None
    except UnicodeDecodeError:
        raise DataError("not UTF-8 text (a feature graph is a TOML file)", file=str(path)) from None
    except tomllib.TOMLDecodeError as exc:
        raise DataError(f"TOML syntax error: {exc}", file=str(path), field="toml") from None
    return parse_graph(doc, source=str(path))


def parse_graph(doc: Mapping, *, source: str | None = None) -> FeatureGraph:
    """Validate a parsed graph document (a dict as from :mod:`tomllib`)."""
    def err(fld, msg):
        return DataError(msg, file=source or "<graph>", field=fld)

    if not isinstance(doc, Mapping):
        raise err(None, "a graph must be a table")
    extra = set(doc) - _TOP_KEYS
    if extra:
        raise err(sorted(extra)[0], f"unknown key (allowed: {', '.join(sorted(_TOP_KEYS))})")
    name = _string(doc.get("name", Path(source).stem if source else "graph"), "name", err)
    title = _string(doc.get("title", name), "title", err)
    thesis = _string(doc.get("thesis", ""), "thesis", err)

    actions = doc.get("actions", [])
    if not isinstance(actions, list) or not all(isinstance(a, str) and a for a in actions):
        raise err("actions", "must be a list of action names (index = action code)")
    if len(set(actions)) != len(actions):
        raise err("actions", "action names must be distinct")

    models = _parse_models(doc.get("models"), err)
    nodes = _parse_nodes(doc.get("nodes"), models, err)
    names = [n["name"] for n in nodes]

    # initial probabilities
    init_mode = doc.get("initial")
    given = [n["initial"] is not None for n in nodes]
    if init_mode is not None:
        if init_mode not in ("uniform", "trained"):
            raise err("initial", "must be \"uniform\" or \"trained\" (or give each node an "
                      f"initial); got {init_mode!r}")
        if any(given):
            raise err("initial", f"\"{init_mode}\" and per-node initial values are exclusive")
        init = [1.0 / len(nodes)] * len(nodes)
    else:
        if not any(given):
            raise err("initial", "no initial probabilities: set initial = \"uniform\" or "
                      "\"trained\", or "
                      "give nodes an initial value")
        init = [n["initial"] if n["initial"] is not None else 0.0 for n in nodes]
        total = math.fsum(init)
        if not math.isclose(total, 1.0, abs_tol=_PROB_TOL):
            raise err("nodes.initial", f"initial probabilities sum to {total:.6g}, not 1")

    edges = _parse_edges(doc.get("edges", []), names, "edges", err)
    action_edges: dict[int, frozenset] = {}
    edge_probs: dict[int, dict[tuple[int, int], float]] = {}
    sets = doc.get("edge_sets", [])
    if not isinstance(sets, list):
        raise err("edge_sets", "must be an array of tables ([[edge_sets]])")
    for k, es in enumerate(sets):
        where = f"edge_sets[{k}]"
        if not isinstance(es, Mapping):
            raise err(where, "must be a table with actions and edges")
        bad = set(es) - {"actions", "edges", "probabilities"}
        if bad:
            raise err(f"{where}.{sorted(bad)[0]}", "unknown key (allowed: actions, edges, probabilities)")
        acts = es.get("actions")
        if not isinstance(acts, list) or not acts:
            raise err(f"{where}.actions", "must be a non-empty list of action names or codes")
        e = _parse_edges(es.get("edges", []), names, f"{where}.edges", err)
        for a in acts:
            if isinstance(a, str):
                if a not in actions:
                    raise err(f"{where}.actions", f"unknown action {a!r} (declared: {actions})")
                code = actions.index(a)
            elif isinstance(a, int) and not isinstance(a, bool) and a >= 0:
                if actions and a >= len(actions):
                    raise err(f"{where}.actions", f"action code {a} out of range "
                              f"(0..{len(actions) - 1})")
                code = a
            else:
                raise err(f"{where}.actions", f"not an action name or code: {a!r}")
            action_edges[code] = action_edges.get(code, frozenset()) | e
            if "probabilities" in es:
                edge_probs.setdefault(code, {}).update(
                    _parse_probabilities(es, names, f"{where}.probabilities", err))

    node_objs = tuple(Node(n["name"], n["label"], n["models"], float(p), n["transient"],
                           n["self_transition"]) for n, p in zip(nodes, init))
    sides = doc.get("sides")
    if sides is not None and sides not in D.OBSERVER_SIDE_CHOICES:
        raise err("sides", f"must be one of {', '.join(D.OBSERVER_SIDE_CHOICES)}; got {sides!r}")
    p_prune = doc.get("p_prune")
    if p_prune is not None and not (isinstance(p_prune, (int, float)) and not isinstance(p_prune, bool)
                                    and 0 < p_prune <= 1):
        raise err("p_prune", f"must be a number in (0, 1]; got {p_prune!r}")
    survivors = doc.get("survivors", False)
    if not isinstance(survivors, bool):
        raise err("survivors", f"must be true or false; got {survivors!r}")
    change_prior = doc.get("change_prior", "trained")
    if change_prior not in CHANGE_PRIORS:
        raise err("change_prior", f"must be one of {', '.join(CHANGE_PRIORS)}; "
                  f"got {change_prior!r}")
    graph = FeatureGraph(name, title, node_objs, models, edges, action_edges, tuple(actions),
                         thesis, source, sides, edge_probs,
                         None if p_prune is None else float(p_prune), survivors, change_prior,
                         init_mode == "trained")
    _check_reachable(graph, err)
    _check_transients(graph, err)
    return graph


def _string(v, fld, err) -> str:
    if not isinstance(v, str):
        raise err(fld, f"must be a string; got {v!r}")
    return v


def _parse_models(raw, err) -> dict[str, ModelSpec]:
    if not isinstance(raw, Mapping) or not raw:
        raise err("models", "missing: declare each model as a [models.NAME] table")
    out = {}
    for name, spec in raw.items():
        where = f"models.{name}"
        if not isinstance(spec, Mapping):
            raise err(where, "must be a table with a kind")
        kind = spec.get("kind")
        known = (MODEL_KINDS.get(kind) or _UNAVAILABLE_PARAMS.get(kind)) \
            if isinstance(kind, str) else None
        if known is None:
            raise err(f"{where}.kind", f"unknown model kind {kind!r} (known: "
                      f"{', '.join(list(MODEL_KINDS) + list(UNAVAILABLE_KINDS))})")
        signal = spec.get("signal", _DEFAULT_SIGNAL[kind])
        if not isinstance(signal, str) or signal not in KNOWN_SIGNALS:
            known_here = CONTACT_SIGNALS if kind == "constraint" else KNOWN_SIGNALS
            close = difflib.get_close_matches(str(signal), known_here, n=1)
            raise err(f"{where}.signal", f"unknown signal {signal!r}"
                      + (f"; did you mean {close[0]!r}?" if close else "")
                      + f" (known: {', '.join(known_here)})")
        if kind == "constraint" and signal not in CONTACT_SIGNALS:
            raise err(f"{where}.signal", f"a constraint model reads position then force: "
                      f"{' or '.join(CONTACT_SIGNALS)}; got {signal!r}")
        params = {k: v for k, v in spec.items() if k not in ("kind", "signal")}
        for k in params:
            if k not in known:
                raise err(f"{where}.{k}", f"unknown parameter for kind {kind!r} "
                          f"(allowed: {', '.join(sorted(known)) or 'none'})")
        for k, required in known.items():
            if required and k not in params:
                raise err(f"{where}.{k}", f"missing (required by kind {kind!r})")
        for k, v in params.items():
            if k in ("sigma", "low", "high", "noise_var", "noise_scale", "offset_sd",
                     "prior_samples", "change_size", "mean_sd", "position_sd", "force_sd"):
                if not isinstance(v, (int, float)) or isinstance(v, bool) or not math.isfinite(v):
                    raise err(f"{where}.{k}", f"must be a finite number; got {v!r}")
        for k in ("sigma", "noise_scale", "offset_sd", "prior_samples", "change_size", "mean_sd",
                  "position_sd", "force_sd"):
            if k in params and params[k] <= 0:
                raise err(f"{where}.{k}", f"must be > 0; got {params[k]!r}")
        if params.get("change_size") == 1:
            raise err(f"{where}.change_size", "must not be 1 (no change to detect)")
        t = params.get("trained")
        if isinstance(t, list) and (kind not in ("constraint", "velocity-fixed",
                                                 "velocity-moving")
                                    or not t or not all(isinstance(x, str) and x for x in t)):
            raise err(f"{where}.trained", "a list of labels trains constraint and velocity "
                      f"models only, and must hold label names; got {t!r}")
        if t is not None and not isinstance(t, (str, list)):
            raise err(f"{where}.trained", f"must be a label name or a list of them; got {t!r}")
        if kind == "velocity-moving":
            _check_moving(params, where, err)
        if kind == "impact":
            _check_impact_prior(params, where, err)
        if kind == "constraint":
            _check_constraint(params, where, err)
        if "wrench_offset_sd" in params:
            v = params["wrench_offset_sd"]
            if not (isinstance(v, list) and len(v) == 2 and all(
                    isinstance(x, (int, float)) and not isinstance(x, bool)
                    and math.isfinite(x) and x >= 0 for x in v)):
                raise err(f"{where}.wrench_offset_sd", "must be [force N, torque N m], two "
                          f"numbers >= 0; got {v!r}")
            if signal != "phase":
                raise err(f"{where}.wrench_offset_sd", "is the phase stream's wrench offset; "
                          f"this model reads {signal!r}")
            params["wrench_offset_sd"] = tuple(float(x) for x in v)
        out[name] = ModelSpec(name, kind, signal, params)
    _check_one_signal_per_label(out, err)
    return out


def _check_one_signal_per_label(models: dict, err) -> None:
    """Constraint models trained on the same labels share one trained model (the models
    file keys them by label), so they must read the same contact signal."""
    first: dict = {}
    for spec in models.values():
        if spec.kind != "constraint":
            continue
        other = first.setdefault(spec.trained, spec)
        if other.signal != spec.signal:
            raise err(f"models.{spec.name}.signal",
                      f"reads {spec.signal!r} but models.{other.name}, trained on the same "
                      f"labels, reads {other.signal!r}: one trained model per label, so give "
                      "them the same signal (or train them on different labels)")


def _check_moving(params, where, err) -> None:
    given = [k for k in ("low", "high", "sigma") if k in params]
    if given and given != ["sigma"] and len(given) < 2:
        missing = sorted({"low", "high"} - set(given))[0]
        raise err(f"{where}.{missing}", "inline velocity-moving parameters need low, high and "
                  "sigma, or low and high (sigma trained), or none (trained)")
    if given == ["sigma"]:
        raise err(f"{where}.low", "inline velocity-moving parameters need low, high and "
                  "sigma, or low and high (sigma trained), or none (trained)")
    if given and not params["low"] < params["high"]:
        raise err(f"{where}.high", f"must exceed low ({params['low']}); got {params['high']}")


def _check_constraint(params, where, err) -> None:
    from contactlab.observer.models.constraint import CONSTRAINT_MODES, parse_constraint

    c = params["constraint"]
    if isinstance(c, int) and not isinstance(c, bool):
        c = params["constraint"] = str(c)
    try:
        parse_constraint(c)
    except ValueError:
        raise err(f"{where}.constraint", f"must be a degree 0-3 or the constrained axes (Z, XZ, "
                  f"YZ, ...); got {c!r}") from None
    if params.get("mode", "fixed") not in CONSTRAINT_MODES:
        raise err(f"{where}.mode", f"must be one of {', '.join(CONSTRAINT_MODES)}; got "
                  f"{params['mode']!r}")
    r = params.get("rotate_deg")
    if r is not None and not (isinstance(r, list) and len(r) == 3 and all(
            isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x)
            for x in r)):
        raise err(f"{where}.rotate_deg", "must be three angles in degrees [x, y, z]")


def _check_impact_prior(params, where, err) -> None:
    inline = [k for k in ("theta_mean", "theta_sd", "noise_var") if k in params]
    if inline and len(inline) != 3:
        missing = sorted({"theta_mean", "theta_sd", "noise_var"} - set(inline))[0]
        raise err(f"{where}.{missing}", "an inline impact prior needs theta_mean, theta_sd "
                  "and noise_var")
    for k in ("theta_mean", "theta_sd"):
        if k in params:
            v = params[k]
            if (not isinstance(v, list) or len(v) != 2
                    or not all(isinstance(x, (int, float)) and math.isfinite(x) for x in v)):
                raise err(f"{where}.{k}", "must be two numbers [mu, a]")
    if "theta_sd" in params and min(params["theta_sd"]) <= 0:
        raise err(f"{where}.theta_sd", "standard deviations must be > 0")
    if "noise_var" in params and params["noise_var"] <= 0:
        raise err(f"{where}.noise_var", "must be > 0")


def _parse_nodes(raw, models, err) -> list[dict]:
    if not isinstance(raw, list) or not raw:
        raise err("nodes", "missing: give at least one [[nodes]] table")
    out, seen = [], set()
    for k, n in enumerate(raw):
        where = f"nodes[{k}]"
        if not isinstance(n, Mapping):
            raise err(where, "must be a table")
        bad = set(n) - _NODE_KEYS
        if bad:
            raise err(f"{where}.{sorted(bad)[0]}", f"unknown key (allowed: {', '.join(sorted(_NODE_KEYS))})")
        name = n.get("name")
        if isinstance(name, int) and not isinstance(name, bool):
            name = str(name)
        if not isinstance(name, str) or not name or "->" in name or name == "*" or "," in name:
            raise err(f"{where}.name", f"must be a non-empty name without '->', ',' or '*'; got {name!r}")
        if name in seen:
            raise err(f"{where}.name", f"duplicate node name {name!r}")
        seen.add(name)
        where = f"nodes[{k}] ({name})"
        label = n.get("label", name)
        if not isinstance(label, str):
            raise err(f"{where}.label", "must be a string")
        m = n.get("models")
        if isinstance(m, str):
            pairs = ((m, m),)
        elif isinstance(m, list) and m and all(isinstance(x, str) for x in m):
            pairs = tuple((x, x) for x in m)
        elif isinstance(m, Mapping) and m and all(isinstance(x, str) for x in m.values()):
            pairs = tuple((str(r), x) for r, x in m.items())
        else:
            raise err(f"{where}.models", "must name the node's model(s): \"S\", [\"S\", \"F\"] "
                      "or {hf = \"S\", velocity = \"F\"}")
        for role, model in pairs:
            if model not in models:
                raise err(f"{where}.models", f"unknown model {model!r} (declared: "
                          f"{', '.join(models)})")
        if len({mm for _, mm in pairs}) != len(pairs) or len({r for r, _ in pairs}) != len(pairs):
            raise err(f"{where}.models", "a node names each model and role once")
        init = n.get("initial")
        if init is not None:
            if not isinstance(init, (int, float)) or isinstance(init, bool) or not (0 <= init <= 1):
                raise err(f"{where}.initial", f"must be a probability in [0, 1]; got {init!r}")
            init = float(init)
        flags = {}
        for key, default in (("transient", False), ("self_transition", True)):
            v = n.get(key, default)
            if not isinstance(v, bool):
                raise err(f"{where}.{key}", f"must be true or false; got {v!r}")
            flags[key] = v
        out.append({"name": name, "label": label, "models": pairs, "initial": init, **flags})
    return out


def _parse_edges(raw, names, where, err) -> frozenset[tuple[int, int]]:
    if not isinstance(raw, list):
        raise err(where, "must be a list of \"A -> B\" strings")
    out = set()
    for k, e in enumerate(raw):
        fld = f"{where}[{k}]"
        if not isinstance(e, str) or e.count("->") != 1:
            raise err(fld, f"an edge is \"A -> B\" (B may list several: \"A -> B, C\"); got {e!r}")
        a, b = (s.strip() for s in e.split("->"))
        srcs = _endpoints(a, names, fld, err)
        dsts = _endpoints(b, names, fld, err)
        for i in srcs:
            for j in dsts:
                if i == j:
                    if a != "*" and b != "*":
                        raise err(fld, f"self edge {names[i]!r} -> {names[i]!r}: use the "
                                  "node's self_transition instead")
                    continue
                out.add((i, j))
    return frozenset(out)


def _parse_probabilities(es, names, where, err) -> dict[tuple[int, int], float]:
    """An edge set's ``probabilities``: one number in [0, 1] per edge of ``edges``, each edge
    then a single ``"A -> B"``; per source node they sum to at most 1 (the rest: no change)."""
    probs, edges = es["probabilities"], es.get("edges", [])
    if not isinstance(probs, list) or len(probs) != len(edges):
        raise err(where, f"must be a list of {len(edges)} numbers, one per edge")
    out: dict[tuple[int, int], float] = {}
    for k, (e, p) in enumerate(zip(edges, probs)):
        if not isinstance(p, (int, float)) or isinstance(p, bool) or not 0.0 <= p <= 1.0:
            raise err(f"{where}[{k}]", f"must be a probability in [0, 1]; got {p!r}")
        a, b = (x.strip() for x in e.split("->"))
        if a not in names or b not in names:
            raise err(f"{where}[{k}]", f"edge {e!r} with a probability must join two named nodes")
        out[(names.index(a), names.index(b))] = float(p)
    total: dict[int, float] = {}
    for (i, _), p in out.items():
        total[i] = total.get(i, 0.0) + p
    for i, t in total.items():
        if t > 1.0 + 1e-3:
            raise err(where, f"probabilities out of node {names[i]!r} sum to {t:.4g} > 1")
    return out


def _endpoints(text, names, fld, err) -> list[int]:
    if text == "*":
        return list(range(len(names)))
    out = []
    for part in text.split(","):
        part = part.strip()
        if part not in names:
            raise err(fld, f"dangling edge: no node named {part!r}")
        out.append(names.index(part))
    return out


def _check_reachable(graph: FeatureGraph, err) -> None:
    adj = np.zeros((graph.n_nodes, graph.n_nodes), dtype=bool)
    for i, j in graph.edges.union(*graph.action_edges.values()) if graph.action_edges else graph.edges:
        adj[i, j] = True
    seen = graph.initial > 0
    frontier = seen.copy()
    while frontier.any():
        nxt = adj[frontier].any(axis=0) & ~seen
        seen |= nxt
        frontier = nxt
    if not seen.all():
        k = int(np.flatnonzero(~seen)[0])
        raise err(f"nodes[{k}] ({graph.nodes[k].name})",
                  "unreachable node: no initial probability and no path of edges leads to it")


def _check_transients(graph: FeatureGraph, err) -> None:
    every = graph.edges.union(*graph.action_edges.values()) if graph.action_edges else graph.edges
    for k, n in enumerate(graph.nodes):
        if n.transient and not any(i == k for i, _ in every):
            raise err(f"nodes[{k}] ({n.name}).transient",
                      "a transient (impact) node needs an edge out of it")
