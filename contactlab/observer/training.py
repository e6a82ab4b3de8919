"""Training every model a feature graph names (``contactlab train --graph``, 7.3, 7.3.1).

For each ``[models.NAME]`` of a graph:

* ``temporal`` -- a :class:`~contactlab.temporal.TemporalModel` of the label
  ``trained``: the labelled runs of the model's conditioned signal are cut into
  blocks (never across a label change), each block's AR(``order``) (with a mean
  if ``mean``) orthogonal parameters and driving variance are computed, and
  the class prior is their mean and covariance (7.3, A.2.3; the same fit as
  ``contactlab train``);
* ``impact`` without inline parameters -- an
  :class:`~contactlab.observer.models.ImpactFeature` prior on the linear decay
  ``(mu, a)`` of the log energy fitted to every labelled run of ``trained``
  (7.1, :meth:`ImpactFeature.fit`), each run starting at its first sample;
* ``constraint`` and ``velocity-*`` without inline parameters -- fitted from
  the labelled runs of the ``contact`` / ``velocity`` signal
  (:mod:`contactlab.observer.kinematics`); inline velocity models and inline
  impacts carry their parameters in the graph file.

``label_map`` maps the archive's own label names (integer codes read as
their names) onto the graph's labels; unmapped labels are ignored.

Signals (the observer's measurement streams) come from
:func:`contactlab.signals.trial_signals`:
``hf`` is y_h of 7.1 with the log floor at half the strain quantisation step
(as the hf-models experiment), ``strain``/``wrench`` the 250 Hz lowpassed
signals, ``velocity``/``position`` the raw channels at the conditioned
samples' newest input sample.  ``reduce="mean"`` replaces a signal's channels
by their mean (one channel; the choice of hf-models, since the thesis's
fig 7.9 is one 2-D scatter), ``"none"`` keeps every channel (independent,
log-likelihoods add).  A conditioned sample carries a training label only if
every input sample it depends on has that label.

Everything is stored in one models file (``datasets_spec/MODELS.md``, "Graph
models"): the temporal models in the ``contactlab train`` layout (readable
by :meth:`ModelSet.load`), the impact priors under ``/impacts``, the signal
reduction and the graph's provenance in root attributes.
"""

from __future__ import annotations

import datetime as _dt
import os
import sys
from dataclasses import dataclass, field
from pathlib import Path

import h5py
import numpy as np

from contactlab import __version__
from contactlab import defaults as D
from contactlab.errors import DataError
from contactlab.observer.graph import FeatureGraph, load_graph
from contactlab.observer.kinematics import (check_map_sources,
                                            fit_kinematic_models, kinematic_specs,
                                            read_kinematic_models, write_kinematic_models)
from contactlab.observer.models.impact import ImpactFeature
from contactlab.fileio import sha256_file
from contactlab.signals import REDUCE, relabel, trial_signals, truth_codes, window_of
from contactlab.temporal.blocks import mask_runs

__all__ = ["GraphModels", "ImpactPrior", "train_graph", "fit_graph", "load_graph_models"]

_TRAINED_SIGNALS = ("hf", "strain", "wrench")


# -- the models file ---------------------------------------------------------------------

@dataclass(frozen=True)
class ImpactPrior:
    """A trained impact-decay prior: (C, 2) mean, (C, 2, 2) covariance of (mu, a), (C,) noise."""

    theta_mean: np.ndarray
    theta_cov: np.ndarray
    noise_var: np.ndarray


@dataclass
class GraphModels:
    """Every trained model a graph needs (what ``contactlab train --graph`` writes).

    temporal : label -> :class:`~contactlab.temporal.TemporalModel` (one signal).
    impacts : label -> :class:`~contactlab.observer.models.ImpactFeature`.
    signal, fs : the temporal models' conditioned signal and its rate.
    reduce : ``"mean"`` or ``"none"`` (see :func:`trial_signals`).
    provenance : archive, trials, settings, graph, created, version, command.
    channels : the signal's channels used (None: all; [] after a mean).
    source : the file it was read from (error messages).
    """

    temporal: dict
    impacts: dict
    signal: str
    fs: float
    reduce: str = "none"
    provenance: dict = field(default_factory=dict)
    channels: list | None = None
    source: str | None = None
    kinematic: dict = field(default_factory=dict)   # {"constraint": {}, "velocity": {}}

    @property
    def trained(self) -> dict:
        """label -> trained object, for :func:`~contactlab.observer.build_models`.

        Impacts are given as :class:`ImpactPrior` (theta_mean, theta_cov, noise_var)
        so that ``build_models`` names each model after its graph declaration.
        """
        out = dict(self.temporal)
        for lab, m in self.impacts.items():
            out[lab] = ImpactPrior(np.asarray(m.theta_mean), np.einsum(
                "cij,ckj->cik", m.theta_sqrt, m.theta_sqrt), np.asarray(m.noise_var))
        for ns, models in self.kinematic.items():
            out.update({f"{ns}:{lab}": m for lab, m in models.items()})
        return out

    @property
    def label_map(self) -> dict | None:
        """The archive label -> graph label map the models were trained with."""
        return self.provenance.get("label_map")

    @property
    def labels(self) -> list[str]:
        return list(self.trained)

    def save(self, path, *, force: bool = False) -> None:
        """Write atomically (refuses to overwrite unless ``force``)."""
        from contactlab.fileio import atomic_path
        from contactlab.temporal import ModelSet

        if not self.temporal and not any(self.kinematic.values()):
            raise ValueError("a models file needs at least one trained model")
        ms = ModelSet(models=dict(self.temporal), signal=self.signal, fs=self.fs,
                      provenance=self.provenance, channels=self.channels)
        with atomic_path(path, force=force) as tmp:
            if self.temporal:
                ms.save(tmp, force=True)
            else:
                _save_header(ms, tmp)
            with h5py.File(tmp, "r+") as h5:
                write_kinematic_models(h5, self.kinematic)
                h5.attrs["reduce"] = self.reduce
                g = h5.create_group("impacts")
                for i, (label, m) in enumerate(self.impacts.items()):
                    sub = g.create_group(str(i))
                    sub.attrs["label"] = label
                    sub.attrs["signal"] = m.signal
                    sub.attrs["n_segments"] = int(getattr(m, "n_segments_", 0))
                    sub.create_dataset("theta_mean", data=np.asarray(m.theta_mean, np.float64))
                    sub.create_dataset("theta_cov", data=np.einsum(
                        "cij,ckj->cik", m.theta_sqrt, m.theta_sqrt))
                    sub.create_dataset("noise_var", data=np.asarray(m.noise_var, np.float64))

    @classmethod
    def load(cls, path) -> "GraphModels":
        """Read a models file (also a plain ``contactlab train`` one: no impacts, no reduce).

        A file HDF5 cannot read (damaged bytes in a dataset or an attribute) is a
        one-line DataError naming it, like every other mistake in it."""
        try:
            return cls._load(path)
        except (OSError, KeyError, RuntimeError) as exc:   # h5py's errors on damaged bytes
            raise DataError(f"damaged models file: HDF5 cannot read it ({exc})",
                            file=str(path)) from None

    @classmethod
    def _load(cls, path) -> "GraphModels":
        ms = _load_model_set(path)
        impacts: dict = {}
        reduce = "none"
        with h5py.File(path, "r") as h5:
            kinematic = read_kinematic_models(h5, path)
            r = h5.attrs.get("reduce", "none")
            reduce = r.decode() if isinstance(r, bytes) else str(r)
            if reduce not in REDUCE:
                raise DataError(f"unknown reduce {reduce!r} (known: {', '.join(REDUCE)})",
                                file=str(path), field="/reduce")
            g = h5.get("impacts")
            for key in (sorted(g, key=int) if isinstance(g, h5py.Group) else []):
                where = f"/impacts/{key}"
                sub = g[key]
                try:
                    label = str(sub.attrs["label"])
                    mean = np.asarray(sub["theta_mean"][()], np.float64)
                    cov = np.asarray(sub["theta_cov"][()], np.float64)
                    var = np.asarray(sub["noise_var"][()], np.float64)
                    sig = str(sub.attrs.get("signal", ms.signal))
                    m = ImpactFeature(name=label, theta_mean=mean,
                                      theta_sqrt=np.linalg.cholesky(cov), noise_var=var,
                                      signal=sig)
                except (KeyError, ValueError, np.linalg.LinAlgError) as exc:
                    raise DataError(f"bad impact prior ({exc})", file=str(path),
                                    field=where) from None
                m.n_segments_ = int(sub.attrs.get("n_segments", 0))
                impacts[label] = m
        return cls(temporal=dict(ms.models), impacts=impacts, signal=ms.signal, fs=ms.fs,
                   reduce=reduce, provenance=ms.provenance, channels=ms.channels,
                   source=str(path), kinematic=kinematic)


def _save_header(ms, path) -> None:
    """A models file without temporal models: the ModelSet's root attributes, no labels."""
    import json

    from contactlab.temporal.model import FORMAT, FORMAT_VERSION

    with h5py.File(path, "w") as h5:
        h5.attrs["format"] = FORMAT
        h5.attrs["format_version"] = FORMAT_VERSION
        h5.attrs["signal"] = ms.signal
        h5.attrs["fs"] = float(ms.fs)
        h5.attrs.create("labels", np.array([], dtype=object), dtype=h5py.string_dtype("utf-8"))
        h5.attrs["channels"] = json.dumps(ms.channels)
        h5.attrs["provenance"] = json.dumps(ms.provenance, sort_keys=True)
        h5.create_group("models")


def _load_model_set(path):
    """:meth:`ModelSet.load`, or the header of a file without temporal models."""
    from contactlab.temporal import ModelSet
    from contactlab.archive.reader import open_h5

    h5 = open_h5(Path(path))
    try:
        labels = h5.attrs.get("labels")
        empty = labels is not None and np.size(labels) == 0
    finally:
        h5.close()
    if not empty:
        return ModelSet.load(path)
    import json

    with h5py.File(path, "r") as h5:
        try:
            return ModelSet(models={}, signal=str(h5.attrs["signal"]), fs=float(h5.attrs["fs"]),
                            provenance=json.loads(h5.attrs["provenance"]),
                            channels=json.loads(h5.attrs["channels"]))
        except (KeyError, ValueError, TypeError) as exc:
            raise DataError(f"malformed models file ({exc})", file=str(path)) from None


def load_graph_models(path) -> GraphModels:
    """:meth:`GraphModels.load` (one-line DataError naming the file on bad input)."""
    return GraphModels.load(path)


# -- training ----------------------------------------------------------------------------


def _longest_runs(trial, transient: dict, longest: dict) -> None:
    """Update ``longest`` (node -> seconds) with the trial's longest labelled run of each
    transient node (``transient``: node -> the labels that name it, after the label map):
    the duration ``recognize`` holds the node at most."""
    names = list(getattr(trial, "label_names", None) or [])
    if not transient or trial.labels is None or not names:
        return
    _longest_in(np.asarray(trial.labels), names, float(trial.rate_hz), transient, longest)


def _longest_in(codes, names, rate_hz: float, transient: dict, longest: dict) -> None:
    """:func:`_longest_runs` on label ``codes`` (indices into ``names``) at ``rate_hz``."""
    for node, labels in transient.items():
        lab = next((x for x in labels if x in names), None)
        if lab is None:
            continue
        runs = mask_runs(codes == names.index(lab))
        if runs:
            secs = max(b - a for a, b in runs) / rate_hz
            longest[node] = max(longest.get(node, 0.0), secs)


def node_labels(graph) -> dict:
    """Per node of ``graph``, the (mapped) label that names it in training data: its own
    name, else the one label every trained model of the node is trained on (a node
    renamed from its models' label); nodes whose models disagree (free-contact's impact,
    read by a contact and a free-space model) have none."""
    out = {}
    for n in graph.nodes:
        trained = {lab for m in n.model_names for lab in graph.models[m].trained_labels}
        out[n.name] = [n.name] + (sorted(trained - {n.name}) if len(trained) == 1 else [])
    return out


def _dwell_in(codes, names, rate_hz: float, nodes: dict, dwell: dict, first: dict) -> None:
    """Add to ``dwell`` (node -> [labelled seconds, labelled changes out of it]) and to
    ``first`` (node -> recordings whose first labelled node it is) a recording's label
    ``codes`` (indices into ``names``, -1 unlabelled) at ``rate_hz``.  ``nodes``: node ->
    the labels that may name it, in order (:func:`node_labels`; a node's own name first,
    a label naming one node only); samples of other labels are skipped, so a change is
    between consecutive samples of two nodes (a node's restart is not seen)."""
    order = list(nodes)
    claimed = {}
    for rank in range(2):              # every node's own name first, then its models' label
        for k, node in enumerate(order):
            if k in claimed.values() or len(nodes[node]) <= rank:
                continue
            lab = nodes[node][rank]
            if lab in names and lab not in claimed:
                claimed[lab] = k
    lookup = np.array([claimed.get(n, -1) for n in names] + [-1], np.int64)
    node = lookup[np.asarray(codes, np.int64)]
    node = node[node >= 0]
    if not node.size:
        return
    first[order[node[0]]] = first.get(order[node[0]], 0) + 1
    secs = np.bincount(node, minlength=len(order)) / float(rate_hz)
    out = np.bincount(node[:-1][node[1:] != node[:-1]], minlength=len(order))
    for k, name in enumerate(order):
        if secs[k] > 0 or out[k]:
            d = dwell.setdefault(name, [0.0, 0])
            d[0] += float(secs[k])
            d[1] += int(out[k])


def _example_label(seen) -> str:
    """A label of the recording to show in a --label-map example: never ``0``, which
    integer-coded recordings use for unlabelled or before-and-after samples."""
    return next((s for s in sorted(seen) if s not in ("0", "-1")), "1")


def _no_label(lab, seen, path, label_map, field, unmatched=()) -> DataError:
    """The one-line error for a graph label the (mapped) ground truth lacks: the labels it
    has, the --label-map entries that matched nothing, or, without a map, how to give one."""
    from contactlab.observer.graph_learn import OUTSIDE

    hint = (f"; --label-map entries matching no label: {', '.join(unmatched)}" if unmatched
            else f"; a learned graph's {lab!r} node trains on the labels the task's map "
            f"leaves out: train with the map 'graph learn' printed (it adds L={lab})"
            if label_map and lab.startswith(OUTSIDE) else "" if label_map else
            "; map the recording's labels onto the graph's with --label-map, e.g. "
            f"--label-map \"{_example_label(seen)}={lab}\"")
    return DataError(f"no label {lab!r} in the ground truth (labels: "
                     f"{', '.join(sorted(seen))}{hint})",
                     file=None if path is None else str(path), field=field)


@dataclass
class _LabelledData:
    """What :func:`train_graph` reads from an archive's labelled trials: the temporal
    models' block features and the impact segments per label, the kinematic models' runs
    per (signal, label), the labels seen (after and before the label map), the trials
    used, their rate and each transient node's longest labelled run."""

    feats: dict
    segs: dict
    kin_runs: dict
    seen_labels: set
    raw_labels: set
    ids_used: list
    fs: float | None
    longest: dict
    dwell: dict
    first: dict


@dataclass
class _Plan:
    """What a graph asks of training: the labels its temporal, impact and kinematic
    models are trained on, the signals they read, each transient node's labels."""

    temporal_specs: dict
    impact_specs: dict
    kin_labels: set
    kin_signals: set
    labels: list
    all_signals: list
    signal: str
    transient: dict
    nodes: dict


def _plan(graph: FeatureGraph) -> _Plan:
    """The training :class:`_Plan` of ``graph``; DataError (file ``graph.source``, field
    ``models``) when it names nothing to train, temporal models of different signals or
    a model on a signal that cannot be trained."""
    gsrc = graph.source or "<graph>"
    temporal_specs, impact_specs = {}, {}
    for name, spec in graph.models.items():
        if spec.kind == "temporal":
            temporal_specs.setdefault(spec.trained, spec)
        elif spec.kind == "impact" and "theta_mean" not in spec.params:
            impact_specs.setdefault(spec.trained, spec)
    kin_specs = kinematic_specs(graph)
    kin_labels = {lab for spec in kin_specs.values() for lab in spec.trained_labels}
    signals = {s.signal for s in temporal_specs.values()}
    if not temporal_specs and not kin_specs:
        raise DataError("the graph names no model to train", file=gsrc, field="models")
    if len(signals) > 1:
        raise DataError(f"temporal models read different signals {sorted(signals)}; one "
                        "models file holds one signal", file=gsrc, field="models")
    signal = signals.pop() if signals else "wrench"
    bad = [s.signal for s in list(temporal_specs.values()) + list(impact_specs.values())
           if s.signal not in _TRAINED_SIGNALS]
    if bad:
        raise DataError(f"cannot train a model on signal {bad[0]!r} (trainable: "
                        f"{', '.join(_TRAINED_SIGNALS)})", file=gsrc, field="models")
    labels = list(dict.fromkeys(list(temporal_specs) + list(impact_specs) + sorted(kin_labels)))
    kin_signals = {spec.signal for spec in kin_specs.values()}
    all_signals = sorted({s.signal for s in impact_specs.values()} | kin_signals
                         | ({signal} if temporal_specs else set()))
    # a transient node's labelled runs: its own name's, else those its impact models are
    # trained on (9.1.1's impact node "1" reads the "impact" labels); not those of its
    # other models (free-contact's impact reads the contact's frame, trained on contact)
    transient = {n.name: [n.name] + [lab for m in n.model_names
                                     if graph.models[m].kind == "impact"
                                     for lab in graph.models[m].trained_labels]
                 for n in graph.nodes if n.transient}
    return _Plan(temporal_specs, impact_specs, kin_labels, kin_signals, labels, all_signals,
                 signal, transient, node_labels(graph))


def _new_labelled(plan: _Plan) -> _LabelledData:
    return _LabelledData({lab: [] for lab in plan.temporal_specs},
                         {lab: [] for lab in plan.impact_specs}, {}, set(), set(), [], None, {},
                         {}, {})


def _cut(acc: _LabelledData, plan: _Plan, data: dict, codes_of, *, order, mean,
         block) -> None:
    """One recording's conditioned signals ``data`` cut into the runs of each label (codes
    into ``plan.labels`` per sample of each signal: ``codes_of(signal)``): the kinematic
    models' runs, the temporal models' block features, the impact segments, added to
    ``acc``."""
    from contactlab.temporal.blocks import cut_blocks
    from contactlab.temporal.features import block_features

    labels = plan.labels
    for s in plan.all_signals:
        codes = codes_of(s)
        if s in plan.kin_signals:
            for k, lab in enumerate(labels):
                if lab in plan.kin_labels:
                    acc.kin_runs.setdefault((s, lab), []).extend(
                        data[s][a:b] for a, b in mask_runs(codes == k))
        y = data[s]
        for k, lab in enumerate(labels):
            if lab in plan.temporal_specs and s == plan.signal:
                runs = np.array([(a, b, k) for a, b in mask_runs(codes == k)],
                                dtype=np.int64).reshape(-1, 3)
                starts, _ = cut_blocks(runs, block)
                if starts.size:
                    acc.feats[lab].append(block_features(y, order=order, mean=mean,
                                                         block=block, starts=starts))
            if lab in plan.impact_specs and plan.impact_specs[lab].signal == s:
                acc.segs[lab].extend(y[a:b] for a, b in mask_runs(codes == k) if b - a >= 3)


def _read_labelled(path, trials, label_map, plan: _Plan, *, quiet, order, mean, block,
                   reduce) -> _LabelledData:
    """Each labelled trial's signals cut into the runs of each label (:func:`train_graph`)."""
    from contactlab.archive import open_archive
    from contactlab.archive.validate import raise_problems, trial_problems
    from contactlab.progress import progress

    acc = _new_labelled(plan)
    with open_archive(path) as arch:
        ids = arch.select(trials)
        for tid in progress(ids, desc="train", quiet=quiet, unit="trial"):
            trial = arch.trial(tid)
            raise_problems(path, trial_problems(trial))   # the arrays checked stay cached
            if trial.labels is None:
                continue
            acc.raw_labels.update(str(n) for n in (trial.label_names or []))
            trial = relabel(trial, label_map)
            acc.seen_labels.update(n for n in (trial.label_names or []) if n is not None)
            data, index, acc.fs = trial_signals(trial, plan.all_signals, reduce=reduce,
                                                path=path)
            acc.ids_used.append(tid)
            _longest_runs(trial, plan.transient, acc.longest)
            if trial.labels is not None and trial.label_names:
                _dwell_in(trial.labels, list(trial.label_names), float(trial.rate_hz),
                          plan.nodes, acc.dwell, acc.first)
            _cut(acc, plan, data,
                 lambda s: truth_codes(trial, index, plan.labels,
                                       window=window_of(s, trial.rate_hz)),
                 order=order, mean=mean, block=block)
    return acc


def _fit_temporal(feats, temporal_specs, seen_labels, path, label_map, *, order, mean,
                  block) -> dict:
    """The temporal models of 7.3 (:func:`~contactlab.temporal.model.fit_class`) from each
    label's block features."""
    from contactlab.temporal.features import BlockFeatures
    from contactlab.temporal.model import fit_class

    temporal = {}
    for lab, parts in feats.items():
        spec = temporal_specs[lab]
        if lab not in seen_labels:
            raise _no_label(lab, seen_labels, path, label_map,
                            f"ground_truth/labels (graph models.{spec.name}.trained)")
        width = parts[0].orthogonal.shape[1] if parts else 1
        f = BlockFeatures.concat(parts, order=order, mean=mean, block=block, channels=width)
        try:
            temporal[lab] = fit_class(lab, f, block=block)
        except ValueError as exc:
            raise DataError(str(exc), file=None if path is None else str(path),
                            field="ground_truth/labels") from None
    return temporal


def _fit_impacts(segs, impact_specs, seen_labels, path, label_map) -> dict:
    """The impact models (:meth:`ImpactFeature.fit`) from each label's
    segments."""
    impacts = {}
    for lab, ss in segs.items():
        spec = impact_specs[lab]
        if lab not in seen_labels:
            raise _no_label(lab, seen_labels, path, label_map,
                            f"ground_truth/labels (graph models.{spec.name}.trained)")
        try:
            m = ImpactFeature(name=lab, signal=spec.signal).fit(ss)
        except ValueError as exc:
            raise DataError(str(exc), file=None if path is None else str(path),
                            field="ground_truth/labels") from None
        impacts[lab] = m
    return impacts


def _fit_models(graph, plan: _Plan, data: _LabelledData, path, label_map, *, order, mean,
                block) -> tuple[dict, dict, dict]:
    """The temporal, impact and kinematic models from the cut runs."""
    temporal = _fit_temporal(data.feats, plan.temporal_specs, data.seen_labels, path,
                             label_map, order=order, mean=mean, block=block)
    impacts = _fit_impacts(data.segs, plan.impact_specs, data.seen_labels, path, label_map)
    missing = sorted(lab for lab in plan.kin_labels if lab not in data.seen_labels)
    if missing:
        unmatched = [src for src in (label_map or {}) if str(src) not in data.raw_labels]
        raise _no_label(missing[0], data.seen_labels, path, label_map,
                        "ground_truth/labels" + (" (after --label-map)" if label_map else ""),
                        unmatched)
    kinematic = fit_kinematic_models(graph, data.kin_runs,
                                     source=None if path is None else str(path))
    return temporal, impacts, kinematic


def fit_graph(graph, recordings, *, fs: float, labels, order: int = D.GRAPH_ORDER,
              mean: bool = D.GRAPH_MEAN, block: int = D.BLOCK,
              reduce: str = D.GRAPH_REDUCE) -> GraphModels:
    """Fit every trained model ``graph`` names from labelled recordings given as arrays
    (:func:`train_graph` does the same from an archive's trials).

    Parameters
    ----------
    graph : a :class:`FeatureGraph` or a graph file path.
    recordings : a sequence of ``(signals, codes)``: ``signals`` maps each signal the
        graph's models read to its conditioned samples, ``(n,)`` or ``(n, channels)`` at
        rate ``fs`` (as :func:`~contactlab.signals.trial_signals` gives them); ``codes``
        the label of each sample, an ``(n,)`` array of indices into ``labels`` (-1:
        unlabelled), or a dict of such arrays per signal.
    fs : the signals' rate, Hz.
    labels : the label names the codes index; a graph model's ``trained`` label is one
        of them.
    order, mean, block, reduce : as for :func:`train_graph` (``reduce`` is recorded: the
        signals are taken as given).

    Returns the :class:`GraphModels` (``save`` writes the models file ``train`` writes).
    Raises DataError for a label with no data, too few blocks or impacts, or a frame the
    data do not determine.
    """
    if not isinstance(graph, FeatureGraph):
        graph = load_graph(graph)
    plan = _plan(graph)
    labels = [str(n) for n in labels]
    acc = _new_labelled(plan)
    acc.fs = float(fs)
    # the codes into the plan's labels (-1: unlabelled, or a label no model is trained on)
    table = np.array([plan.labels.index(n) if n in plan.labels else -1 for n in labels]
                     + [-1], np.int64)
    for i, (signals, codes) in enumerate(recordings):
        missing = [s for s in plan.all_signals if s not in signals]
        if missing:
            raise ValueError(f"recording {i} lacks signal {missing[0]!r} (the graph's models "
                             f"read {', '.join(plan.all_signals)})")
        data = {s: np.asarray(signals[s], float).reshape(len(signals[s]), -1)
                for s in plan.all_signals}
        given = {s: np.asarray(codes[s] if isinstance(codes, dict) else codes, np.int64)
                 for s in plan.all_signals}
        for s, c in given.items():
            if c.shape != (len(data[s]),) or c.max(initial=-1) >= len(labels):
                raise ValueError(f"recording {i}: the codes of {s!r} must be one index into "
                                 f"labels (or -1) per sample ({len(data[s])})")

        def codes_of(s, given=given):
            return table[np.maximum(given[s], -1)]
        present = {labels[c] for g in given.values() for c in np.unique(g) if c >= 0}
        acc.seen_labels.update(present)
        acc.raw_labels.update(present)
        acc.ids_used.append(str(i))
        _longest_in(given[plan.all_signals[0]], labels, float(fs), plan.transient, acc.longest)
        _dwell_in(given[plan.all_signals[0]], labels, float(fs), plan.nodes, acc.dwell,
                  acc.first)
        _cut(acc, plan, data, codes_of, order=order, mean=mean, block=block)
    temporal, impacts, kinematic = _fit_models(graph, plan, acc, None, None, order=order,
                                               mean=mean, block=block)
    provenance = {
        "label_map": None, "archive": None, "trials": acc.ids_used, "labels": "truth",
        "classes": list(temporal), "impacts": list(impacts), "skipped": {},
        "signal": plan.signal, "reduce": reduce, "block": int(block), "order": int(order),
        "mean": bool(mean), "blocks": {k: m.n_blocks for k, m in temporal.items()},
        "impact_segments": {k: len(v) for k, v in acc.segs.items()},
        "transient_longest_s": acc.longest,
        "node_dwell": acc.dwell,
        "node_first": acc.first,
        "graph": {"name": graph.name, "source": graph.source},
        "created": _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"),
        "contactlab_version": __version__, "command": "fit_graph",
    }
    return GraphModels(temporal=temporal, impacts=impacts, signal=plan.signal, fs=float(fs),
                       reduce=reduce, provenance=provenance,
                       channels=None if reduce == "none" else [], kinematic=kinematic)


def train_graph(archive, graph, *, order: int = D.GRAPH_ORDER, mean: bool = D.GRAPH_MEAN,
                block: int = D.BLOCK,
                reduce: str = D.GRAPH_REDUCE, trials=None, quiet: bool = True,
                command: str | None = None, label_map: dict | None = None) -> GraphModels:
    """Fit every trained model ``graph`` names from the labelled trials of ``archive``.

    Parameters
    ----------
    archive : path of an archive with ground-truth labels named like the graph's
        ``trained`` labels.
    graph : a :class:`FeatureGraph` or a graph file path.
    order, mean, block : the temporal models' AR(order) (+ mean) and training
        block length (7.3: a mean and one AR coefficient, units of 100).
    reduce : ``"mean"`` (channel mean) or ``"none"`` (see :func:`trial_signals`).
    trials : trial ids to use (default all).
    label_map : archive label name -> graph label (unmapped labels ignored).

    Raises DataError (one line, file and field) for a label with no data, too
    few blocks or impacts, a frame the data do not determine, or a graph whose
    temporal models read different signals.
    """
    if not isinstance(graph, FeatureGraph):
        graph = load_graph(graph)
    if reduce not in REDUCE:
        raise ValueError(f"reduce must be one of {REDUCE}; got {reduce!r}")
    plan = _plan(graph)
    path = Path(archive)
    data = _read_labelled(path, trials, label_map, plan, quiet=quiet, order=order, mean=mean,
                          block=block, reduce=reduce)
    if not data.ids_used:
        raise DataError("no trial has ground-truth labels", file=str(path),
                        field="/trials/*/ground_truth/labels")
    check_map_sources(label_map, data.raw_labels, file=str(path),
                      field="/trials/*/ground_truth/labels")
    temporal, impacts, kinematic = _fit_models(graph, plan, data, path, label_map,
                                               order=order, mean=mean, block=block)
    signal, segs, ids_used, longest, fs = (plan.signal, data.segs, data.ids_used,
                                           data.longest, data.fs)
    provenance = {
        "label_map": label_map,
        "constraints": {k: getattr(m, "n_segments_", 0)
                        for k, m in kinematic["constraint"].items()},
        "archive": str(path.resolve()), "archive_sha256": sha256_file(path), "trials": ids_used,
        "labels": "truth", "classes": list(temporal), "impacts": list(impacts), "skipped": {},
        "signal": signal, "reduce": reduce, "block": int(block), "order": int(order),
        "mean": bool(mean), "blocks": {k: m.n_blocks for k, m in temporal.items()},
        "impact_segments": {k: len(v) for k, v in segs.items()},
        "transient_longest_s": longest,
        "node_dwell": data.dwell,
        "node_first": data.first,
        "labels_read": sorted(data.raw_labels),
        "graph": {"name": graph.name, "source": graph.source,
                  "sha256": sha256_file(Path(graph.source)) if graph.source
                  and Path(graph.source).is_file() else None},
        "created": _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"),
        "contactlab_version": __version__,
        "command": command if command is not None else " ".join(
            [os.path.basename(sys.argv[0])] + sys.argv[1:]),
    }
    return GraphModels(temporal=temporal, impacts=impacts, signal=signal, fs=float(fs),
                       reduce=reduce, provenance=provenance,
                       channels=None if reduce == "none" else [], kinematic=kinematic)

