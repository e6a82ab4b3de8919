"""Short simulations that between them run every branch of the integrator (rigid and
split drive, elasto-plastic and rigid drive friction, position / stroke / integral force
control, true and encoder feedback, one to three planes, a texture boundary, impacts),
and a fingerprint of every array they return: the regression guard of
tests/test_sim_checksums.py.  ``python tests/sim_scenarios.py`` prints the fingerprints.

The integrator's kernels are compiled with floating-point contraction and reassociation
(``sim/dynamics.py``), so their last bits depend on the processor's vector width and on
the compiler: a SHA-256 of a float array differs between machines.  A float array's
fingerprint is therefore numbers compared with a tolerance -- 64 of its values, evenly
spaced, its largest magnitude, and its projection on fixed pseudo-random weights, which
moves with a change anywhere in the array -- while integer and boolean arrays keep an
exact digest.  Compiled for a generic x86-64 instead of this machine's processor, most
arrays move by 1e-11 of their scale or less; the split-drive corner under integral force
control, whose stick-slip amplifies rounding, by up to 1e-4 (measured)."""

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


#: values of a float array taken evenly over its flat index
N_SAMPLED = 64


def fingerprint(a: np.ndarray) -> dict:
    """dtype, shape and either the SHA-256 of the bytes (integers, booleans) or, for a
    float array, ``sampled`` values, the ``projection`` on weights in [0.5, 1.5) drawn
    from a fixed seed, ``scale`` = the projection of ``|a|`` (the yardstick of the
    projection's tolerance) and ``max_abs`` (that of the sampled values')."""
    a = np.ascontiguousarray(a)
    out = {"dtype": a.dtype.str, "shape": list(a.shape)}
    if a.dtype.kind != "f":
        out["sha256"] = hashlib.sha256(a.tobytes()).hexdigest()
        return out
    flat = a.ravel()
    w = np.random.default_rng(20261129).uniform(0.5, 1.5, flat.size)
    idx = np.unique(np.linspace(0, flat.size - 1, min(N_SAMPLED, flat.size)).astype(np.int64))
    out["sampled"] = flat[idx].tolist() if flat.size else []
    out["projection"] = float(w @ flat) if flat.size else 0.0
    out["scale"] = float(w @ np.abs(flat)) if flat.size else 0.0
    out["max_abs"] = float(np.abs(flat).max()) if flat.size else 0.0
    return out


def checksums() -> dict:
    """scenario -> field -> :func:`fingerprint` of the array."""
    out = {}
    for name, kw in scenarios().items():
        r = simulate(**kw)
        out[name] = {field: fingerprint(val) for field, val in sorted(vars(r).items())
                     if isinstance(val, np.ndarray)}
    return out


if __name__ == "__main__":
    json.dump(checksums(), sys.stdout, indent=1, sort_keys=True)
    print()
