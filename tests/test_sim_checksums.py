"""Regression guard of the simulator's integrator: the short simulations of
``tests/sim_scenarios.py`` must reproduce the arrays they gave when the integrator was
split into parts and its parameters grouped into named records: integer and boolean
arrays to the bit, float arrays to 1e-3 of their scale (the kernels' fast-math gives other
last bits on another processor, which one stick-slip scenario amplifies to 1e-4; see
``sim_scenarios``).  A slip in a refactor (a wrong sign, index or term) moves them by far
more.

This is a fingerprint file of that output (``tests/data/sim_checksums.json``,
written by ``python tests/sim_scenarios.py``), not an independent oracle: it says the
simulator did not change, not that it is right (tests/test_sim_dynamics.py and the other
test_sim_* files check the physics).  A deliberate change of the simulator's results
regenerates the file in the same commit, saying why."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from sim_scenarios import checksums

STORED = json.loads((Path(__file__).parent / "data" / "sim_checksums.json").read_text())


@pytest.fixture(scope="module")
def computed():
    return checksums()


#: tolerance of a float array's projection, relative to its scale: ten times the largest
#: difference between two processors' compilations (``sim_scenarios``)
RTOL = 1e-3
#: tolerance of its sampled values, relative to its largest magnitude: a measured strain
#: or wrench may move by one converter count (0.2 % of the corner scenario's largest)
SAMPLED_TOL = 1e-2


def _same(new: dict, old: dict) -> bool:
    if (new["dtype"], new["shape"]) != (old["dtype"], old["shape"]) or set(new) != set(old):
        return False
    if "sha256" in old:
        return new["sha256"] == old["sha256"]
    scale = old["scale"]
    return (np.allclose(new["sampled"], old["sampled"], rtol=0.0, atol=SAMPLED_TOL * old["max_abs"])
            and abs(new["projection"] - old["projection"]) <= RTOL * scale)


@pytest.mark.parametrize("scenario", sorted(STORED))
def test_simulation_is_unchanged(computed, scenario):
    assert set(computed[scenario]) == set(STORED[scenario])
    changed = sorted(f for f, old in STORED[scenario].items() if not _same(computed[scenario][f], old))
    assert not changed, f"{scenario}: arrays differ from the stored fingerprints: {changed}"
