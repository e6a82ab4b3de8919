"""One simulated trial: :func:`simulate` -> :class:`SimResult`.

The trial time base starts at 0 after a short settling pre-roll (the robot
starts at rest with its initial command, and the pre-roll lets the fingertip
settle on a surface it starts on, so a trial that "starts resting on the
plate" really does).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from contactlab.sim import constants as C
from contactlab.sim.controllers import KIND_INTEGRAL_FORCE
from contactlab.sim.dynamics import (Apparatus, Drive, Labelling, Mechanics, Servo, Start, Surfaces, Texture,
                                     brush_ripple_table, integrate)
from contactlab.sim.environment import Environment
from contactlab.sim.sensor import Encoders, StrainGaugeSensor


@dataclass
class SimResult:
    """Measurements and ground truth of one trial, one row per output sample.

    The attributes from ``time`` to ``command_kind`` are the measurements (what the real
    apparatus would record); those from ``wrench_true`` on are the ground truth.

    Attributes
    ----------
    time : (n,) s
    strain : (n, 8) quantised half-bridge outputs, V
    wrench : (n, 6) Fx Fy Fz (N), Mx My Mz (N m) at the sensor origin, computed
        from the strains with the inverse calibration (4.6 sign: the force the
        environment exerts on the fingertip, plus its weight and inertia)
    position : (n, 3) encoder-quantised robot position, m
    velocity : (n, 3) first-differenced, lowpassed position, m/s
    command : (n, 3) the commanded action: desired position (m) for position
        controllers, desired force (N) for the integral force controller
    command_kind : "position" or "force"
    wrench_true : (n, 6) noise-free sensor wrench
    robot_position, robot_velocity, fingertip_position, fingertip_velocity : (n, 3)
    desired_position : (n, 3) the position the servo loop tracked
    control_wrench : (n, 3) controller output w_r (4.12) incl. gravity compensation
    surfaces : names of the environment planes (columns of the per-surface arrays)
    contact : (n, S) bool, surface touched at the sample
    contact_mask : (n,) int, bit s set when surface s is touched
    contact_normals : (n, S, 3) unit normal of each touched surface (0 if not touched)
    contact_force : (n, S, 3) contact force on the fingertip averaged over the sample
        interval (so sum * dt is the exact contact impulse)
    slipping : (n, S) bool, contact sliding (outside the static cone)
    sliding_speed : (n,) fingertip speed tangent to the touched surfaces (speed in free space), m/s
    moving : (n,) bool, sliding_speed > ``moving_threshold``
    impact : (n,) bool, inside an impact interval
    impact_intervals : (k, 2) int [start, end) sample indices, from the impact until
        the ringing has decayed below the sensor noise; a bounce train is one impact
        (definition in :func:`_impact_intervals`)
    impact_kinds : (k,) int, 1 = contact gained at speed (4.47), 2 = contact lost
        while loaded (4.52)
    texture : (n,) int index into ``materials`` of the surface under the finger (-1: none)
    materials : material names
    """

    time: np.ndarray
    strain: np.ndarray
    wrench: np.ndarray
    position: np.ndarray
    velocity: np.ndarray
    command: np.ndarray
    command_kind: str
    wrench_true: np.ndarray
    robot_position: np.ndarray
    robot_velocity: np.ndarray
    fingertip_position: np.ndarray
    fingertip_velocity: np.ndarray
    desired_position: np.ndarray
    control_wrench: np.ndarray
    surfaces: list
    contact: np.ndarray
    contact_mask: np.ndarray
    contact_normals: np.ndarray
    contact_force: np.ndarray
    slipping: np.ndarray
    sliding_speed: np.ndarray
    moving: np.ndarray
    impact: np.ndarray
    impact_intervals: np.ndarray
    impact_kinds: np.ndarray
    texture: np.ndarray
    materials: list
    rate_hz: float
    calibration: np.ndarray
    metadata: dict = field(default_factory=dict)

    def __len__(self) -> int:
        return len(self.time)


def simulate(*, environment: Environment, controller, duration_s: float, seed: int,
             rate_hz: float = C.OUTPUT_RATE_HZ, start=None, preroll_s: float = 0.3,
             apparatus: Apparatus | None = None, sensor: StrainGaugeSensor | None = None,
             encoders: Encoders | None = None, internal_rate_hz: float = C.INTERNAL_RATE_MIN_HZ,
             control_noise: bool = True, moving_threshold: float = C.MOVING_SPEED_THRESHOLD,
             initial_velocity=(0.0, 0.0, 0.0)) -> SimResult:
    """Simulate one trial.

    Parameters
    ----------
    environment : an :class:`~contactlab.sim.environment.Environment`
    controller : a controller from :mod:`contactlab.sim.controllers`
    duration_s : recorded length, s
    seed : seeds the control error and the sensor noise (the surface texture
        is fixed by ``environment.texture_seed``); same seed -> identical arrays
    rate_hz : output (ADC) rate; 1000 Hz (7.1) or 2700 Hz (impact spectrogram)
    start : initial fingertip-centre/robot position (m); default ``environment.start``
    preroll_s : settling time simulated before t = 0 and discarded
    apparatus, sensor, encoders : hardware parameters (defaults from :mod:`constants`)
    internal_rate_hz : minimum integration rate; the step is 1/(rate_hz * n_sub)
        with n_sub = ceil(internal_rate_hz / rate_hz)
    control_noise : include the random control wrench w of (4.12)
    moving_threshold : speed (m/s) above which ``moving`` is true
    initial_velocity : initial velocity of robot and fingertip, m/s (used to set up
        an impact without a controller-driven approach)
    """
    if duration_s <= 0:
        raise ValueError("duration_s must be positive")
    if rate_hz <= 0 or internal_rate_hz < rate_hz:
        raise ValueError("need 0 < rate_hz <= internal_rate_hz")
    if preroll_s < 0:
        raise ValueError("preroll_s must be >= 0")
    app = apparatus or Apparatus()
    sen = sensor or StrainGaugeSensor()
    enc = encoders or Encoders()
    n_sub = int(math.ceil(internal_rate_hz / rate_hz - 1e-9))
    dt = 1.0 / (rate_hz * n_sub)
    n_pre = int(round(preroll_s * rate_hz))
    n_rec = int(round(duration_s * rate_hz))
    n_out = n_pre + n_rec
    t0 = n_pre / rate_hz  # trial time = sim time - t0

    n_ticks = int(math.ceil(n_out / rate_hz * app.servo_rate_hz)) + 2
    t_ticks = np.arange(n_ticks) / app.servo_rate_hz - t0
    start = np.asarray(environment.start if start is None else start, float)
    sa = controller.servo_arrays(start, t_ticks)
    ss = np.random.SeedSequence(int(seed))
    # a third child stream (spawning more children leaves the first two unchanged)
    rng_ctrl, rng_sensor, rng_motor = (np.random.default_rng(s) for s in ss.spawn(3))
    # the motors' shaft angles at the start position are unknown: uniform over a revolution
    comm_phase = rng_motor.uniform(0.0, 2.0 * math.pi, 3)
    noise = rng_ctrl.normal(0.0, app.control_error_std, (n_ticks, 3)) if control_noise else np.zeros((n_ticks, 3))

    pk = environment.pack(app.radius)
    gvec = np.array([0.0, 0.0, -app.gravity])
    v0 = np.asarray(initial_velocity, float)
    xr0 = start.copy()
    # hanging at rest on the sensor spring, below the link's static bending
    x0 = start + app.shell_mass * gvec / app.sensor_stiffness + app.drive_sag * gvec / app.gravity
    ring_tau = 1.0 / (2.0 * math.pi * C.RING_LOWPASS_HZ)
    vb, va = enc.velocity_filter(app.servo_rate_hz, enc.servo_velocity_lowpass_hz)
    vfilt = np.array([vb[0], vb[1], vb[2], va[1], va[2]]) / va[0]
    kin_a, kin_q = enc.kinematic_error()
    f_loss = float(np.linalg.norm(sen.wrench_noise_std[:3])) * 3.0
    mech = Mechanics(app.robot_mass, app.shell_mass, app.sensor_stiffness, app.sensor_damping, app.radius,
                     app.origin_offset, app.gravity, app.servo_rate_hz)
    drive = Drive(app.robot_friction, app.robot_damping, app.robot_static_friction,
                  brush_ripple_table(app.brush_friction_variation), app.presliding_stiffness,
                  app.presliding_damping, float(app.force_resolution), float(app.rotor_mass),
                  float(max(app.cable_stiffness, 0.0)), float(app.cable_damping), float(app.link_tip_mass),
                  float(max(app.link_stiffness, 0.0)), float(app.link_damping), int(app.commutation_events),
                  float(app.motor_rad_per_m), comm_phase)
    surf = Surfaces(pk["n_planes"], pk["geo"], pk["mat_ids"], pk["props"],
                    Texture(*(pk[f] for f in Texture._fields)))
    servo = Servo(sa, noise, float(enc.resolution), vfilt, kin_a, kin_q)
    labels = Labelling(ring_tau, C.IMPACT_MIN_APPROACH_SPEED, f_loss, C.TANGENTIAL_STIFFNESS_RATIO,
                       C.CONTACT_MARGIN)
    out = integrate(n_out, n_sub, dt, mech, drive, surf, servo, Start(xr0, v0.copy(), x0, v0.copy()), labels)
    (o_xr, o_vr, o_x, o_v, o_w, o_wr, o_xd, o_act, o_slip, o_mat, o_fc, o_event, o_ring) = out
    sl = slice(n_pre, n_out)
    n_s = len(environment.planes)
    o_act = o_act[sl, :n_s]
    o_slip = o_slip[sl, :n_s]
    o_mat = o_mat[sl, :n_s]
    o_fc = o_fc[sl, :n_s]
    time = np.arange(n_rec) / rate_hz
    wrench_true = o_w[sl]
    strain, wrench = sen.measure(wrench_true, rng_sensor)
    position, velocity = enc.measure(o_xr[sl], rate_hz)

    normals = environment.normals()
    contact_normals = o_act[:, :, None] * normals[None, :, :] if n_s else np.zeros((n_rec, 0, 3))
    contact_mask = (o_act.astype(np.int64) << np.arange(n_s)).sum(axis=1) if n_s else np.zeros(n_rec, np.int64)
    vf = o_v[sl]
    vt = vf.copy()
    for s in range(n_s):
        vn = vt @ normals[s]
        vt = np.where(o_act[:, s:s + 1], vt - vn[:, None] * normals[s], vt)
    sliding_speed = np.linalg.norm(vt, axis=1)
    texture = np.full(n_rec, -1, np.int64)
    for s in range(n_s - 1, -1, -1):
        texture = np.where(o_mat[:, s] >= 0, o_mat[:, s], texture)

    noise_level = float(np.linalg.norm(sen.wrench_noise_std[:3]))
    intervals, kinds = _impact_intervals(o_event[sl], o_ring[sl], noise_level, rate_hz)
    impact = np.zeros(n_rec, bool)
    for a, b in intervals:
        impact[a:b] = True
    kind_str = "force" if sa.kind == KIND_INTEGRAL_FORCE else "position"
    return SimResult(
        time=time, strain=strain, wrench=wrench, position=position, velocity=velocity,
        command=np.asarray(controller.command(start, time), float), command_kind=kind_str,
        wrench_true=wrench_true, robot_position=o_xr[sl], robot_velocity=o_vr[sl],
        fingertip_position=o_x[sl], fingertip_velocity=vf, desired_position=o_xd[sl],
        control_wrench=o_wr[sl], surfaces=environment.surface_names, contact=o_act,
        contact_mask=contact_mask, contact_normals=contact_normals, contact_force=o_fc,
        slipping=o_slip, sliding_speed=sliding_speed, moving=sliding_speed > moving_threshold,
        impact=impact, impact_intervals=np.asarray(intervals, np.int64).reshape(-1, 2),
        impact_kinds=np.asarray(kinds, np.int64), texture=texture,
        materials=[m.name for m in environment.materials], rate_hz=float(rate_hz),
        calibration=sen.calibration,
        metadata=dict(seed=int(seed), environment=environment.name, texture_seed=environment.texture_seed,
                      controller=getattr(controller, "name", type(controller).__name__),
                      duration_s=float(duration_s), internal_rate_hz=1.0 / dt, preroll_s=preroll_s,
                      noise_level_n=noise_level))


def _impact_intervals(event, ring, noise_level, rate_hz):
    """Impact intervals (thesis 4.47-4.52, 7.1) as [start, end) sample indices, and their kinds.

    Definition.  An impact starts at a contact event: a contact gained at a normal
    approach speed above IMPACT_MIN_APPROACH_SPEED (kind 1, 4.47), or a contact lost
    while it carried more than 3 sigma of sensor noise (kind 2, 4.52).  It lasts until
    the ringing (``ring``: peak of the sensor force minus its RING_LOWPASS_HZ lowpass
    within the sample) has stayed below the sensor noise level for IMPACT_QUIET_S, but
    at most IMPACT_MAX_DURATION_S after the event.  An event while an interval is open
    (the next bounce of a bounce train, 4.51) belongs to the same impact and restarts
    its decay: a train of bounces is one interval, from its first bounce to the decay
    after its last, of the kind of its first event; so only the decay after the last
    event, not the whole interval, is bounded by IMPACT_MAX_DURATION_S.
    """
    n = len(event)
    quiet = max(1, int(round(C.IMPACT_QUIET_S * rate_hz)))
    max_len = int(round(C.IMPACT_MAX_DURATION_S * rate_hz))
    below = ring < noise_level
    # run length of "below" starting at each index
    run = np.zeros(n + 1, np.int64)
    for i in range(n - 1, -1, -1):
        run[i] = run[i + 1] + 1 if below[i] else 0
    intervals: list[list[int]] = []
    kinds: list[int] = []
    for i in np.flatnonzero(event):
        end = min(n, i + max_len)
        for k in range(i + 1, min(n, i + max_len)):
            if run[k] >= quiet:
                end = k
                break
        if intervals and i < intervals[-1][1]:
            intervals[-1][1] = max(intervals[-1][1], end)
        else:
            intervals.append([int(i), int(end)])
            kinds.append(int(event[i]))
    return intervals, kinds
