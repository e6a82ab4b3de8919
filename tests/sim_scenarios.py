"""Short simulations that between them run every branch of the integrator (rigid and
split drive, elasto-plastic and rigid drive friction, position / stroke / integral force
control, true and encoder feedback, one to three planes, a texture boundary, impacts),
and the SHA-256 of every array they return: the regression guard of
tests/test_sim_checksums.py.  ``python tests/sim_scenarios.py`` prints the checksums."""

from __future__ import annotations

import hashlib
import json
import sys

import numpy as np

from contactlab.sim import (Apparatus, IntegralForceController, Move, PositionController, StrokeController,
                            block, corner, plane, sample_a, simulate)
from contactlab.sim import constants as C

R = C.FINGERTIP_RADIUS


def scenarios():
    """name -> keyword arguments of :func:`contactlab.sim.simulate`."""
    down = PositionController(moves=(Move((0.004, 0.0, -0.004), 0.15, 0.02),))
    return {
        "plane_position": dict(environment=plane(), controller=down, duration_s=0.25, seed=1,
                               start=(0.0, 0.0, R + 0.001)),
        "corner_force_split_drive": dict(
            environment=corner(), controller=IntegralForceController(forces=((0.0, (0.1, -0.1, -0.2)),)),
            duration_s=0.25, seed=2, start=(0.020 - R - 0.0002, 0.020 - R - 0.0002, R + 0.0002),
            apparatus=Apparatus(cable_stiffness=C.CABLE_STIFFNESS, link_stiffness=C.LINK_STIFFNESS)),
        "block_rigid_stick_true_feedback": dict(
            environment=block(), controller=PositionController(moves=(Move((0.0, 0.01, -0.003), 0.1),),
                                                               feedback="true"),
            start=(0.0, 0.015 - R - 0.0005, R + 0.0003),
            duration_s=0.2, seed=3, apparatus=Apparatus(robot_presliding=0.0, commutation_events=0),
            initial_velocity=(0.0, 0.0, -0.05)),
        "sample_a_stroke_boundary": dict(
            environment=sample_a(), controller=StrokeController(stroke_length=0.004, command_start_s=0.02,
                                                                command_s=0.2, shape="constant_velocity"),
            duration_s=0.25, seed=4, start=(0.0254 - 0.002, 0.0, R + 20e-6)),
    }


def checksums() -> dict:
    """scenario -> field -> SHA-256 of the array's bytes (dtype and shape included)."""
    out = {}
    for name, kw in scenarios().items():
        r = simulate(**kw)
        sums = {}
        for field, val in sorted(vars(r).items()):
            if isinstance(val, np.ndarray):
                a = np.ascontiguousarray(val)
                h = hashlib.sha256(f"{a.dtype.str}{a.shape}".encode())
                h.update(a.tobytes())
                sums[field] = h.hexdigest()
        out[name] = sums
    return out


if __name__ == "__main__":
    json.dump(checksums(), sys.stdout, indent=1, sort_keys=True)
    print()
