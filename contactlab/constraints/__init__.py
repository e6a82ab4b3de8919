"""Constraint estimation (thesis chapter 8.1.1, 8.2, 8.3): Cartesian estimators,
friction filter, alignment error, degree and direction decisions, exploration
diagnostic and the recursive form.

- :mod:`.cartesian`    :class:`CartesianConstraint` (constraint form, 8.21-8.28),
  :class:`CartesianStiffness` (stiffness form, 8.12-8.20) -> fit objects
- :mod:`.frames`       the batched numerics (criteria, Newton, Powell, trace)
- :mod:`.scaling`      reciprocity-preserving units (8.7-8.9)
- :mod:`.friction`     friction compensation filter (8.29)
- :mod:`.alignment`    SVD alignment error and the log-normal summary (tables 8.1-8.5)
- :mod:`.degree`       degree of constraint (8.2)
- :mod:`.direction`    direction of constraint (8.69-8.70)
- :mod:`.exploration`  is there information in every direction? (9.1.2)
- :mod:`.recursive`    information matrices updated sample by sample
- :mod:`.dispersion`   the spread of frames between blocks beyond their noise
- :mod:`.compliance`   a compliant contact's penetration and a turning frame, with the frame
- :mod:`.archive`      per-segment estimation of archive trials (``contactlab estimate``)

Example::

    from contactlab.constraints import CartesianConstraint, CompliantConstraint
    fit = CartesianConstraint(friction=True).estimate(position, force)   # (n, 3) SI
    fit.degree_, fit.normals_, fit.angle_sd_deg_, fit.log_likelihoods_
    # a compliant contact: the penetration's compliance estimated with the frame
    fit = CompliantConstraint(CartesianConstraint(friction=True)).estimate(position, force)
    fit.parameters["compliance_m_per_n"]
"""

from contactlab.constraints.alignment import (angular_error_deg, alignment_deviation,
                                              direction_cosines, equivalent_angle_deg,
                                              joint_projection, lognormal_summary)
from contactlab.constraints.cartesian import (FORCE_SD, POSITION_SD, VELOCITY_SD, BlockFits,
                                              CartesianConstraint, CartesianStiffness,
                                              ConstraintFit, StiffnessFit, min_samples)
from contactlab.constraints.compliance import Compliance, CompliantConstraint, fit_compliance
from contactlab.constraints.degree import (AlignmentDegreeTest, alignment_statistic,
                                           decide_degree)
from contactlab.constraints.direction import (alignment_penalty, decide_direction,
                                              direction_log_likelihood, prior_rate)
from contactlab.constraints.exploration import Exploration, exploration
from contactlab.constraints.friction import friction_filter
from contactlab.constraints.recursive import RecursiveConstraint
from contactlab.constraints.scaling import Scaling, reciprocal_scaling

__all__ = [
    "AlignmentDegreeTest", "BlockFits", "CartesianConstraint", "CartesianStiffness",
    "Compliance", "CompliantConstraint", "ConstraintFit", "Exploration", "FORCE_SD",
    "POSITION_SD", "RecursiveConstraint", "Scaling", "StiffnessFit", "VELOCITY_SD",
    "alignment_deviation", "alignment_penalty", "alignment_statistic", "angular_error_deg",
    "decide_degree", "decide_direction", "direction_cosines", "direction_log_likelihood",
    "equivalent_angle_deg", "exploration", "fit_compliance", "friction_filter",
    "joint_projection", "lognormal_summary", "min_samples", "prior_rate", "reciprocal_scaling",
]
