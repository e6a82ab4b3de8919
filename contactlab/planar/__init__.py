"""Planar polygon constraint estimation (thesis 8.1.2-8.1.3).

Public API:

* :func:`estimate_polygon` (``configuration``, ``wrench``, ``kind`` in
  A/B/AA/BB/AB/line-line, ``noise``) -> :class:`PolygonEstimate`
* :class:`PolygonNoise`: the measurement scales of the unit-free scaling
* :class:`Contact`: one type A or B contact; :mod:`.geometry` holds the
  constraints, tangents, cotangents and curvature matrices (8.30-8.48)
* :func:`simulate_polygon`: the planar simulator of 8.1.3.5
* :mod:`.tableau`: tangent-space tableaux (8.50-8.56) and equivalence tests
"""

from contactlab.planar.estimate import KINDS, PolygonEstimate, PolygonNoise, estimate_polygon
from contactlab.planar.geometry import Contact
from contactlab.planar.simulate import PlanarSim, simulate_polygon

__all__ = ["KINDS", "Contact", "PlanarSim", "PolygonEstimate", "PolygonNoise",
           "estimate_polygon", "simulate_polygon"]
