"""PHANToM motor commutation torque ripple (contactlab.sim.dynamics "Motors") against closed forms."""

from __future__ import annotations

import math

import numpy as np
import pytest

from contactlab.sim import Apparatus, Move, PositionController, free_space, simulate
from contactlab.sim import constants as C
from contactlab.sim.dynamics import commutation_gain


def _cos_sawtooth_moments(n):
    # torque ~ cos(phi), phi uniform on [-a, a], a = pi / n:  E cos = sin a / a,
    # E cos^2 = 1/2 + sin 2a / (4 a)
    a = math.pi / n
    m1 = math.sin(a) / a
    m2 = 0.5 + math.sin(2 * a) / (4 * a)
    return m1, m2


@pytest.mark.parametrize("n", [7, 22, 13])
def test_commutation_gain_shape(n):
    th = np.linspace(0.0, 2 * math.pi, 200001)[:-1]
    g = np.array([commutation_gain(t, n) for t in th])
    assert g.mean() == pytest.approx(1.0, abs=1e-6)             # k_t is the mean torque constant
    m1, _ = _cos_sawtooth_moments(n)
    assert g.max() == pytest.approx(1.0 / m1, rel=1e-6)
    assert g.min() == pytest.approx(math.cos(math.pi / n) / m1, rel=1e-4)
    assert (g.max() - g.min()) * m1 == pytest.approx(1.0 - math.cos(math.pi / n), rel=1e-4)
    # period 2 pi / n in shaft angle
    np.testing.assert_allclose([commutation_gain(t + 2 * math.pi / n, n) for t in th[::997]], g[::997],
                               atol=1e-9)
    assert commutation_gain(1.234, 0) == 1.0


def test_ripple_constants_from_segments():
    k = C.COMMUTATOR_SEGMENTS
    assert C.COMMUTATION_EVENTS_PER_REV == (2 * k if k % 2 else k)
    assert C.COMMUTATION_RIPPLE_PP == pytest.approx(1.0 - math.cos(math.pi / C.COMMUTATION_EVENTS_PER_REV))
    # motor-side encoder cross-check: 2000 counts/rev through the ratio ~ the tip resolution
    assert 2 * math.pi / 2000 / C.MOTOR_RAD_PER_TIP_M == pytest.approx(C.ENCODER_RESOLUTION, rel=0.4)


def _vertical_run(speed, app, duration=2.0):
    # constant-velocity lift (the motor carries gravity compensation: ~0.83 N on z), ideal
    # feedback, no control noise, exact force DAC: the only vibration source is the commutation ripple
    ctrl = PositionController(moves=(Move((0.0, 0.0, speed * duration), duration, 0.0, "constant_velocity"),),
                              stiffness=(400.0,) * 3, feedback="true")
    return simulate(environment=free_space(), controller=ctrl, duration_s=duration, seed=4,
                    start=(0.0, 0.0, 0.0), apparatus=app, control_noise=False)


def _ripple(r, t0=0.8):
    sel = r.time >= t0
    fz = r.wrench_true[sel, 2]
    t = r.time[sel]
    fz = fz - np.polyval(np.polyfit(t, fz, 2), t)
    return t, fz, np.abs(r.control_wrench[sel, 2]).mean()


@pytest.mark.parametrize("speed", [0.05, 0.1])
def test_ripple_frequency_scales_with_speed_and_amplitude_matches_mass_ratio(speed):
    # the brushes' friction ripple (a broadband vibration source of its own) is off here
    app = Apparatus(commutation_events=C.COMMUTATION_EVENTS_PER_REV, brush_friction_variation=0.0,
                    force_resolution=0.0)
    t, fz, f_motor = _ripple(_vertical_run(speed, app))
    spec = np.abs(np.fft.rfft(fz * np.hanning(len(fz))))
    freqs = np.fft.rfftfreq(len(fz), t[1] - t[0])
    f_expect = C.COMMUTATION_EVENTS_PER_REV * C.MOTOR_RAD_PER_TIP_M * speed / (2 * math.pi)
    df = freqs[1]
    assert abs(freqs[np.argmax(spec[freqs > 2.0]) + np.sum(freqs <= 2.0)] - f_expect) <= 1.5 * df
    # amplitude of the fundamental: the ripple force F c1 cos(w t) on the robot (c1 the
    # waveform's first Fourier coefficient, by quadrature) moves the PD-loop mass-spring-damper
    # (total mass m, stiffness k, damping b); the sensor sees the shell's share of the
    # acceleration, m_f w^2 |X| (far below the 740 Hz robot-shell mode)
    n = C.COMMUTATION_EVENTS_PER_REV
    m1, _ = _cos_sawtooth_moments(n)
    v = np.linspace(-math.pi, math.pi, 200001)
    c1 = np.trapezoid(np.cos(v / n) * np.cos(v), v) / math.pi / m1
    sa = PositionController(stiffness=(400.0,) * 3).servo_arrays((0, 0, 0), np.zeros(1))
    k, b, m = 400.0, sa.bp[2] + app.robot_damping, app.total_mass
    w = 2 * math.pi * f_expect
    expect = app.shell_mass * w**2 * f_motor * abs(c1) / abs(k - m * w**2 + 1j * b * w)
    phase = 2 * math.pi * f_expect * t
    basis = np.column_stack([np.cos(phase), np.sin(phase)])
    coef = np.linalg.lstsq(basis, fz, rcond=None)[0]
    assert np.hypot(*coef) == pytest.approx(expect, rel=0.15)
    # and without ripple the same run is silent at that frequency
    _, fz0, _ = _ripple(_vertical_run(speed, Apparatus(commutation_events=0, brush_friction_variation=0.0,
                                                                 force_resolution=0.0)))
    assert np.std(fz0) < 0.1 * np.std(fz)


def test_ripple_is_on_by_default():
    assert Apparatus().commutation_events == C.COMMUTATION_EVENTS_PER_REV


def test_ripple_is_static_at_rest():
    # holding still, the ripple is a fixed function of the (fixed) shaft angle: no vibration
    ctrl = PositionController(stiffness=(400.0,) * 3, feedback="true")
    r = simulate(environment=free_space(), controller=ctrl, duration_s=1.0, seed=4, start=(0.0, 0.0, 0.0),
                 apparatus=Apparatus(commutation_events=C.COMMUTATION_EVENTS_PER_REV), control_noise=False)
    fz = r.wrench_true[r.time >= 0.5, 2]
    assert np.ptp(fz) < 1e-9
