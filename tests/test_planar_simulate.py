"""The planar simulator of 8.1.3.5 satisfies the contact constraints and reciprocity."""

from __future__ import annotations

import numpy as np
import pytest

from contactlab.planar import Contact, simulate_polygon
from contactlab.planar.geometry import constraint, cotangent, tangents, unit
from contactlab.planar.simulate import tangent_basis

CASES = {
    "B": (Contact.touching("B", normal=unit(0.4), point=5 * unit(2.0)),),
    "A": (Contact.touching("A", normal=unit(-1.0), point=5 * unit(0.5)),),
    "BB": (Contact.touching("B", normal=unit(0.3), point=5 * unit(0.3) + 2 * unit(1.87)),
           Contact.touching("B", normal=unit(1.87), point=5 * unit(1.87))),
    "AB": (Contact.touching("A", normal=unit(0.3), point=5 * unit(1.3)),
           Contact.touching("B", normal=unit(2.5), point=4 * unit(2.3))),
}


@pytest.mark.parametrize("name", list(CASES))
def test_solution_is_on_the_constraints_and_optimal(name):
    contacts = CASES[name]
    s = simulate_polygon(contacts, rng=np.random.default_rng(3), stiffness=(1, 1, 25))
    x = s.configuration
    for c in contacts:
        assert np.abs(constraint(c, x)).max() < 1e-10
    G = np.stack([cotangent(c, x) for c in contacts], 1)
    # KKT: the spring wrench lies in the cotangent span; velocity lies in the tangent space
    np.testing.assert_allclose(np.einsum("nj,nji->ni", s.lam, G), s.true_wrench, atol=1e-9)
    assert np.abs(np.einsum("nji,ni->nj", G, s.true_velocity)).max() < 1e-10
    # the wrench does no work on any admissible motion (8.2)
    T = tangent_basis(contacts, x)
    assert np.abs(np.einsum("nik,ni->nk", T, s.true_wrench)).max() < 1e-9
    # each point minimises the energy: nudging along the constraint raises it
    K = np.diag([1, 1, 25.0])
    for sign in (-1, 1):
        xn = x + sign * 1e-4 * T[:, :, 0]
        # return to the manifold to second order is not needed for a first-order check:
        dE = np.einsum("ni,ij,nj->n", xn - s.desired, K, xn - s.desired) \
            - np.einsum("ni,ij,nj->n", x - s.desired, K, x - s.desired)
        assert np.all(dE > -1e-6)
    assert np.ptp(x[:, 2]) > 0.05


def test_noise_stays_on_the_complement_bases():
    c = CASES["B"]
    s = simulate_polygon(c, rng=np.random.default_rng(4), noise_ratio=0.1)
    dv, dw = s.velocity - s.true_velocity, s.wrench - s.true_wrench
    assert np.abs(dw[:, 2]).max() == 0                         # no torque noise (8.1.3.5)
    np.testing.assert_allclose(dv[:, :2] @ (np.array([[0, -1], [1, 0]]) @ c[0].n), 0, atol=1e-12)
    np.testing.assert_allclose(dw[:, :2] @ c[0].n, 0, atol=1e-12)
    J = tangents(c[0], s.configuration)
    assert np.abs(dv[:, 2]).max() == 0 and np.std(dv[:, :2] @ c[0].n) > 0
    assert s.noise_sd["force"] > 0 and J.shape == (100, 2, 3)
