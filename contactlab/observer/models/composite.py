"""Composite nodes (9.1.1): a node is a tuple of models -- e.g. (high frequency,
constraint, velocity) -- whose log-likelihoods add (the signals are modelled as
independent given the node) and each of which has its own change detector; a
change in any of them is a change of the node (6.4).

:func:`build_models` binds the model declarations of a graph file to model
objects, using trained models where the declaration names one.
"""

from __future__ import annotations

import copy

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from contactlab.errors import DataError
from contactlab.observer.graph import UNAVAILABLE_KINDS, FeatureGraph, ModelSpec
from contactlab.observer.models.base import FeatureModel
from contactlab.observer.models.constraint import ConstraintFeature, parse_constraint
from contactlab.observer.models.gaussian import GaussianFeature
from contactlab.observer.models.impact import ImpactFeature
from contactlab.observer.models.temporal import TemporalFeature
from contactlab.observer.models.velocity import FixedVelocity, MovingVelocity

__all__ = ["CompositeNode", "build_models", "node_models"]


@dataclass(frozen=True)
class CompositeNode:
    """The models of one node, in the graph file's role order."""

    name: str
    roles: tuple[str, ...]
    models: tuple[FeatureModel, ...]


def node_models(graph: FeatureGraph, models: Mapping[str, FeatureModel]) -> list[CompositeNode]:
    """The :class:`CompositeNode` of every graph node, in node order."""
    missing = [m for m in graph.models if m not in models]
    if missing:
        raise ValueError(f"no model object for {missing[0]!r} (graph {graph.name!r} declares "
                         f"{list(graph.models)})")
    return [CompositeNode(n.name, tuple(r for r, _ in n.models),
                          tuple(models[m] for _, m in n.models)) for n in graph.nodes]


def build_models(graph: FeatureGraph, trained: Mapping | None = None, *,
                 source: str | None = None) -> dict[str, FeatureModel]:
    """Model objects for every declaration in ``graph``.

    ``trained`` maps a trained-model label to a trained object: a
    :class:`contactlab.temporal.TemporalModel` for ``temporal``, an
    :class:`ImpactFeature` (or anything with ``theta_mean``, ``theta_cov``,
    ``noise_var``) for ``impact``; a ``ModelSet`` may be passed as is.
    ``source`` names the models file in error messages.
    """
    if trained is not None and hasattr(trained, "models") and not isinstance(trained, Mapping):
        trained = trained.models
    trained = trained or {}
    out = {}
    for name, spec in graph.models.items():
        out[name] = _build(spec, trained, graph, source)
    return _paired_velocity(out)


def _paired_velocity(models: dict) -> dict:
    """Moving-velocity models of a graph that also has a fixed-velocity model on the same
    signal test the change to rest against that model's variance (the loosest, if several):
    9.1.1 uses the pair F/M as the test of whether the robot moves."""
    for name, m in models.items():
        if isinstance(m, MovingVelocity) and m.rest_sigma is None:
            rest = [f.sigma for f in models.values()
                    if isinstance(f, FixedVelocity) and f.signal == m.signal]
            if rest:
                models[name] = m.with_rest(max(rest))
    return models


def _build(spec: ModelSpec, trained: Mapping, graph: FeatureGraph, source) -> FeatureModel:
    where = f"models.{spec.name}"
    p = spec.params
    if spec.kind in UNAVAILABLE_KINDS:
        raise DataError(f"model kind {spec.kind!r} is not available "
                        f"({UNAVAILABLE_KINDS[spec.kind]})", file=graph.source,
                        field=f"{where}.kind")
    if spec.kind == "velocity-fixed" and "sigma" in p:
        return FixedVelocity(name=spec.name, sigma=p["sigma"], signal=spec.signal)
    if spec.kind == "velocity-moving" and "sigma" in p:
        return MovingVelocity(name=spec.name, low=p["low"], high=p["high"], sigma=p["sigma"],
                              signal=spec.signal)
    if spec.kind == "impact" and "theta_mean" in p:
        return ImpactFeature(name=spec.name, theta_mean=p["theta_mean"], theta_sqrt=p["theta_sd"],
                             noise_var=p["noise_var"], signal=spec.signal)
    label = spec.trained
    ns = {"constraint": "constraint", "velocity-fixed": "velocity",
          "velocity-moving": "velocity", "gaussian": "gaussian"}.get(spec.kind)
    if ns is not None and f"{ns}:{label}" in trained:     # a models file's namespaced entry
        label = f"{ns}:{label}"
    if label not in trained:
        raise DataError(f"no trained model {label!r} for {spec.kind} model {spec.name!r} "
                        f"(have: {', '.join(map(str, trained)) or 'none'})",
                        file=source or graph.source, field=f"{where}.trained")
    obj = trained[label]
    if spec.kind == "gaussian":
        if not isinstance(obj, GaussianFeature) or obj.signal != spec.signal:
            raise DataError(f"trained model {label!r} is not a Gaussian model of the "
                            f"{spec.signal!r} signal", file=source or graph.source,
                            field=f"{where}.trained")
        return _renamed(obj, spec)
    if spec.kind == "constraint":
        return _constraint(spec, obj, graph, source)
    if spec.kind in ("velocity-fixed", "velocity-moving"):
        cls = FixedVelocity if spec.kind == "velocity-fixed" else MovingVelocity
        if not isinstance(obj, cls):
            raise DataError(f"trained model {label!r} is not a {spec.kind} model",
                            file=source or graph.source, field=f"{where}.trained")
        if spec.kind == "velocity-moving" and "low" in p:   # the range given, the noise trained
            return MovingVelocity(name=spec.name, low=p["low"], high=p["high"], sigma=obj.sigma,
                                  signal=spec.signal)
        return _renamed(obj, spec)
    if spec.kind == "temporal":
        model = (_renamed(obj, spec) if isinstance(obj, TemporalFeature)
                 else TemporalFeature.from_trained(obj, name=spec.name, signal=spec.signal))
        return model.with_mean_sd(p["mean_sd"]) if "mean_sd" in p else model
    if isinstance(obj, ImpactFeature):
        return _renamed(obj, spec)
    if hasattr(obj, "order"):
        raise DataError(f"trained model {label!r} is an AR model; the impact model needs an "
                        "impact-decay prior (ImpactFeature.fit)", file=source or graph.source,
                        field=f"{where}.trained")
    return ImpactFeature(name=spec.name, theta_mean=obj.theta_mean,
                         theta_sqrt=np.linalg.cholesky(np.asarray(obj.theta_cov)),
                         noise_var=obj.noise_var, signal=spec.signal)


def _constraint(spec: ModelSpec, obj, graph: FeatureGraph, source) -> ConstraintFeature:
    """A graph's constraint declaration bound to a trained :class:`ConstraintFeature`:
    the trained frame when the graph gives a degree, else the graph's named (and
    rotated) frame; the trained ``V`` when the degrees agree (times ``noise_scale``)."""
    where = f"models.{spec.name}"
    p = spec.params
    if not isinstance(obj, ConstraintFeature):
        raise DataError(f"trained model {spec.trained!r} is not a constraint model",
                        file=source or graph.source, field=f"{where}.trained")
    if obj.signal != spec.signal:
        held = f" in {source}" if source else ""
        raise DataError(f"reads {spec.signal!r}, but its trained model {spec.trained!r}{held} "
                        f"was fitted on {obj.signal!r} (train again with this graph)",
                        file=graph.source or source, field=f"{where}.signal")
    m, N = parse_constraint(p["constraint"])
    if N is None:
        if obj.degree != m:
            raise DataError(f"trained model {spec.trained!r} has degree {obj.degree}; the graph "
                            f"asks for {m}", file=source or graph.source,
                            field=f"{where}.constraint")
        N = obj.normals
    if "rotate_deg" in p:
        from scipy.spatial.transform import Rotation

        N = Rotation.from_euler("xyz", p["rotate_deg"], degrees=True).as_matrix() @ N
    if obj.degree == m:
        V = obj.V
    else:       # another degree: the trained model's mean variances along normals / free dirs
        d = np.diag(obj.V)
        vn = d[:obj.degree].mean() if obj.degree else d.mean()
        vf = d[obj.degree:].mean() if obj.degree < len(d) else d.mean()
        V = np.diag([vn] * m + [vf] * (len(d) - m))
    V = V * float(p.get("noise_scale", 1.0))
    return ConstraintFeature(name=spec.name, normals=N, V=V, mode=p.get("mode", obj.mode),
                             position_sd=obj.position_sd, force_sd=obj.force_sd,
                             offset_sd=float(p.get("offset_sd", obj.offset_sd)),
                             prior_samples=float(p.get("prior_samples", obj.prior_samples)),
                             signal=spec.signal, change_size=p.get("change_size"))


def _renamed(model: FeatureModel, spec: ModelSpec) -> FeatureModel:
    """``model`` under the graph's name and signal for it (the observer keys models by
    the graph's names, which need not be the training labels)."""
    if model.name == spec.name and getattr(model, "signal", spec.signal) == spec.signal:
        return model
    out = copy.copy(model)
    out.name = spec.name
    out.signal = spec.signal
    return out
