"""Planar contact geometry (8.30-8.48) and the tangent-space tableau (8.50-8.56)."""

from __future__ import annotations

import numpy as np
import pytest

from contactlab.planar import geometry as g
from contactlab.planar import tableau as tb
from contactlab.planar.geometry import Contact, unit

RNG = np.random.default_rng(7)
XS = np.column_stack([RNG.normal(0, 2, 30), RNG.normal(0, 2, 30), RNG.uniform(-1, 1, 30)])


@pytest.mark.parametrize("kind", ["A", "B"])
def test_gradient_and_hessian_match_finite_differences(kind):
    c = Contact(kind, tuple(unit(0.7)), 0.3, (1.2, -0.4))
    grad, hess = g.cotangent(c, XS), g.hessian(c, XS)
    for j in range(3):
        e = np.zeros(3)
        e[j] = 1e-6
        fd = (g.constraint(c, XS + e) - g.constraint(c, XS - e)) / 2e-6
        np.testing.assert_allclose(grad[:, j], fd, atol=1e-7)
        fdh = (g.cotangent(c, XS + e) - g.cotangent(c, XS - e)) / 2e-6
        np.testing.assert_allclose(hess[:, :, j], fdh, atol=1e-7)


@pytest.mark.parametrize("kind", ["A", "B"])
def test_curvature_forms_reproduce_the_fields(kind):
    c = Contact(kind, tuple(unit(-2.1)), 1.0, (0.5, 2.0))
    Y, T = g.cotangent(c, XS), g.tangents(c, XS)
    assert np.abs(np.einsum("nki,ni->nk", T, Y)).max() < 1e-12          # reciprocity (8.6)
    np.testing.assert_allclose(np.cross(T[:, 0], T[:, 1]), Y, atol=1e-12)  # (8.49)
    np.testing.assert_allclose((g.curvature_cotangent(kind, XS) @ c.cotangent_vector())[:, :3],
                               Y, atol=1e-12)                          # (8.39) / (8.45)
    C1, C2 = g.curvature_tangents(kind, XS)
    J1, J2 = g.tangent_vectors(c)
    np.testing.assert_allclose((C1 @ J1)[:, :3], T[:, 0], atol=1e-12)   # (8.41) / (8.47)
    np.testing.assert_allclose((C2 @ J2)[:, :3], T[:, 1], atol=1e-12)   # (8.42) / (8.48)
    back = Contact.from_cotangent_vector(kind, 3.0 * c.cotangent_vector())
    np.testing.assert_allclose(back.p, c.p, atol=1e-12)


def test_bb_tableau_matches_closed_form():
    c1 = Contact("B", tuple(unit(0.3)), 1.0, (2.0, -1.0))
    c2 = Contact("B", tuple(unit(1.9)), 0.5, (-1.0, 0.7))
    y1, y2 = c1.cotangent_vector(), c2.cotangent_vector()
    np.testing.assert_allclose(tb.tableau(c1, c2), tb.tableau_bb(y1[:2], y1[2:], y2[:2], y2[2:]),
                               atol=1e-10)


def test_tableau_identifies_equivalent_and_different_mechanisms():
    c1 = Contact("B", tuple(unit(0.3)), 1.0, (2.0, -1.0))
    c2 = Contact("B", tuple(unit(1.9)), 0.5, (-1.0, 0.7))
    e1, e2 = tb.equivalent_bb(c1, c2, normal=unit(-0.8))
    assert abs(e1.n @ unit(-0.8) - 1) < 1e-12 and np.linalg.norm(e1.p - c1.p) > 0.5
    T, Te = tb.tableau(c1, c2), tb.tableau(e1, e2)
    assert tb.equivalent(T, Te)
    # independent check: the equivalent pair admits exactly the original tangent everywhere
    J = np.cross(g.cotangent(c1, XS), g.cotangent(c2, XS))
    Je = np.cross(g.cotangent(e1, XS), g.cotangent(e2, XS))
    np.testing.assert_allclose(np.cross(J, Je), 0, atol=1e-9)
    moved = Contact("B", c2.normal, c2.distance, (c2.p[0] + 0.2, c2.p[1]))
    assert not tb.equivalent(T, tb.tableau(c1, moved), tol=1e-3)


@pytest.mark.parametrize("kinds", [("A", "A"), ("A", "B")])
def test_thesis_feature_vectors_span_the_tangent_field(kinds):
    c1 = Contact(kinds[0], tuple(unit(0.3)), 1.0, (2.0, -1.0))
    c2 = Contact(kinds[1], tuple(unit(1.9)), 0.5, (-1.0, 0.7))
    T = tb.tableau(c1, c2)        # raises if (8.54)/(8.56) features do not span J(x)
    J = np.cross(g.cotangent(c1, XS), g.cotangent(c2, XS))
    np.testing.assert_allclose(tb.features("".join(kinds), XS) @ T.T, J, atol=1e-9)
