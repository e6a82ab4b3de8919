"""The PHANToM's link mode (dynamics module docstring, "The drive's structure"; off by default,
``[apparatus] link_stiffness_n_per_m``): the link's tip with the sensor rings on the distal link's
bending stiffness against the rest of the robot."""

from __future__ import annotations

import numpy as np
import pytest

from contactlab.sim import Apparatus, Move, PositionController, free_space, simulate
from contactlab.sim import constants as C


LINKED = Apparatus(link_stiffness=C.LINK_STIFFNESS)


def test_the_link_mode_sits_where_cable_driven_arms_have_theirs():
    assert 100.0 < LINKED.drive_mode_hz < 300.0
    assert LINKED.drive_mass + LINKED.link_mass == pytest.approx(C.ROBOT_MASS)
    assert LINKED.friction_mass == LINKED.drive_mass and LINKED.base_mass == C.LINK_TIP_MASS
    rigid = Apparatus()
    assert rigid.rigid_drive and rigid.drive_mode_hz == 0.0 and rigid.friction_mass == C.ROBOT_MASS
    assert rigid.drive_sag == 0.0
    both = Apparatus(link_stiffness=C.LINK_STIFFNESS, cable_stiffness=C.CABLE_STIFFNESS)
    assert both.rotor_mass + both.arm_mass + both.link_mass == pytest.approx(C.ROBOT_MASS)


@pytest.mark.parametrize("app", [LINKED, Apparatus(link_stiffness=C.LINK_STIFFNESS, cable_stiffness=C.CABLE_STIFFNESS)],
                         ids=["link", "cable+link"])
def test_at_rest_the_link_bends_under_the_weight_it_carries(app):
    r = simulate(environment=free_space(), controller=PositionController(), duration_s=0.3, seed=1,
                 start=(0.0, 0.0, 0.0), control_noise=False, apparatus=app)
    sag = r.fingertip_position[-50:, 2] - r.robot_position[-50:, 2]
    # every spring in the chain stretched by the weight below it: closed form from the masses
    g = app.gravity
    expect = -(app.shell_mass * g / app.sensor_stiffness + (app.link_mass + app.shell_mass) * g / app.link_stiffness
               + (0.0 if app.rigid_cable else (app.robot_mass - app.rotor_mass + app.shell_mass) * g
                  / app.cable_stiffness))
    assert sag.mean() == pytest.approx(expect, rel=0.05)


def _moving_sensor_spectrum(app):
    ctrl = PositionController(moves=(Move((0.04, 0.0, 0.0), 1.6, 0.2, "constant_velocity"),))
    r = simulate(environment=free_space(), controller=ctrl, duration_s=2.0, seed=3, start=(0.0, 0.0, 0.0),
                 apparatus=app)
    fs = r.rate_hz
    d = np.diff(r.wrench_true[int(0.5 * fs):int(1.6 * fs), 0])
    power = np.abs(np.fft.rfft(d * np.hanning(len(d)))) ** 2
    return np.fft.rfftfreq(len(d), 1.0 / fs), power


def test_a_moving_drive_shakes_the_sensor_at_the_link_mode():
    # 7.3.3: the brush and cable ripple of a turning drive reaches the sensor through the
    # link's resonance; a rigid robot passes it on only through the shell's inertia
    app = LINKED
    f, p = _moving_sensor_spectrum(app)
    band = np.abs(f - app.drive_mode_hz) < 0.25 * app.drive_mode_hz
    assert p[band].sum() > 0.6 * p.sum()
    f, p = _moving_sensor_spectrum(Apparatus())
    assert p[band].sum() < 0.2 * p.sum()
