"""The contact feature observer (chapter 6): feature graphs, feature models, and
the change-triggered beam Viterbi search of section 6.4.

- :mod:`.graph` -- :class:`FeatureGraph` and the TOML loader/validator (:func:`load_graph`).
- :mod:`.models` -- the feature models (one interface, one module per family).
- :mod:`.paths` -- path histories, change events, trimmed buffers.
- :mod:`.events` -- 6.4's decisions at a detected change (alarms, candidates, pruning).
- :mod:`.observer` -- :class:`Observer` (incremental, ``update(chunk)``) and :func:`observe`.

Example::

    graph = load_graph("datasets_spec/graphs/hf-context-free.toml")
    models = build_models(graph, ModelSet.load("models.h5"))
    obs = Observer(graph, models, threshold=8.0, change_size=2.0)
    result = observe(obs, conditioned.hf)          # or obs.update(chunk) per chunk
    result.node_prob, result.map_path, result.events
"""

from contactlab.observer.graph import FeatureGraph, ModelSpec, Node, load_graph, parse_graph
from contactlab.observer.models import (CompositeNode, FeatureModel, FixedVelocity, ImpactFeature,
                                        ModelBank, MovingVelocity, TemporalFeature, build_models,
                                        node_models)
from contactlab.observer.observer import (Observer, ObserverResult, ObserverStep, labels_from_path,
                                          observe)
from contactlab.observer.paths import ChangeEvent, PathInfo
from contactlab.observer.recognize import observe_trial, recognize_archive, recognize_trial
from contactlab.observer.training import GraphModels, fit_graph, train_graph
from contactlab.signals import trial_signals

__all__ = [
    "FeatureGraph", "ModelSpec", "Node", "load_graph", "parse_graph",
    "FeatureModel", "ModelBank", "TemporalFeature", "ImpactFeature", "FixedVelocity",
    "MovingVelocity", "CompositeNode", "build_models", "node_models",
    "Observer", "ObserverStep", "ObserverResult", "observe", "labels_from_path",
    "ChangeEvent", "PathInfo",
    "recognize_archive", "recognize_trial", "observe_trial", "GraphModels", "train_graph", "fit_graph",
    "trial_signals",
]
