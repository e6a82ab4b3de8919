"""Regression guard of the simulator's integrator: the short simulations of
``tests/sim_scenarios.py`` must reproduce, bit for bit, the arrays they gave before the
integrator was split into parts and its parameters grouped into named records.

This is a checksum file of that pre-refactor output (``tests/data/sim_checksums.json``,
written by ``python tests/sim_scenarios.py``), not an independent oracle: it says the
simulator did not change, not that it is right (tests/test_sim_dynamics.py and the other
test_sim_* files check the physics).  A deliberate change of the simulator's results
regenerates the file in the same commit, saying why."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from sim_scenarios import checksums

STORED = json.loads((Path(__file__).parent / "data" / "sim_checksums.json").read_text())


@pytest.fixture(scope="module")
def computed():
    return checksums()


@pytest.mark.parametrize("scenario", sorted(STORED))
def test_simulation_is_unchanged_to_the_bit(computed, scenario):
    changed = sorted(f for f, h in STORED[scenario].items() if computed[scenario].get(f) != h)
    assert set(computed[scenario]) == set(STORED[scenario])
    assert not changed, f"{scenario}: arrays differ from the stored checksums: {changed}"
