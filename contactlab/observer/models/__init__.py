"""Feature models the observer runs, one module per model family (chapter 6.1, 7, 9.1).

- :mod:`.base` -- the interface every model implements, and the bank of its instances.
- :mod:`.temporal` -- AR models under trained priors (orthogonal square-root Kalman, A.2.3).
- :mod:`.impact` -- the impact-decay model (7.1).
- :mod:`.velocity` -- velocity models F and M (9.1.1).
- :mod:`.constraint` -- Cartesian constraint models of a degree and frame (8.1.1, 9.1.1).
- :mod:`.gaussian` -- a Gaussian per sample of a phase's features (graphs learnt from labels).
- :mod:`.composite` -- nodes made of several models; binding graph declarations to models.
"""

from contactlab.observer.models.base import FeatureModel, ModelBank
from contactlab.observer.models.constraint import ConstraintFeature
from contactlab.observer.models.composite import CompositeNode, build_models, node_models
from contactlab.observer.models.gaussian import GaussianFeature
from contactlab.observer.models.impact import ImpactFeature
from contactlab.observer.models.temporal import TemporalFeature
from contactlab.observer.models.velocity import FixedVelocity, MovingVelocity

__all__ = ["FeatureModel", "ModelBank", "TemporalFeature", "ImpactFeature", "FixedVelocity",
           "MovingVelocity", "ConstraintFeature", "GaussianFeature", "CompositeNode", "build_models",
           "node_models"]
