"""The gear-shift maze of thesis 9.2 (fig 9.6) as a planar configuration space for a disc."""

from __future__ import annotations

import math

import numpy as np
import pytest

from contactlab.sim import IntegralForceController, maze, simulate
from contactlab.sim import constants as C
from contactlab.sim.environment import maze_outline
from contactlab.sim.materials import get_material

R = C.FINGERTIP_RADIUS


def test_maze_outline_is_an_h_with_a_tail_and_walls_face_the_channel():
    pts = np.array(maze_outline())
    assert len(pts) == 16
    area = 0.5 * np.sum(pts[:, 0] * np.roll(pts[:, 1], -1) - np.roll(pts[:, 0], -1) * pts[:, 1])
    w, a, L, T = 0.010, 0.025, 0.040, 0.040
    assert area == pytest.approx(2 * (2 * w) * (2 * L) + (2 * a - 2 * w) * 2 * w + 2 * w * (T - w))  # CCW
    env = maze(depth=0.003)
    r_disc = math.sqrt(R**2 - (R - 0.003) ** 2)
    for p in env.planes[1:]:
        n = np.asarray(p.normal)
        assert n[2] == pytest.approx((R - 0.003) / R) and np.hypot(n[0], n[1]) == pytest.approx(r_disc / R)
    # a sphere centred on the floor at the middle of the crossbar touches nothing but the floor
    assert env.signed_distances((0.0, 0.0, R))[0] == pytest.approx(0.0)


@pytest.mark.parametrize("force, wall_at", [((0.0, 0.15, -0.3), ("y", 0.010)),     # crossbar's upper wall
                                            ((0.3, 0.0, -0.3), ("x", 0.035))])     # right leg's outer wall
def test_a_pushed_finger_stops_where_the_disc_meets_the_wall(force, wall_at):
    depth = 0.003
    env = maze(depth=depth)
    r_disc = math.sqrt(R**2 - (R - depth) ** 2)   # the disc cut from the sphere at the wall's top edge
    ctrl = IntegralForceController(forces=((0.0, force),))
    res = simulate(environment=env, controller=ctrl, duration_s=4.0, seed=1)
    axis = "xyz".index(wall_at[0])
    assert not res.moving[-100:].any()
    touched = [res.surfaces[i] for i in np.flatnonzero(res.contact[-1])]
    walls = [s for s in touched if s.startswith("wall")]
    assert len(walls) == 1
    # the push is nearly along the edge's inclined normal, so the edge alone can carry it and
    # friction may hold the finger a little up the edge (tens of um): the finger rests on the
    # edge (its centre R from the edge's plane, less the micron Hertz deflection), within
    # 0.1 mm of the floor, so where the disc meets the wall to within that climb
    c = res.fingertip_position[-1]
    wall = env.planes[[p.name for p in env.planes].index(walls[0])]
    assert np.asarray(wall.normal) @ c - wall.offset == pytest.approx(R, abs=5e-6)
    assert -5e-6 <= c[2] - R < 1e-4
    assert c[axis] == pytest.approx(wall_at[1] - r_disc, abs=1.2 * (c[2] - R) + 5e-6)
    n = res.contact_normals[-1, res.surfaces.index(walls[0])]
    assert -n[axis] == pytest.approx(r_disc / R, abs=1e-9) and n[2] == pytest.approx((R - depth) / R)
    # the edge force is inclined, so it carries part of the finger's downward push, and it
    # lies inside the friction cone about the edge normal
    fc = res.contact_force[-200:, res.surfaces.index(walls[0])].mean(axis=0)
    fn = fc @ n
    assert fn > 0.1 and fc[2] > 0.3 * fn
    assert np.linalg.norm(fc - fn * n) <= get_material("lexan").mu_static * fn * 1.01
