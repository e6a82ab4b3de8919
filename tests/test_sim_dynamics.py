"""Simulator mechanics against independent oracles (thesis 4.19-4.21, 4.44, 4.47-4.50, 3.3, 9.1.2)."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg

from contactlab.sim import (Apparatus, Encoders, IntegralForceController, Material, Move, PositionController, block,
                            free_space, get_material, plane, simulate)
from contactlab.sim import constants as C

R = C.FINGERTIP_RADIUS


def test_free_flight_covariance_matches_lyapunov_solution():
    # (4.19)-(4.21): zeta = [p_t, x~_t] per axis, driven by the random control wrench.
    # The linear oracle cannot hold the robot's Coulomb backdrive friction (0.04 N, 10x the
    # 4 mN control error: with it the robot simply sticks), so the friction is disabled
    # here; the robot's viscous (back-EMF) damping is kept, and added to the loop's
    # damping in the oracle (it acts on the robot velocity, which at the loop's 5 Hz is
    # the velocity of the whole moving mass).  The force DAC's steps are off and the random
    # control wrench is the white w of (4.12), at the DAC error's size.
    app = Apparatus(robot_friction=0.0, force_resolution=0.0, control_error_std=C.CONTROL_ERROR_STD)
    kp = 100.0
    # the chapter-4 model feeds back the true state (encoder quantisation is not in 4.12)
    ctrl = PositionController(stiffness=(kp, kp, kp), feedback="true")
    bp = ctrl.servo_arrays((0, 0, 0), np.zeros(1)).bp[0] + app.robot_damping
    r = simulate(environment=free_space(), controller=ctrl, duration_s=40.0, seed=3, start=(0, 0, 0),
                 apparatus=app)
    ht = app.total_mass
    a_t = np.array([[1.0, bp], [0.0, ht]])
    b_t = np.array([[0.0, kp], [-1.0, 0.0]])
    s_t = np.array([[1.0], [0.0]])
    v_w = app.control_error_std**2 / app.servo_rate_hz  # piecewise-constant noise -> white intensity
    f = -np.linalg.solve(a_t, b_t)
    g = np.linalg.solve(a_t, s_t)
    v_zeta = scipy.linalg.solve_continuous_lyapunov(f, -g @ g.T * v_w)
    # (4.21) in the thesis's form holds for the solution
    np.testing.assert_allclose(b_t @ v_zeta @ a_t.T + a_t @ v_zeta @ b_t.T, s_t @ s_t.T * v_w, atol=1e-12)
    p_t = app.robot_mass * r.robot_velocity + app.shell_mass * r.fingertip_velocity
    x_t = r.robot_position
    var_p = np.mean([np.var(p_t[:, a]) for a in range(3)])
    var_x = np.mean([np.var(x_t[:, a]) for a in range(3)])
    assert var_p == pytest.approx(v_zeta[0, 0], rel=0.15)
    assert var_x == pytest.approx(v_zeta[1, 1], rel=0.15)
    corr = np.mean([np.corrcoef(p_t[:, a], x_t[:, a])[0, 1] for a in range(3)])
    assert abs(corr) < 0.1  # the Lyapunov solution has zero cross-covariance


# exact kinematics: the PHANToM's kinematic error (8.1.1.2) shifts the x-y servo's reported
# position as the finger settles, a few mN of tangential push that 4.44's balance leaves out
EXACT = Encoders(kinematic_angle_error_deg=0.0, kinematic_curvature=0.0)


def test_quasi_static_wrench_on_a_plane_is_applied_force_plus_gravity():
    # (4.44): E[w_m] = G + E[C_x lambda]: normal force = applied 0.2 N, the shell's weight
    # is carried by the sensor, no torque from a force through the centre.
    # the force DAC's static error (up to half a 14 mN step per axis) is not in 4.44's model
    app = Apparatus(force_resolution=0.0)
    push = 0.2
    ctrl = PositionController(stiffness=(100.0, 100.0, 0.0), damping=(2.0, 2.0, 0.0), feedforward=(0, 0, -push))
    r = simulate(environment=plane(material="lexan"), controller=ctrl, duration_s=1.0, seed=5,
                 start=(0, 0, R + 0.0005), preroll_s=0.5, apparatus=app, encoders=EXACT)
    # The PHANToM's Coulomb backdrive friction (constants.ROBOT_BACKDRIVE_FRICTION) holds the
    # resting robot anywhere within +-F_c of the commanded push (it is not in 4.44's model).
    assert r.contact[:, 0].all()
    fc = r.contact_force[:, 0].mean(axis=0)
    np.testing.assert_allclose(fc[:2], [0, 0], atol=app.robot_static_friction)
    assert abs(fc[2] - push) <= app.robot_friction + 0.01
    # the sensor carries exactly the contact force less the shell's weight (4.44)
    expected = np.array([fc[0], fc[1], fc[2] - app.shell_mass * app.gravity])
    np.testing.assert_allclose(r.wrench_true[:, :3].mean(axis=0), expected, atol=0.005)
    np.testing.assert_allclose(r.wrench[:, :3].mean(axis=0), expected, atol=0.005)  # measured via strains
    assert np.abs(r.wrench[:, 3:].mean(axis=0)).max() < 1e-3


def test_impact_impulse_is_along_the_normal_and_removes_normal_momentum():
    # (4.47)-(4.50) on a frictionless plane: the robot coasts tangentially (no tangential
    # gains, no friction) and a damped z loop holds a target 2 mm below the surface.  The
    # PHANToM's own losses (Coulomb backdrive friction, viscous back-EMF damping) are
    # disabled: (4.50) is about a lossless coasting robot, and the tangential momentum must
    # be kept exactly.  The motors' commutation ripple is disabled too: the impulse balance
    # below uses the commanded control wrench as the force the motors deliver.
    app = Apparatus(robot_friction=0.0, robot_damping=0.0, commutation_events=0)
    slick = Material(name="slick", youngs_modulus=69e9, poisson_ratio=0.33, mu_static=0.0, mu_kinetic=0.0,
                     mu_variation=0.0, roughness_rms=0.0, wavelength_min=1e-4, wavelength_max=1e-3,
                     restitution=0.7)
    kz = 200.0
    bz = 2.0 * np.sqrt(kz * app.total_mass)
    z_target = R - 0.002
    # the idealised (4.12) servo: this critically damped 200 N/m loop needs a fresh velocity;
    # on encoder velocity (delayed by its filter) it keeps bouncing on the restitution-0.7 plane
    ctrl = PositionController(moves=(Move((0, 0, z_target - (R + 0.001)), 1e-3, -1.0),),
                              stiffness=(0, 0, kz), damping=(0, 0, bz), feedback="true")
    r = simulate(environment=plane(material=slick), controller=ctrl, duration_s=0.6, seed=6, preroll_s=0.0,
                 start=(0, 0, R + 0.001), initial_velocity=(0.03, 0.01, -0.05), control_noise=False,
                 apparatus=app)
    assert len(r.impact_intervals) >= 1 and r.impact_kinds[0] == 1
    i0 = r.impact_intervals[0, 0]
    dt = 1.0 / r.rate_hz
    p = app.robot_mass * r.robot_velocity + app.shell_mass * r.fingertip_velocity
    p_old = p[i0 - 1]
    n = np.array([0.0, 0.0, 1.0])
    contact_impulse = r.contact_force[i0 - 1:, 0].sum(axis=0) * dt
    # the controller (net of its gravity compensation) keeps pushing over the window
    f_ext = r.control_wrench[i0 - 1:] - app.total_mass * app.gravity * n
    w_impulse = contact_impulse + f_ext.sum(axis=0) * dt
    k_expected = -(n @ p_old)  # (4.48) with C_j = n and an isotropic H_t
    assert w_impulse[2] == pytest.approx(k_expected, rel=0.05)
    assert np.hypot(w_impulse[0], w_impulse[1]) < 1e-3 * abs(k_expected)  # along the normal (4.49)
    p_new = p[-1]
    np.testing.assert_allclose(p_new[:2], p_old[:2], rtol=1e-6)  # (4.50): tangent part kept
    assert abs(p_new[2]) < 0.02 * abs(p_old[2])  # normal part removed
    assert r.contact[-100:, 0].all()  # and it stays on the new constraint


def test_impact_rings_near_the_shell_mode():
    # 3.3 / fig 7.1: sampled at 2700 Hz, the strain after an impact rings near 690 Hz.
    ctrl = PositionController(moves=(Move((0, 0.03, 0), 0.5, 0.05),), stiffness=(200, 200, 200))
    r = simulate(environment=block(floor=False), controller=ctrl, duration_s=0.6, seed=2, rate_hz=2700.0,
                 start=(0, 0, 0.02))
    assert len(r.impact_intervals) >= 1
    a, b = r.impact_intervals[0]
    assert r.surfaces[int(np.flatnonzero(r.contact[a + 5])[0])] == "block_face"
    seg = np.diff(r.strain[a:a + 108], axis=0)  # 40 ms after the impact, difference signal (7.1)
    n_fft = 2048
    spec = np.abs(np.fft.rfft(seg * np.hamming(len(seg))[:, None], n_fft, axis=0)) ** 2
    freqs = np.fft.rfftfreq(n_fft, 1.0 / 2700.0)
    band = (freqs > 200) & (freqs < 1350)
    peak = freqs[band][np.argmax(spec[band].sum(axis=1))]
    assert peak == pytest.approx(C.SHELL_MODE_HZ, rel=0.10)
    # and the ringing dies away: resting against the block at the end is much quieter
    rest = np.diff(r.strain[-135:], axis=0)
    assert np.mean(seg**2) > 100 * np.mean(rest**2)
    assert b < len(r)


def _slide(controller, material="polished_aluminium", duration=2.5, seed=4):
    return simulate(environment=plane(material=material), controller=controller, duration_s=duration,
                    seed=seed, start=(0, 0, R + 0.0005))


def test_steady_sliding_friction_ratio_is_the_kinetic_coefficient():
    ctrl = IntegralForceController(forces=((0.0, (0.0, 0.0, -0.3)), (0.3, (0.25, 0.0, -0.3))))
    r = _slide(ctrl)
    sl = slice(800, None)
    assert r.slipping[sl, 0].all() and (r.fingertip_velocity[sl, 0] > 0.005).all()
    fc = r.contact_force[sl, 0]
    ratio = np.mean(np.hypot(fc[:, 0], fc[:, 1])) / np.mean(fc[:, 2])
    assert ratio == pytest.approx(get_material("polished_aluminium").mu_kinetic, rel=0.05)


def _still_runs(v, thr=1e-3):
    still = np.abs(v) < thr
    return still.mean(), int(np.sum(np.diff(still.astype(int)) != 0))


def test_stick_slip_under_low_stiffness_position_control_but_not_integral_force_control():
    # on aluminium sanded with 80 grit (a surface of the thesis, 7.2), both controllers on
    # their defaults (encoder feedback): the 100 N/m PD loop sticks and slips repeatedly,
    # the integral force controller (a generalized damper, 9.1.2) slides steadily
    pd = PositionController(moves=(Move((0, 0, -0.0035), 0.2, 0.0), Move((0.01, 0, 0), 2.0, 0.3)))
    r = _slide(pd, material="sanded_aluminium_80")
    vx = r.fingertip_velocity[600:2200, 0]
    frac_still, transitions = _still_runs(vx)
    assert frac_still > 0.1 and np.mean(vx > 0.005) > 0.2 and transitions >= 10
    fi = IntegralForceController(forces=((0.0, (0.0, 0.0, -0.3)), (0.3, (0.25, 0.0, -0.3))))
    r2 = _slide(fi, material="sanded_aluminium_80")
    vx2 = r2.fingertip_velocity[800:2500, 0]
    frac_still2, transitions2 = _still_runs(vx2)
    # (the drive's commutation and brush ripple may dip it under 1 mm/s for a few ms once:
    # one dip, not the repeated stick-slip of the PD loop)
    assert frac_still2 < 0.01 and transitions2 <= 2


def test_cached_texture_phases_match_the_exact_evaluation_along_a_path():
    # the integrator advances each texture mode's (sin, cos) by rotation between steps
    # (dynamics._texture_cached); along a slow slide, a stop, a jump and a change of material
    # it must give what the exact evaluation gives
    from contactlab.sim.dynamics import TEXTURE_RESYNC_STEPS, _texture_at, _texture_cached
    from contactlab.sim.environment import sample_b

    pk = sample_b().pack(C.FINGERTIP_RADIUS)
    keys = ("h_k1", "h_k2", "h_amp", "h_bamp", "h_phase", "m_k1", "m_k2", "m_amp", "m_phase", "e_tab", "e_par")
    arrs = [pk[k] for k in keys]
    nh, nm = pk["h_k1"].shape[1], pk["m_k1"].shape[1]
    kmax = np.array([max((np.abs(pk["h_k1"][m]) + np.abs(pk["h_k2"][m])).max(),
                         (np.abs(pk["m_k1"][m]) + np.abs(pk["m_k2"][m])).max()) for m in range(pk["h_k1"].shape[0])])
    tcache = np.array([[-1.0, 0.0, 0.0, 0.0]])
    tsh, tch, tsm, tcm = np.zeros((1, nh)), np.zeros((1, nh)), np.zeros((1, nm)), np.zeros((1, nm))
    rng = np.random.default_rng(0)
    s1 = np.cumsum(np.r_[np.full(3000, 4e-7), np.zeros(200), [2e-3], np.full(1000, -4e-7)])
    s2 = np.cumsum(rng.normal(0.0, 5e-8, len(s1)))
    mids = np.r_[np.zeros(2000, int), np.ones(len(s1) - 2000, int)]
    rotated = 0
    for a, b, m in zip(s1, s2, mids):
        got = _texture_cached(0, m, a, b, tcache, tsh, tch, tsm, tcm, kmax, *arrs)
        want = _texture_at(m, a, b, *arrs)
        rotated += tcache[0, 3] > 0
        np.testing.assert_allclose(got, want, rtol=1e-8, atol=1e-12 * np.max(np.abs(want)) + 1e-15)
    assert rotated > len(s1) * (1 - 2.0 / TEXTURE_RESYNC_STEPS) - 10  # the rotation path ran


def test_scaled_friction_scales_only_the_coulomb_coefficients():
    from contactlab.sim.materials import MATERIALS, scaled_friction

    wood = MATERIALS["rough_wood"]
    m = scaled_friction("rough_wood", 0.25)
    assert (m.mu_static, m.mu_kinetic) == pytest.approx((0.25 * wood.mu_static,
                                                         0.25 * wood.mu_kinetic))
    # the relative variation along the surface, the elasticity and the relief are kept
    assert m.mu_variation == wood.mu_variation
    assert m.hertz_constant() == wood.hertz_constant()
    assert (m.roughness_rms, m.restitution) == (wood.roughness_rms, wood.restitution)
    assert m.name == "rough_wood-friction-x0.25" and MATERIALS["rough_wood"] is wood
    assert scaled_friction(m, 0.0).mu_static == 0.0
    with pytest.raises(ValueError, match="factor"):
        scaled_friction("rough_wood", -1.0)
