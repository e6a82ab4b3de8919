"""The capstan cables (dynamics module docstring, "The drive's structure"; off by default,
``[apparatus] cable_stiffness_n_per_m``): the motors' rotors ring on the cables against the arm,
and a turning drive shakes the sensor at that mode."""

from __future__ import annotations

import numpy as np
import pytest

from test_sim_link import _moving_sensor_spectrum

from contactlab.sim import Apparatus, PositionController, free_space, simulate
from contactlab.sim import constants as C

CABLED = Apparatus(cable_stiffness=C.CABLE_STIFFNESS)
RIGID = Apparatus(cable_stiffness=0.0)


def _chain_modes_hz(app):
    """Free-free modes of rotor -cable- arm -sensor- shell, from the chain's mass and stiffness
    matrices (numpy's eigenvalues: an oracle independent of the integrator)."""
    m = np.diag([app.rotor_mass, app.robot_mass - app.rotor_mass, app.shell_mass])
    kc, ks = app.cable_stiffness, app.sensor_stiffness
    k = np.array([[kc, -kc, 0.0], [-kc, kc + ks, -ks], [0.0, -ks, ks]])
    w2 = np.sort(np.linalg.eigvals(np.linalg.solve(m, k)).real)
    return np.sqrt(np.clip(w2, 0.0, None)) / (2.0 * np.pi)


def test_the_rotors_reflected_inertia_and_the_cable_mode():
    assert CABLED.rotor_mass == pytest.approx(C.ROTOR_INERTIA * C.MOTOR_RAD_PER_TIP_M ** 2)
    assert 0.005 < CABLED.rotor_mass < 0.012                      # J G^2 of an RE 25-class rotor
    assert CABLED.friction_mass == CABLED.rotor_mass and CABLED.base_mass == pytest.approx(
        C.ROBOT_MASS - CABLED.rotor_mass)
    f = _chain_modes_hz(CABLED)
    assert f[0] < 1.0 and CABLED.cable_mode_hz == pytest.approx(f[1], rel=0.05)
    assert 200.0 < CABLED.cable_mode_hz < 600.0


def test_at_rest_the_cables_stretch_under_the_arm_and_shell():
    app = CABLED
    r = simulate(environment=free_space(), controller=PositionController(), duration_s=0.3, seed=1,
                 start=(0.0, 0.0, 0.0), control_noise=False, apparatus=app)
    sag = r.fingertip_position[-50:, 2] - r.robot_position[-50:, 2]
    g = app.gravity
    expect = -(app.shell_mass * g / app.sensor_stiffness
               + (app.robot_mass - app.rotor_mass + app.shell_mass) * g / app.cable_stiffness)
    assert sag.mean() == pytest.approx(expect, rel=0.05)


def test_a_moving_drive_shakes_the_sensor_at_the_cable_mode():
    # 7.3.3: the brush ripple and the DAC's steps act on the light rotors, which ring on the
    # cables and shake the arm; with rigid cables they reach the sensor only through the
    # shell's inertia on the whole robot
    f, p = _moving_sensor_spectrum(CABLED)
    mode = _chain_modes_hz(CABLED)[1]
    low = (f > 100.0) & (f < 550.0)
    assert abs(f[low][np.argmax(p[low])] - mode) < 0.1 * mode
    # around the mode the cables amplify what the rotors feel (the rigid robot passes the
    # brush ripple on too, through the shell's inertia, at every frequency)
    _, p_rigid = _moving_sensor_spectrum(RIGID)
    near = np.abs(f - mode) < 0.15 * mode
    assert p[near].sum() > 3.0 * p_rigid[near].sum()
