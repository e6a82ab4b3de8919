"""The PHANToM's own losses (backdrive friction, back-EMF damping) and what follows from them:
quiet resting contact (7.1-7.3, figs 7.5/7.9), ringing that dies within an impact interval,
a stable integral force controller on encoder feedback (fig 9.3), and the friction cone that
decides whether a guarded move reaches the corner (9.1.2-9.1.3)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from contactlab.sim import (Apparatus, IntegralForceController, Move, PositionController, StrainGaugeSensor,
                            StrokeController, block, corner, free_space, plane, sample_a, simulate)
from contactlab.sim import constants as C

R = C.FINGERTIP_RADIUS


def _y_h(strain):
    # 7.1: log of the absolute strain difference, averaged over blocks of 8 samples (and over
    # the 8 gauges) and decimated 4:1 to 250 Hz; returns (values, index of each block start)
    d = np.abs(np.diff(strain, axis=0))
    starts = np.arange(0, len(d) - 8, 4)
    return np.log(np.array([d[i:i + 8].mean() for i in starts])), starts


def test_backdrive_friction_is_coulomb_with_a_true_stick():
    # free space, no control noise, zero gains: a constant drive force below F_c leaves the
    # robot exactly at rest; above it the robot (and the shell on it) accelerates at
    # (F - F_c) / m (the viscous term and the brush ripple of the kinetic friction are
    # switched off for this oracle).
    # the rigid-stick law (no pre-sliding compliance)
    app = Apparatus(robot_damping=0.0, brush_friction_variation=0.0, robot_presliding=0.0,
                    force_resolution=0.0)
    fc = app.robot_friction
    for push, moves in ((0.5 * fc, False), (fc + 0.02, True)):
        ctrl = PositionController(stiffness=(0.0, 0.0, 0.0), damping=(0.0, 0.0, 0.0), feedforward=(push, 0.0, 0.0))
        r = simulate(environment=free_space(), controller=ctrl, duration_s=0.2, seed=1, preroll_s=0.0,
                     start=(0, 0, 0), control_noise=False, apparatus=app)
        if not moves:
            assert np.all(r.robot_velocity == 0.0) and np.all(r.robot_position[:, 0] == 0.0)
        else:
            t = r.time[100:]
            a_fit = np.polyfit(t, r.robot_velocity[100:, 0], 1)[0]
            assert a_fit == pytest.approx((push - fc) / app.total_mass, rel=0.05)


def test_resting_contact_is_quieter_than_sliding_on_sanded_aluminium():
    # figs 7.5 / 7.9: at rest in contact (H2) the high-frequency log-energy y_h sits at the
    # sensor's noise floor; sliding over the 80-grit aluminium raises it.  Without the
    # PHANToM's losses the robot mass rang on the sensor spring at rest and inverted this.
    ctrl = StrokeController()
    r = simulate(environment=sample_a(), controller=ctrl, duration_s=7.0, seed=1)
    yh, starts = _y_h(r.strain)
    t = r.time[starts]
    rest = t < ctrl.command_start_s - 0.05
    sliding = (t > 1.5) & (t < 2.8)
    assert (r.texture[starts[sliding]] == r.materials.index("sanded_aluminium_80")).all()
    assert r.moving[starts[sliding]].all() and not r.moving[starts[rest]].any()
    assert yh[rest].mean() < yh[sliding].mean() - 0.2
    end = t > ctrl.command_start_s + ctrl.command_s + 1.0       # resting again after the freeze
    assert yh[end].mean() < yh[sliding].mean() - 0.2


def test_ringing_after_an_impact_decays_within_the_impact_interval_cap():
    # a guarded move into the block (command finished before the bounce train ends): the
    # ~250 Hz robot-on-sensor ringing after the last bounce dies out by itself, the impact
    # interval closes before IMPACT_MAX_DURATION_S, and the resting finger is then close to
    # the sensor's noise floor (above it by the amplifiers' force noise the pressed sensor
    # carries, constants.AMPLIFIER_FORCE_NOISE: ~0.1 mN against the wrench noise's 2.6 mN).
    sen = StrainGaugeSensor()
    noise_diff = math.sqrt(2.0 * ((sen.noise_lsb * sen.lsb_v) ** 2 + sen.lsb_v ** 2 / 12.0))
    for seed in (0, 1):
        ctrl = PositionController(moves=(Move((0, 0.012, 0), 0.25, 0.05),))
        r = simulate(environment=block(floor=False), controller=ctrl, duration_s=0.8, seed=seed, start=(0, 0, 0.02))
        c = r.contact[:, r.surfaces.index("block_face")]
        gains = np.flatnonzero(np.diff(c.astype(int)) == 1) + 1
        assert len(r.impact_intervals) == 1
        a, b = r.impact_intervals[0]
        last = gains[gains < b][-1]
        assert (b - last) / r.rate_hz < 0.8 * C.IMPACT_MAX_DURATION_S
        assert c[b:].all()
        hf = np.diff(r.strain[b + 50:], axis=0)
        assert np.sqrt(np.mean(hf ** 2)) < 2.0 * noise_diff


@pytest.mark.parametrize("material", ["lexan", "rough_wood", "polished_aluminium"])
def test_integral_force_controller_holds_a_steady_force_on_encoder_feedback(material):
    # fig 9.3 on what the real servo sees (encoder-quantised position, differenced velocity):
    # a guarded move down with f_d = 0.2 N lands, stays on the surface and holds the force.
    ctrl = IntegralForceController(forces=((0.0, (0.0, 0.0, -0.2)),))
    assert ctrl.feedback == "encoder"
    r = simulate(environment=plane(material=material), controller=ctrl, duration_s=2.0, seed=2,
                 start=(0, 0, R + 0.002))
    settled = slice(800, None)
    assert r.contact[settled, 0].all()
    fz = r.contact_force[settled, 0, 2]
    assert fz.mean() == pytest.approx(0.2, abs=0.01)
    # steady within about one step of the force DAC (constants.FORCE_RESOLUTION, 14 mN), which
    # the integrating loop dithers across (the robot moves on its pre-sliding compliance); a
    # limit cycle would hop off, unloading the contact
    assert fz.std() < C.FORCE_RESOLUTION * 1.5 and fz.min() > 0.1


def test_guarded_move_reaches_the_corner_only_outside_the_friction_cone():
    # 9.1.2-9.1.3: under integral force control the finger slides along the YZ wall into the
    # corner only if the commanded force along the wall exceeds the friction the table and
    # the wall can hold (mu_floor f_z + mu_wall f_y).  Rough wood table, hard plastic walls:
    # f_x = 0.15 N > 0.35 * 0.2 + 0.35 * 0.1 = 0.105 N reaches the corner; the thesis's
    # (100, -100, 200) mN with polished-aluminium walls (0.40 * 0.2 + 0.61 * 0.1 = 0.141 N
    # > 0.1 N) sticks on the YZ wall with the friction holding the commanded force.
    env = corner(material="rough_wood", wall_material="hard_plastic", wall_y=0.020, wall_x=0.030)
    r = simulate(environment=env, controller=IntegralForceController(forces=((0.5, (0.15, 0.1, -0.2)),)),
                 duration_s=4.0, seed=0)
    assert r.contact[-500:].all()                          # table + both walls: the corner
    env = corner(material="rough_wood", wall_material="polished_aluminium", wall_y=0.020, wall_x=0.030)
    r = simulate(environment=env, controller=IntegralForceController(forces=((0.5, (0.1, 0.1, -0.2)),)),
                 duration_s=4.0, seed=0)
    end = slice(-500, None)
    assert r.contact[end, :2].all() and not r.contact[end, 2].any()     # stuck on table + YZ wall
    assert (r.sliding_speed[end] < C.MOVING_SPEED_THRESHOLD).all()
    fx_friction = r.contact_force[end, :2, 0].sum(axis=1)                # table + wall friction along x
    assert fx_friction.mean() == pytest.approx(-0.1, abs=0.01)


def test_a_velocity_step_command_onset_makes_a_start_burst_and_a_smooth_one_does_not():
    # 7.2 phase 2 ("impact-like burst ... caused by the start of the motion command"): with
    # a constant-velocity command the desired velocity steps and the servo's damping term
    # kicks the robot; the sinusoidal-acceleration command of 7.3 starts without a burst.
    out = {}
    for shape in ("constant_velocity", "sinusoidal"):
        ctrl = StrokeController(shape=shape)
        r = simulate(environment=sample_a(), controller=ctrl, duration_s=1.0, seed=1)
        yh, starts = _y_h(r.strain)
        t = r.time[starts]
        rest = yh[t < ctrl.command_start_s - 0.05]
        onset = yh[(t >= ctrl.command_start_s) & (t < ctrl.command_start_s + 0.05)]
        out[shape] = onset.max() - rest.max()
    assert out["constant_velocity"] > 0.3
    assert out["sinusoidal"] < 0.2


def test_a_pressed_still_finger_carries_the_motors_force_noise_through_the_contact():
    # 7.3.3: pressed is louder than stationary.  The stuck drive is compliant before it breaks
    # away (constants.ROBOT_PRESLIDING_DISPLACEMENT): the amplifiers' random force moves the
    # robot by fractions of a micrometre; free, robot and shell move together, pressed, the
    # sensor carries it.  With a rigid stick the motors' noise never reaches the sensor.  The
    # sensor's true force (before the gauges' noise): how much of it shows above the electronic
    # floor is the amplifiers' level (constants.AMPLIFIER_FORCE_NOISE, the apparatus experiment)
    def hf_rms(env, app):
        ctrl = PositionController(moves=(Move((0.0, 0.0, -0.003), 0.2, 0.0),))
        r = simulate(environment=env, controller=ctrl, duration_s=1.0, seed=1, start=(0, 0, R + 0.0002),
                     apparatus=app)
        assert not r.moving[500:].any()
        return np.sqrt(np.mean(np.diff(r.wrench_true[500:, :3], axis=0) ** 2))

    compliant, rigid = Apparatus(), Apparatus(robot_presliding=0.0)
    pressed = hf_rms(plane(material="polished_aluminium"), compliant)
    assert pressed > 1.5 * hf_rms(free_space(), compliant)
    assert hf_rms(plane(material="polished_aluminium"), rigid) < 0.05 * pressed
