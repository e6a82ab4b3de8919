"""contactlab: statistical contact sensing for robot manipulation.

An implementation of B. S. Eberman, "Contact Sensing: A Sequential Decision
Approach to Sensing Manipulation Contact Features", MIT AI-TR 1543 (1995).

The main classes and functions are importable from the package itself, e.g.
``from contactlab import Segmenter, Observer, load_graph, open_archive``
(listed in ``contactlab.__all__``).  They are imported on first use (PEP 562),
so ``import contactlab`` stays fast and loads none of the subpackages.

Subpackages and modules follow the thesis's figure 1.3 / 6.1, one box each:

- :mod:`contactlab.archive`       HDF5 trace archives (format in ``datasets_spec/ARCHIVE.md``)
- :mod:`contactlab.conditioning`  signal conditioning of section 7.1
- :mod:`contactlab.signals`       trials to conditioned signals and ground truth (7.1)
- :mod:`contactlab.payload`       a turning tool's weight and a wrist sensor's offset
- :mod:`contactlab.estimators`    square-root estimators of appendix A
- :mod:`contactlab.detection`     Page-Hinkley change detection of section 6.3.1
- :mod:`contactlab.segmentation`  change-detector segmentation of strains and forces (7.2.1)
- :mod:`contactlab.segmenter`     :class:`~contactlab.segmenter.Segmenter`, the same
  segmenters with the interface of ruptures and scikit-learn
- :mod:`contactlab.temporal`      trained temporal models and block labelling (chapter 7)
- :mod:`contactlab.observer`      feature graphs, feature models and the observer (chapter 6)
- :mod:`contactlab.constraints`   constraint estimation (8.1.1, 8.2, 8.3)
- :mod:`contactlab.planar`        planar polygon constraint estimation (8.1.2-8.1.3)
- :mod:`contactlab.maze`          the gear-shift maze of 9.2
- :mod:`contactlab.sim`           simulator of the PHANToM and fingertip-sensor apparatus
- :mod:`contactlab.acquire`       acquisition: simulated and real sources into an archive
- :mod:`contactlab.synthetic`     synthetic data with known truth, without the simulator
- :mod:`contactlab.peers`         the standard peers the methods are compared with
- :mod:`contactlab.experiments`   the thesis experiments (``contactlab reproduce``)
- :mod:`contactlab.report`        HTML/PDF reports
- :mod:`contactlab.metrics`       the confusion matrix of decisions against ground truth
- :mod:`contactlab.export`        recognition results as CSV tables
- :mod:`contactlab.errors`        the two error kinds: in a file, or in what was typed
- :mod:`contactlab.cli`           the ``contactlab`` command and its verbs (click)
- :mod:`contactlab.kernel_cache`  where numba keeps the compiled kernels
"""

from __future__ import annotations

import importlib

from contactlab.kernel_cache import configure as _configure_kernel_cache

__version__ = "0.1.0"

# compiled kernels are cached per state of the whole source (contactlab.kernel_cache):
# numba alone would keep a kernel compiled with an edited helper from another file
_configure_kernel_cache()

#: public name -> the module that defines it (imported on first access)
_EXPORTS = {
    # archives
    "open_archive": "contactlab.archive",
    "create_archive": "contactlab.archive",
    "validate_archive": "contactlab.archive",
    "import_csv": "contactlab.archive",
    "Archive": "contactlab.archive",
    "Trial": "contactlab.archive",
    # conditioning
    "condition_strains": "contactlab.conditioning",
    "velocity_from_position": "contactlab.conditioning",
    "trial_signals": "contactlab.signals",
    # estimators and detectors
    "SquareRootRLS": "contactlab.estimators",
    "SquareRootKalman": "contactlab.estimators",
    "ARModel": "contactlab.estimators",
    "PageHinkley": "contactlab.detection",
    "VarianceChangeDetector": "contactlab.detection",
    # segmentation
    "Segmenter": "contactlab.segmenter",
    "Segmentation": "contactlab.segmentation",
    "segment_level": "contactlab.segmentation",
    "segment_glr": "contactlab.segmentation",
    "segment_signal": "contactlab.segmentation",
    # temporal models
    "TemporalModel": "contactlab.temporal",
    "ModelSet": "contactlab.temporal",
    "train_temporal": "contactlab.temporal",
    "fit_temporal": "contactlab.temporal",
    # the observer
    "FeatureGraph": "contactlab.observer",
    "load_graph": "contactlab.observer",
    "Observer": "contactlab.observer",
    "ObserverResult": "contactlab.observer",
    "observe": "contactlab.observer",
    "build_models": "contactlab.observer",
    "train_graph": "contactlab.observer",
    "fit_graph": "contactlab.observer",
    "GraphModels": "contactlab.observer",
    "recognize_archive": "contactlab.observer",
    "ConstraintFeature": "contactlab.observer.models",
    "MovingVelocity": "contactlab.observer.models",
    "FixedVelocity": "contactlab.observer.models",
    "ImpactFeature": "contactlab.observer.models",
    "TemporalFeature": "contactlab.observer.models",
    "GaussianFeature": "contactlab.observer.models",
    # constraints
    "CartesianConstraint": "contactlab.constraints",
    "RecursiveConstraint": "contactlab.constraints",
    "decide_degree": "contactlab.constraints",
    "estimate_polygon": "contactlab.planar",
    # data
    "simulate": "contactlab.sim",
    "free_contact_recording": "contactlab.synthetic.free_contact",
    "piecewise_ar": "contactlab.synthetic",
    # errors
    "ContactlabError": "contactlab.errors",
    "DataError": "contactlab.errors",
    "UsageError": "contactlab.errors",
}

#: the subpackages and modules, reachable as attributes (``contactlab.observer``)
_SUBMODULES = (
    "archive", "conditioning", "signals", "payload", "estimators", "detection", "segmentation",
    "segmenter", "temporal", "observer", "constraints", "planar", "maze", "sim", "acquire",
    "synthetic", "peers", "experiments", "report", "metrics", "export", "errors", "cli",
)

__all__ = sorted(_EXPORTS)


def __getattr__(name: str):
    if name in _EXPORTS:
        value = getattr(importlib.import_module(_EXPORTS[name]), name)
        globals()[name] = value           # later look-ups skip this function
        return value
    if name in _SUBMODULES:
        return importlib.import_module(f"contactlab.{name}")
    raise AttributeError(f"module 'contactlab' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted({*globals(), *_EXPORTS, *_SUBMODULES})
