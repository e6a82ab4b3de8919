"""Training and storing the constraint and velocity models of a feature graph (8.1.1, 9.1.1).

``contactlab train --graph`` fits, for every ``constraint`` declaration, a
:class:`~contactlab.observer.models.ConstraintFeature` from the labelled runs of
its ``trained`` label on the ``contact`` signal (position then force), and for
every ``velocity-fixed``/``velocity-moving`` declaration without inline
parameters a :class:`FixedVelocity`/:class:`MovingVelocity` from the labelled
runs on the ``velocity`` signal.  :func:`kinematic_specs` lists what a graph
needs, :func:`fit_kinematic_models` fits it from the collected runs, and
:func:`write_kinematic_models` / :func:`read_kinematic_models` store it in
the models file (``datasets_spec/MODELS.md``, "Constraint and velocity models").

The constraint models of one file share one normalisation of units (8.7-8.9):
the position and force accuracies are the white-noise levels of the training
runs after the 7.1 lowpass (:func:`contactlab.constraints.noise.raw_noise_sd`
on the conditioned signal: the median over runs and axes), unless the graph's
constraint models state them (``position_sd``, ``force_sd``).
"""

from __future__ import annotations

import h5py
import numpy as np

from contactlab.errors import DataError, UsageError
from contactlab.observer.graph import FeatureGraph
from contactlab.observer.models.constraint import K, ConstraintFeature, parse_constraint
from contactlab.observer.models.gaussian import (GaussianFeature, read_gaussian_models,
                                                 write_gaussian_models)
from contactlab.observer.models.velocity import FixedVelocity, MovingVelocity
from contactlab.signals import CONTACT_SIGNALS, PHASE, phase_offset_sd

__all__ = ["kinematic_specs", "fit_kinematic_models", "write_kinematic_models",
           "read_kinematic_models", "parse_label_map", "check_label_map", "check_map_sources",
           "unmatched_map_note", "trial_label_names",
           "KINEMATIC_SIGNALS"]

KINEMATIC_SIGNALS = CONTACT_SIGNALS + ("velocity", "phase")
_VELOCITY = {"velocity-fixed": FixedVelocity, "velocity-moving": MovingVelocity}


def kinematic_specs(graph: FeatureGraph) -> dict:
    """Trained label -> the first declaration needing it (constraint, or velocity
    without inline parameters)."""
    out = {}
    for spec in graph.models.values():
        if spec.kind in ("constraint", "gaussian") or (spec.kind in _VELOCITY
                                                       and "sigma" not in spec.params):
            out.setdefault((spec.kind, spec.trained), spec)
    return out


def parse_label_map(text: str | None, *, field: str = "--label-map") -> dict | None:
    """``"1=free,2=contact,3=free"`` -> ``{"1": "free", ...}`` (None for None/empty).

    UsageError (exit 2) naming the option for a malformed entry or a label mapped twice."""
    if text is None or not str(text).strip():
        return None
    if ";" in str(text):
        raise UsageError(f"{field}: separate the entries with commas, not ';' (got {text!r})")
    out: dict[str, str] = {}
    for k, part in enumerate(str(text).split(",")):
        src, eq, dst = part.partition("=")
        src, dst = src.strip(), dst.strip()
        if not eq or not src or not dst:
            raise UsageError(f"{field}: entry {k + 1} {part.strip()!r} is not LABEL=NODE")
        if src in out and out[src] != dst:
            raise UsageError(f"{field}: label {src!r} mapped twice ({out[src]!r}, {dst!r})")
        out[src] = dst
    return out


def check_map_sources(label_map: dict | None, label_names, *, file=None,
                      field: str = "ground_truth/labels") -> None:
    """DataError when ``label_map`` maps none of ``label_names`` (the recording's own
    labels): a map made for other labels (a typo, another recording's names) would
    otherwise leave every sample unlabelled without a word.  A map may name labels a
    recording lacks, as long as one of its entries matches."""
    if not label_map or label_names is None:
        return
    names = {str(n) for n in label_names}
    if not any(str(src) in names for src in label_map):
        raise DataError(f"--label-map maps none of the recording's labels (its labels: "
                        f"{', '.join(sorted(names)) or 'none'}; the map's: "
                        f"{', '.join(map(str, label_map))})", file=file, field=field)


def check_label_map(label_map: dict | None, graph: FeatureGraph,
                    field: str = "--label-map") -> None:
    """UsageError (exit 2, as a misspelt option value) when a map's target is neither a
    node nor a trained label of ``graph``."""
    if not label_map:
        return
    known = set(graph.node_names) | {lab for s in graph.models.values()
                                     for lab in s.trained_labels}
    for src, dst in label_map.items():
        if dst not in known:
            raise UsageError(f"{field}: {src}={dst}: {dst!r} is not a node or trained label "
                             f"of graph {graph.name!r} (known: {', '.join(sorted(known))})")


def trial_label_names(trial) -> list[str] | None:
    """The names of ``trial``'s ground-truth labels (None without labels), for
    :func:`unmatched_map_note` over the trials a stage read."""
    names = getattr(trial, "label_names", None)
    if getattr(trial, "labels", None) is None or names is None:
        return None
    return [str(n) for n in names]


def unmatched_map_note(label_map: dict | None, label_names, where: str) -> list[str]:
    """A note (in a list, empty when none) naming the entries of ``label_map`` whose label
    no trial read carries: a map may cover labels some recordings lack, but an entry
    that matches nothing at all is more often a typo, which would otherwise pass without
    a word.  ``label_names``: every label of the trials read; ``where``: what they were
    (an archive, "the trials read")."""
    if not label_map or label_names is None:
        return []
    names = {str(n) for n in label_names}
    missing = [f"{src}={dst}" for src, dst in label_map.items() if str(src) not in names]
    if not missing:
        return []
    return [f"--label-map: no trial of {where} carries the label of "
            f"{', '.join(missing)} (their labels: {', '.join(sorted(names)) or 'none'})"]


#: Noise levels below these (1 nm, 1 uN) are no measurement noise: the runs are
#: noiseless or their quantisation was smoothed away by the 7.1 lowpass (a quantised
#: position that rests on one step has zero second differences).  Normalising by such
#: a level would make every millimetre of contact compliance look like 10^6 noise
#: units and the constraint forms' likelihoods be decided by their dimensions alone;
#: the toolkit's accuracies (contactlab.constraints.cartesian.POSITION_SD, FORCE_SD)
#: are used instead.
NOISELESS_POSITION = 1e-9
NOISELESS_FORCE = 1e-6


def _noise_level(segments, columns) -> float:
    from contactlab.constraints.noise import raw_noise_sd

    levels = [raw_noise_sd(s[:, columns]) for s in segments if len(s) >= 5]
    if not levels:
        return float("nan")
    return float(np.median(np.concatenate(levels)))


def _given_accuracies(graph: FeatureGraph, source) -> dict:
    """The accuracies (8.7-8.9) the graph's constraint models state (``position_sd``,
    ``force_sd``); every model of one graph shares one normalisation, so they must agree."""
    out: dict = {}
    for spec in graph.models.values():
        if spec.kind != "constraint":
            continue
        for key in ("position_sd", "force_sd"):
            if key in spec.params:
                v = float(spec.params[key])
                if out.setdefault(key, v) != v:
                    raise DataError(f"constraint models state different {key} ({out[key]:g}, "
                                    f"{v:g}); one graph has one normalisation (8.7-8.9)",
                                    file=graph.source, field=f"models.{spec.name}.{key}")
    return out


def fit_kinematic_models(graph: FeatureGraph, runs: dict, *, source: str | None = None) -> dict:
    """Fit every model of :func:`kinematic_specs` from labelled runs.

    ``runs`` maps ``(signal, label)`` to a list of (n_i, C) arrays (maximal runs of
    that label on that signal); a model trained on a list of labels pools their runs.  Returns label-keyed ``{"constraint": {...},
    "velocity": {...}}``.  DataError (file = ``source``) when a label has no data or
    the data do not determine a frame.
    """
    from contactlab.constraints.cartesian import FORCE_SD, POSITION_SD

    specs = kinematic_specs(graph)
    contact_runs = [s for (sig, _), ss in runs.items() if sig in CONTACT_SIGNALS for s in ss]
    pos_sd = _noise_level(contact_runs, slice(0, K))
    frc_sd = _noise_level(contact_runs, slice(K, 2 * K))
    pos_sd = pos_sd if np.isfinite(pos_sd) and pos_sd > NOISELESS_POSITION else POSITION_SD
    frc_sd = frc_sd if np.isfinite(frc_sd) and frc_sd > NOISELESS_FORCE else FORCE_SD
    given = _given_accuracies(graph, source)
    pos_sd, frc_sd = given.get("position_sd", pos_sd), given.get("force_sd", frc_sd)
    out: dict = {"constraint": {}, "velocity": {}, "gaussian": {}}
    for (kind, label), spec in specs.items():
        where = f"models.{spec.name}.trained"
        signal = spec.signal
        segs = [s for lab in spec.trained_labels for s in runs.get((signal, lab), [])]
        if not segs:
            raise DataError(f"no labelled samples of {label!r} to train {kind} model "
                            f"{spec.name!r}", file=source, field=f"ground_truth/labels "
                            f"(graph {where})")
        try:
            if kind == "constraint":
                m, N = parse_constraint(spec.params["constraint"])
                if N is not None and "rotate_deg" in spec.params:   # the graph's frame, as bound
                    from scipy.spatial.transform import Rotation

                    N = Rotation.from_euler("xyz", spec.params["rotate_deg"],
                                            degrees=True).as_matrix() @ N
                model = ConstraintFeature(name=label, degree=m, normals=N,
                                          mode=spec.params.get("mode", "fixed"),
                                          position_sd=pos_sd, force_sd=frc_sd, signal=signal)
                out["constraint"][label] = model.fit(segs)
            elif kind == "gaussian":
                offset = (phase_offset_sd(segs[0].shape[1],
                                          spec.params.get("wrench_offset_sd"))
                          if signal == PHASE else None)
                out["gaussian"][label] = GaussianFeature(name=label, signal=signal,
                                                         offset_sd=offset).fit(segs)
            else:
                out["velocity"][label] = _VELOCITY[kind](name=label).fit(segs)
        except ValueError as exc:
            raise DataError(str(exc), file=source, field=f"ground_truth/labels "
                            f"(graph {where})") from None
    return out


def write_kinematic_models(h5: h5py.File, models: dict) -> None:
    """Store the fitted models under ``/constraints/<i>`` and ``/velocity/<i>``."""
    g = h5.create_group("constraints")
    for i, (label, m) in enumerate(models.get("constraint", {}).items()):
        sub = g.create_group(str(i))
        sub.attrs["label"] = label
        sub.attrs["degree"] = int(m.degree)
        sub.attrs["mode"] = m.mode
        sub.attrs["signal"] = m.signal
        sub.attrs["n_segments"] = int(getattr(m, "n_segments_", 0))
        for key in ("position_sd", "force_sd", "offset_sd", "prior_samples"):
            sub.attrs[key] = float(getattr(m, key))
        sub.create_dataset("normals", data=np.asarray(m.normals, np.float64).reshape(K, -1))
        sub.create_dataset("V", data=np.asarray(m.V, np.float64))
    g = h5.create_group("velocity")
    for i, (label, m) in enumerate(models.get("velocity", {}).items()):
        sub = g.create_group(str(i))
        sub.attrs["label"] = label
        sub.attrs["kind"] = m.kind
        for key, v in m.params().items():
            sub.attrs[key] = float(v)
    if models.get("gaussian"):
        write_gaussian_models(h5, models["gaussian"])


def read_groups(h5: h5py.File, name: str, path, what: str, read) -> dict:
    """``{label: model}`` from the numbered groups ``/name/<i>`` of a models file;
    ``read(group) -> (label, model)``; DataError naming the group when one is bad."""
    out = {}
    g = h5.get(name)
    for key in (sorted(g, key=int) if isinstance(g, h5py.Group) else []):
        try:
            label, model = read(g[key])
        except (KeyError, ValueError, TypeError) as exc:
            raise DataError(f"bad {what} ({exc})", file=str(path),
                            field=f"/{name}/{key}") from None
        out[label] = model
    return out


def _read_constraint(sub):
    label = _text(sub.attrs["label"])
    N = np.asarray(sub["normals"][()], np.float64).reshape(K, -1)
    if N.shape[1] != int(sub.attrs["degree"]):
        raise ValueError(f"normals have {N.shape[1]} columns for degree "
                         f"{int(sub.attrs['degree'])}")
    m = ConstraintFeature(name=label, normals=N, V=np.asarray(sub["V"][()], np.float64),
                          mode=_text(sub.attrs["mode"]),
                          signal=_text(sub.attrs.get("signal", "contact")),
                          **{k: float(sub.attrs[k]) for k in (
                              "position_sd", "force_sd", "offset_sd", "prior_samples")})
    m.n_segments_ = int(sub.attrs.get("n_segments", 0))
    return label, m


def _read_velocity(sub):
    label = _text(sub.attrs["label"])
    cls = _VELOCITY[_text(sub.attrs["kind"])]
    keys = ("sigma",) if cls is FixedVelocity else ("low", "high", "sigma")
    return label, cls(name=label, **{k: float(sub.attrs[k]) for k in keys})


def read_kinematic_models(h5: h5py.File, path) -> dict:
    """The models :func:`write_kinematic_models` stored (empty when absent)."""
    return {"constraint": read_groups(h5, "constraints", path, "constraint model",
                                      _read_constraint),
            "velocity": read_groups(h5, "velocity", path, "velocity model", _read_velocity),
            "gaussian": read_gaussian_models(h5, path)}


def _text(v) -> str:
    return v.decode() if isinstance(v, bytes) else str(v)
