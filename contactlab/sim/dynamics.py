"""The apparatus: robot mass, sensor spring, fingertip shell, contacts.

One module on purpose: :func:`integrate` is one compiled (numba) time-stepping
loop over one state -- robot, shell, every contact's stick/slip spring, the
servo -- and the compiled helpers it inlines are read beside it: the servo tick
(:func:`_servo_tick`), the contact forces with their friction (:func:`_contact_forces`),
the drive's forces and losses (:func:`_drive_forces`, :func:`_drive_friction`), the
output sampling, and the small ones (texture heights, the brush ripple, commutation,
quantisation).  Its inputs are named records (:class:`Mechanics`, :class:`Drive`,
:class:`Surfaces` with their :class:`Texture`, :class:`Servo`, :class:`Start`,
:class:`Labelling`), its state named records of arrays, its result :class:`Outputs`; the
apparatus constants it runs with are the :class:`Apparatus` above it.  The helpers are
inlined into the loop (``inline="always"``): the kernels' fast-math lets the compiler
reassociate, and helpers compiled apart round differently; tests/test_sim_checksums.py
holds the results to the bit.

Model (thesis 4.6-4.8, 4.12).  Two point masses in R^3:

- the robot (PHANToM endpoint), mass ``robot_mass``, position x_r, driven by the
  controller wrench w_r of (4.12) (gravity-compensated, with a random error w);
- the fingertip shell, mass ``shell_mass``, position x (the sphere centre),
  joined to the robot by the sensor's spring K and damper B.  The sensor
  measures w_m = K (x - x_r) + B (xdot - xdot_r)  (4.6).

  p_r' = w_r + w_m + m_r g                  (4.7, gravity written explicitly)
  p'   = f_contact + m g - w_m              (4.8, contacts replace C_x lambda + w_d)

The shell mode.  K is chosen so that the shell on a fixed base rings at the
thesis's 690 Hz (3.3), lightly damped; so this same spring is the sensor
structure mode: every impact, every bounce, every loss of contact rings it, and
the ringing dies away with the 2 % modal damping.  While the shell is pressed on
a stiff surface its normal motion is stiffened by the contact (the in-contact
mode is higher); impacts, which are trains of short bounces (4.51), ring at the
free-shell frequency in between.

Contacts: stiff, damped penalty (Hertz + Hunt-Crossley), not complementarity.
The quantities the thesis cares about (impact ringing, bounce trains, stored
spring energy released at loss of contact, 4.51-4.52) are compliant-contact
phenomena; complementarity would make the contact rigid and the impact
instantaneous and then need a separate restitution model.  The normal force
is F_n = k_h delta^1.5 (1 + 1.5 alpha delta') with k_h from Hertz theory for the
steel shell on the material and alpha from its restitution, so the stiffness
is physical, not a numerical choice.  Any number of planes can be active
together (plane, line = 2, corner = 3).

Friction: a stick/slip state machine with a tangential (Mindlin) contact spring,
not a regularised (tanh) Coulomb law.  A regularised law creeps under any
tangential load, so a finger could never truly stick and there would be no
static > kinetic breakaway, hence no stick-slip.  Here each contact carries an
elastic tangential displacement xi: sticking, F_t = -k_t xi - c_t v_t must stay
inside the static cone mu_s F_n; once it leaves it the contact slips with
|F_t| = mu_k F_n opposing the slip, and it re-sticks when the trial force falls
back inside the kinetic cone (the slip has stopped or reversed).  The height
the sphere follows is the texture's envelope (the components it can follow, and for a
lay-dominated texture the exact envelope over its ridges, whose cusps are micro-impacts);
the roughness it bridges raises or lowers the friction coefficient with the
asperity-flank slope along the sliding direction, and mu itself varies along
the surface (:mod:`contactlab.sim.materials`): that is what makes sliding
vibrate, without lifting the finger off.  Across a texture boundary the two
followed heights are blended over the width the sphere needs to roll over the
step (``constants.TEXTURE_EDGE_MIN_WIDTH``).

The drive's structure (``Apparatus.cable_stiffness``, ``Apparatus.link_stiffness``, both off by
default: the rigid robot, one mass).  The real robot is not one rigid mass.  The motors pull the
arm through capstan cables, and the sensor's body sits on the end of the distal link, which
bends.  The simulator can split the robot mass into a chain of up to three bodies: the drive
(position x_r: where the motors' force, the backdrive friction with its brush ripple, the
commutation ripple and the encoders act), the arm (x_a) and the link's tip (x_l, carrying the
sensor's base), joined by the cables' stiffness k_c, c_c and the link's bending stiffness k_l,
c_l:

  m_d x_r'' = w_r + k_c (x_a - x_r) + c_c (x_a' - x_r') + m_d g + friction
  m_a x_a'' = k_l (x_l - x_a) + c_l (x_l' - x_a') - k_c (x_a - x_r) - c_c (x_a' - x_r') + m_a g
  m_l x_l'' = w_m - k_l (x_l - x_a) - c_l (x_l' - x_a') + m_l g
  w_m = K (x - x_l) + B (x' - x_l')

A rigid cable or link merges the two bodies it joins (its force is then whatever the next
spring passes on).  With the cables (``constants.CABLE_STIFFNESS``) the drive is the motors'
rotors reflected to the tip (``constants.ROTOR_MASS``, 7.7 g) and the arm is the rest: the
rotors ring on the cables at ~380 Hz, and the brush ripple and the force DAC's steps that act
on them reach the arm amplified, so a moving drive shakes the sensor several times harder
than a rigid one (7.3.3: moving is louder than stationary).  But the amplifiers' force noise
then reaches a pressed sensor through a lightly damped arm (the drive's friction damps only
the rotors), so a pressed finger is louder still (``constants.CABLE_STIFFNESS`` gives the
measurements).  With the link (``constants.LINK_STIFFNESS``) the link's tip (``link_tip_mass``)
with the shell rings against the rest at ~180 Hz; a lumped tip light enough for that mode puts
the sensor's own ringing on a 15 g base (``constants.LINK_STIFFNESS`` gives what that does to
the thesis's signal facts).

The PHANToM's own losses.  Without them the only damping of the ~250 Hz mode of
the robot mass on the sensor spring is the sensor's 2 % (0.7 % of critical for
that mode), and a resting finger would ring on control noise forever.  The robot
mass carries (a) the Coulomb backdrive friction of its motors, brushes, bearings
and capstan cables (``constants.ROBOT_BACKDRIVE_FRICTION``) with its pre-sliding
compliance: an elasto-plastic law (Dupont et al. 2002; the bristle of the LuGre model), a
deflection z_b that follows the robot and pulls it back with -k_b z_b - c_b v_r while that
stays inside the static limit (stuck: the robot moves only by micrometres,
``constants.ROBOT_PRESLIDING_DISPLACEMENT``), clipped to the kinetic value while it slides,
stuck again once the trial force falls back inside the kinetic limit (the same state machine
as a contact's tangential spring); with ``robot_presliding = 0`` the exact set-valued law of
a rigid stick instead; and (b) a small viscous term from the back-EMF left over
by the current amplifiers (``constants.ROBOT_VISCOUS_DAMPING``).  Friction
decays a ringing amplitude linearly, by 4 F_c of spring force per cycle, and holds
a robot whose net drive is below F_c: that is what makes a resting contact quiet.
Held by the compliant stick, the motors' random force (``constants.AMPLIFIER_FORCE_NOISE``)
still moves the robot by a fraction of a micrometre: in free space robot and shell move
together and the sensor feels only the shell's inertia, pressed against an object the
sensor is the stiffest path to ground and carries that force (7.3.3: pressed is louder).
A stuck robot breaks free only above the static value
(``constants.ROBOT_BACKDRIVE_STATIC_FRICTION``), so a motion starts with a jerk (the
start-of-motion burst of 7.2); while it slides the kinetic value ripples with the
motor shaft angle (``constants.BRUSH_FRICTION_VARIATION``: brushes over the
commutator, capstan cable strands), a tabulated pattern over one revolution of the
path travelled (:func:`brush_ripple_table`): the vibration of a moving drive.

Motors.  The servo's force command leaves the DAC in steps of ``force_resolution``
(``constants.FORCE_RESOLUTION``, its error a function of the command, CONTROL_ERROR_STD) and
the current amplifiers add a random force per tick (the random control wrench w of 4.12).
The PHANToM's brushed DC motors (Maxon RE 25 class, ironless rotor: no cogging)
deliver the commanded force times a commutation ripple that depends on the shaft angle
(:func:`commutation_gain`; ``constants.COMMUTATOR_SEGMENTS``, ``COMMUTATION_RIPPLE_PP``):
each Cartesian axis is taken as one motor turning ``constants.MOTOR_RAD_PER_TIP_M`` rad per
metre of robot travel, so the ripple is a fixed pattern in position -- a static force
error at rest and a vibration at n_events x shaft rev/s while moving (28 Hz at 0.1 m/s).

Servo.  The controller runs at the 1 kHz servo rate on what the controller
declares it feeds back (``controllers.FEEDBACK``): by default the encoder-
quantised robot position as the PHANToM's (slightly wrong) kinematics report it
(``sensor.Encoders.kinematic_error``) and a differenced, lowpassed velocity, as on the real
PHANToM; or the true state, the idealised controller of (4.12).

Integrator: fixed step, semi-implicit (symplectic) Euler at >= 20 kHz, with the
stiff contact springs (normal, and tangential while sticking) treated linearly
implicitly along their directions, so the step is stable for any contact
stiffness while the 690 Hz mode (omega dt ~ 0.2) is resolved.  Output is point
sampled (like an ADC without anti-alias filter) every ``n_sub`` steps.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numba
import numpy as np

# floating-point contraction, reassociation and fast reciprocals in the integrator's kernels
# (no assumptions about NaN or infinity): ~20-30 % faster, results equal to rounding
_FAST = {"nsz", "arcp", "contract", "afn", "reassoc"}

from contactlab.sim import constants as C
from contactlab.sim.controllers import ServoArrays
from contactlab.sim.environment import (GEO_EDGE, GEO_LOWER, GEO_NORMAL, GEO_OFFSET, GEO_SPLIT, GEO_U, GEO_UPPER,
                                        GEO_V, PROP_ALPHA, PROP_HERTZ, PROP_MU_KINETIC, PROP_MU_STATIC)


def _mode_hz(k: float, m1: float, m2: float) -> float:
    """Natural frequency of two masses joined by a spring of stiffness ``k``, Hz (physics)."""
    return math.sqrt(k * (1.0 / m1 + 1.0 / m2)) / (2.0 * math.pi)


def _mode_damping(k: float, m1: float, m2: float, ratio: float) -> float:
    """Damping of that spring for ``ratio`` of critical on the reduced mass, N s/m."""
    return 2.0 * ratio * math.sqrt(k * (m1 * m2 / (m1 + m2)))


@dataclass(frozen=True)
class Apparatus:
    """Mechanical parameters of the robot + sensor + fingertip (defaults from :mod:`constants`)."""

    robot_mass: float = C.ROBOT_MASS
    shell_mass: float = C.SHELL_MASS
    sensor_stiffness: float = C.SENSOR_STIFFNESS
    sensor_damping: float = C.SENSOR_DAMPING
    radius: float = C.FINGERTIP_RADIUS
    origin_offset: float = C.SENSOR_ORIGIN_OFFSET
    gravity: float = C.GRAVITY
    control_error_std: float = C.AMPLIFIER_FORCE_NOISE
    force_resolution: float = C.FORCE_RESOLUTION
    servo_rate_hz: float = C.SERVO_RATE_HZ
    robot_friction: float = C.ROBOT_BACKDRIVE_FRICTION
    robot_static_friction: float = C.ROBOT_BACKDRIVE_STATIC_FRICTION
    brush_friction_variation: float = C.BRUSH_FRICTION_VARIATION
    robot_damping: float = C.ROBOT_VISCOUS_DAMPING
    # commutation torque ripple of the brushed motors (0 events: an ideal motor).  On by
    # default: with the drive's static friction and brush ripple the encoder-feedback integral
    # force loop against the maze walls keeps its margin (no limit cycle; the apparatus
    # experiment's force-loop fact and the maze trials measure it)
    commutation_events: int = C.COMMUTATION_EVENTS_PER_REV
    motor_rad_per_m: float = C.MOTOR_RAD_PER_TIP_M
    # pre-sliding displacement of the backdrive friction at breakaway, m (0: a rigid stick)
    robot_presliding: float = C.ROBOT_PRESLIDING_DISPLACEMENT
    presliding_damping_ratio: float = C.PRESLIDING_DAMPING_RATIO
    # the drive's structure (module docstring, "The drive's structure"): the motors' rotors
    # (rotor_mass of robot_mass, where the motors' force, the friction and the encoders act) on
    # the capstan cables' stiffness cable_stiffness against the arm, and the link's tip
    # (link_tip_mass, carrying the sensor) on the link's bending stiffness link_stiffness; both
    # 0 (rigid) by default, one robot mass (constants.CABLE_STIFFNESS and LINK_STIFFNESS say
    # why; those values turn the modes on)
    rotor_mass: float = C.ROTOR_MASS
    cable_stiffness: float = 0.0
    cable_damping_ratio: float = C.CABLE_DAMPING_RATIO
    link_tip_mass: float = C.LINK_TIP_MASS
    link_stiffness: float = 0.0
    link_damping_ratio: float = C.LINK_DAMPING_RATIO

    @property
    def rigid_cable(self) -> bool:
        return self.cable_stiffness <= 0.0

    @property
    def rigid_link(self) -> bool:
        return self.link_stiffness <= 0.0

    @property
    def rigid_drive(self) -> bool:
        """Cables and link rigid: the robot is one mass."""
        return self.rigid_cable and self.rigid_link

    @property
    def friction_mass(self) -> float:
        """The mass the drive's friction and motors act on (the drive), kg: the rotors behind
        the cables, the robot less the link's tip for rigid cables, the whole robot for a rigid
        drive."""
        if not self.rigid_cable:
            return self.rotor_mass
        return self.robot_mass - (0.0 if self.rigid_link else self.link_tip_mass)

    drive_mass = friction_mass

    @property
    def arm_mass(self) -> float:
        """The arm behind the cables (links, drums, gimbal; with the link's tip unless the link
        mode is on), kg; 0 for rigid cables."""
        if self.rigid_cable:
            return 0.0
        return self.robot_mass - self.rotor_mass - (0.0 if self.rigid_link else self.link_tip_mass)

    @property
    def link_mass(self) -> float:
        """The link's tip (carrying the sensor's base) with the link mode, kg."""
        return self.link_tip_mass

    @property
    def base_mass(self) -> float:
        """The body the sensor's base sits on, kg: the link's tip, else the arm behind the
        cables, else the whole robot."""
        if not self.rigid_link:
            return self.link_tip_mass
        return self.robot_mass - (0.0 if self.rigid_cable else self.rotor_mass)

    @property
    def cable_damping(self) -> float:
        """Damping of the cables' stretch, N s/m (CABLE_DAMPING_RATIO on the cable mode's
        reduced mass)."""
        if self.rigid_cable:
            return 0.0
        return _mode_damping(self.cable_stiffness, self.rotor_mass, self._cable_rest,
                             self.cable_damping_ratio)

    @property
    def cable_mode_hz(self) -> float:
        """The cable mode (the rotors against the rest of the robot with the shell), Hz (0:
        rigid cables)."""
        if self.rigid_cable:
            return 0.0
        return _mode_hz(self.cable_stiffness, self.rotor_mass, self._cable_rest)

    @property
    def _cable_rest(self) -> float:
        """What the rotors pull through the cables: the rest of the robot and the shell, kg."""
        return self.robot_mass - self.rotor_mass + self.shell_mass

    @property
    def link_damping(self) -> float:
        """Damping of the link's bending, N s/m (LINK_DAMPING_RATIO on the mode's reduced mass)."""
        if self.rigid_link:
            return 0.0
        return _mode_damping(self.link_stiffness, self.robot_mass - self.link_tip_mass,
                             self.link_mass + self.shell_mass, self.link_damping_ratio)

    @property
    def drive_mode_hz(self) -> float:
        """The link mode (the link's tip with the shell against the rest of the robot), Hz (0:
        rigid link)."""
        if self.rigid_link:
            return 0.0
        return _mode_hz(self.link_stiffness, self.robot_mass - self.link_tip_mass,
                        self.link_mass + self.shell_mass)

    @property
    def drive_sag(self) -> float:
        """Static sag of the sensor's base below the drive: the cables' stretch under the arm's
        and the shell's weight plus the link's bending under its tip's and the shell's, m."""
        sag = 0.0
        if not self.rigid_cable:
            sag += (self.robot_mass - self.rotor_mass + self.shell_mass) * self.gravity / self.cable_stiffness
        if not self.rigid_link:
            sag += (self.link_mass + self.shell_mass) * self.gravity / self.link_stiffness
        return sag

    @property
    def presliding_stiffness(self) -> float:
        """Stiffness of the drive friction before it breaks away, N/m (0: rigid stick)."""
        if self.robot_presliding <= 0.0 or self.robot_static_friction <= 0.0:
            return 0.0
        return self.robot_static_friction / self.robot_presliding

    @property
    def presliding_damping(self) -> float:
        """Damping of the pre-sliding deflection, N s/m."""
        return 2.0 * self.presliding_damping_ratio * math.sqrt(self.presliding_stiffness * self.friction_mass)

    @property
    def total_mass(self) -> float:
        return self.robot_mass + self.shell_mass

    @property
    def shell_mode_hz(self) -> float:
        return math.sqrt(self.sensor_stiffness / self.shell_mass) / (2.0 * math.pi)


# ---------------- the integrator's inputs, as named records (numba accepts named tuples) --------


class Mechanics(NamedTuple):
    """The robot + sensor + fingertip masses and the sensor's spring (module docstring)."""

    robot_mass: float            # mr: the whole robot, kg
    shell_mass: float            # mf: the fingertip shell, kg
    sensor_stiffness: float      # ks, N/m
    sensor_damping: float        # bs, N s/m
    radius: float                # fingertip radius, m
    origin_offset: float         # distance of the sensor origin from the sphere centre, m
    gravity: float               # m/s^2
    servo_rate: float            # Hz


class Drive(NamedTuple):
    """The robot's drive: its losses, the force DAC, the structure and the motors (module
    docstring, "The PHANToM's own losses", "The drive's structure", "Motors")."""

    friction: float              # fr: kinetic backdrive friction, N
    damping: float               # br: viscous back-EMF damping, N s/m
    static_friction: float       # frs: breakaway friction, N
    brush_table: np.ndarray      # kinetic-friction multiplier over a shaft revolution
    presliding_stiffness: float  # kb, N/m (0: rigid stick)
    presliding_damping: float    # cb, N s/m
    force_resolution: float      # f_res: the force DAC's step, N
    rotor_mass: float            # m_rot: the rotors reflected to the tip, kg
    cable_stiffness: float       # kc (0: rigid cables), N/m
    cable_damping: float         # cc, N s/m
    link_tip_mass: float         # m_tip, kg
    link_stiffness: float        # kl (0: rigid link), N/m
    link_damping: float          # cl, N s/m
    commutation_events: int      # n_comm per revolution (0: ideal motors)
    motor_gain: float            # shaft rad per tip metre
    commutation_phase: np.ndarray  # (3,) shaft angle offsets, rad


class Texture(NamedTuple):
    """Every material's texture modes (:func:`contactlab.sim.materials.texture_modes`, one row a
    material): height modes' wavenumbers, amplitudes (followed and bridged) and phases, friction
    modes' wavenumbers, amplitudes and phases, the lay envelope's table and its parameters."""

    h_k1: np.ndarray
    h_k2: np.ndarray
    h_amp: np.ndarray
    h_bamp: np.ndarray
    h_phase: np.ndarray
    m_k1: np.ndarray
    m_k2: np.ndarray
    m_amp: np.ndarray
    m_phase: np.ndarray
    e_tab: np.ndarray
    e_par: np.ndarray


class Surfaces(NamedTuple):
    """The environment's planes (:meth:`contactlab.sim.environment.Environment.pack`): ``geo``
    one row a plane with the columns ``environment.GEO_*``, the two materials of each plane
    (either side of its split), ``props`` one row a material with the columns
    ``environment.PROP_*``, and the materials' textures."""

    n_planes: int
    geo: np.ndarray
    mat_ids: np.ndarray
    props: np.ndarray
    texture: Texture


class Servo(NamedTuple):
    """The controller, one row a servo tick, the amplifiers' noise, and what the servo
    measures (sensor module docstring, Encoders)."""

    controller: ServoArrays
    noise: np.ndarray            # (ticks, 3) amplifiers' random force, N
    encoder_resolution: float    # m
    velocity_filter: np.ndarray  # biquad (b0, b1, b2, a1, a2)
    kin_a: np.ndarray            # kinematic error, linear part (3, 3)
    kin_q: np.ndarray            # kinematic error, quadratic part (3, 3, 3)


class Start(NamedTuple):
    """Initial positions and velocities of the robot and the shell, m and m/s (3,)."""

    robot_position: np.ndarray
    robot_velocity: np.ndarray
    shell_position: np.ndarray
    shell_velocity: np.ndarray


class Labelling(NamedTuple):
    """What the ground truth's impact labels use (simulate._impact_intervals) and the contact
    numerics shared with them."""

    ring_tau: float              # lowpass time constant of the ringing measure, s
    impact_speed: float          # approach speed that makes a gained contact an impact, m/s
    loss_force: float            # normal force whose loss is an impact, N
    tangential_ratio: float      # tangential / normal contact stiffness
    margin: float                # contact search margin, m


class Outputs(NamedTuple):
    """What :func:`integrate` returns, one row an output sample."""

    robot_position: np.ndarray
    robot_velocity: np.ndarray
    shell_position: np.ndarray
    shell_velocity: np.ndarray
    wrench: np.ndarray           # (n, 6) sensor wrench at its origin
    control_wrench: np.ndarray
    desired_position: np.ndarray
    active: np.ndarray           # (n, planes) in contact
    slipping: np.ndarray
    material: np.ndarray         # (n, planes) material under the finger (-1: none)
    contact_force: np.ndarray    # (n, planes, 3) averaged over the sample interval
    event: np.ndarray            # 1: impact, 2: loaded loss of contact
    ring: np.ndarray             # peak ringing within the sample, N


@numba.njit(cache=True, fastmath=_FAST)
def _lay_at(mid, s1, s2, etab, epar):
    # the sphere's envelope over the lay ridges (tabulated, linearly interpolated) and its
    # gradient; beyond the table it is held at its end value (constants)
    c1 = epar[mid, 0]
    c2 = epar[mid, 1]
    uf = (c1 * s1 + c2 * s2 - epar[mid, 2]) / epar[mid, 3]
    iu = int(math.floor(uf))
    ne = etab.shape[1]
    if iu < 0 or iu > ne - 2:
        h = etab[mid, 0] if iu < 0 else etab[mid, ne - 1]
        de = 0.0
    else:
        de = etab[mid, iu + 1] - etab[mid, iu]
        h = etab[mid, iu] + (uf - iu) * de
        de = de / epar[mid, 3]
    return h, de * c1, de * c2


@numba.njit(cache=True, fastmath=_FAST)
def _texture_sum(mid, s1, s2, sh, ch, sm, hk1, hk2, hamp, hbamp, mamp, etab, epar):
    # the texture at (s1, s2) from the sines/cosines of its height modes' phases (sh, ch) and
    # the sines of its friction modes' phases (sm): followed height h and its gradient
    # (g1, g2) with the lay envelope, gradient (b1, b2) of the bridged part, relative friction
    # variation m (materials module docstring)
    h, g1, g2 = _lay_at(mid, s1, s2, etab, epar)
    b1 = 0.0
    b2 = 0.0
    for j in range(hk1.shape[1]):
        ca = ch[j]
        h += hamp[mid, j] * sh[j]
        g1 += hamp[mid, j] * hk1[mid, j] * ca
        g2 += hamp[mid, j] * hk2[mid, j] * ca
        b1 += hbamp[mid, j] * hk1[mid, j] * ca
        b2 += hbamp[mid, j] * hk2[mid, j] * ca
    m = 0.0
    for j in range(sm.shape[0]):
        m += mamp[mid, j] * sm[j]
    return h, g1, g2, b1, b2, m


@numba.njit(cache=True, fastmath=_FAST)
def _texture_at(mid, s1, s2, hk1, hk2, hamp, hbamp, hph, mk1, mk2, mamp, mph, etab, epar):
    # the texture at (s1, s2), every phase evaluated exactly (_texture_sum)
    a = hk1[mid] * s1 + hk2[mid] * s2 + hph[mid]
    return _texture_sum(mid, s1, s2, np.sin(a), np.cos(a), np.sin(mk1[mid] * s1 + mk2[mid] * s2 + mph[mid]),
                        hk1, hk2, hamp, hbamp, mamp, etab, epar)


TEXTURE_ROTATE_MAX = 0.3
"""numerics: a texture mode's phase is advanced by rotating its stored (sin, cos) while the
step's phase change k . ds stays below this (rad; 0.3 rad is 0.4 um of travel on the shortest,
20 um, texture wavelength, i.e. 8 mm/s at 20 kHz); the series used for the rotation (to d^10)
is then exact to ~1e-13 per step, and the pair is recomputed exactly every
TEXTURE_RESYNC_STEPS steps (:func:`_texture_cached`)."""

TEXTURE_RESYNC_STEPS = 256
"""numerics: steps between exact recomputations of the rotated texture phases."""


@numba.njit(cache=True, fastmath=_FAST)
def _rot(sa, ca, d):
    # (sin, cos) of a + d from those of a, d small: Taylor series of sin d (to d^9) and
    # cos d (to d^10), Horner form
    d2 = d * d
    sd = d * (1.0 - d2 / 6.0 * (1.0 - d2 / 20.0 * (1.0 - d2 / 42.0 * (1.0 - d2 / 72.0))))
    cd = 1.0 - d2 / 2.0 * (1.0 - d2 / 12.0 * (1.0 - d2 / 30.0 * (1.0 - d2 / 56.0 * (1.0 - d2 / 90.0))))
    return sa * cd + ca * sd, ca * cd - sa * sd


@numba.njit(cache=True, fastmath=_FAST)
def _texture_cached(p, mid, s1, s2, tcache, tsh, tch, tsm, tcm, kmax,
                    hk1, hk2, hamp, hbamp, hph, mk1, mk2, mamp, mph, etab, epar):
    """:func:`_texture_at` for plane ``p``, keeping each mode's (sin, cos) of its phase between
    calls: while the contact point moves little (k . ds below TEXTURE_ROTATE_MAX for the
    material's largest wavenumber ``kmax``) the pairs are rotated by the phase change instead
    of recomputed (a sliding or resting contact moves well under a micrometre per step).
    ``tcache[p]`` = (material id, s1, s2, steps since the exact evaluation)."""
    d1 = s1 - tcache[p, 1]
    d2 = s2 - tcache[p, 2]
    exact = (int(tcache[p, 0]) != mid or tcache[p, 3] >= TEXTURE_RESYNC_STEPS
             or kmax[mid] * (abs(d1) + abs(d2)) > TEXTURE_ROTATE_MAX)
    if exact:
        for j in range(hk1.shape[1]):
            a = hk1[mid, j] * s1 + hk2[mid, j] * s2 + hph[mid, j]
            tsh[p, j] = math.sin(a)
            tch[p, j] = math.cos(a)
        for j in range(mk1.shape[1]):
            a = mk1[mid, j] * s1 + mk2[mid, j] * s2 + mph[mid, j]
            tsm[p, j] = math.sin(a)
            tcm[p, j] = math.cos(a)
        tcache[p, 0] = mid
        tcache[p, 3] = 0.0
    else:
        for j in range(hk1.shape[1]):
            tsh[p, j], tch[p, j] = _rot(tsh[p, j], tch[p, j], hk1[mid, j] * d1 + hk2[mid, j] * d2)
        for j in range(mk1.shape[1]):
            tsm[p, j], tcm[p, j] = _rot(tsm[p, j], tcm[p, j], mk1[mid, j] * d1 + mk2[mid, j] * d2)
        tcache[p, 3] += 1.0
    tcache[p, 1] = s1
    tcache[p, 2] = s2
    return _texture_sum(mid, s1, s2, tsh[p], tch[p], tsm[p], hk1, hk2, hamp, hbamp, mamp, etab, epar)


@numba.njit(cache=True)
def _quantise(x, res):
    if res <= 0.0:
        return x
    return math.floor(x / res + 0.5) * res


def brush_ripple_table(variation: float, *, seed: int = C.CALIBRATION_SEED, n: int = 16384,
                       radius: float = C.BRUSH_TRACK_RADIUS,
                       wavelength_min: float = C.BRUSH_WAVELENGTH_MIN,
                       bars: int = C.COMMUTATOR_SEGMENTS) -> np.ndarray:
    """Kinetic-friction multiplier over one shaft revolution (``n`` points, mean 1, rms
    ``variation``, >= 0): a random pattern of flat spectrum between the commutator bar pitch
    and ``wavelength_min`` on a track of ``radius`` (constants.BRUSH_FRICTION_VARIATION), one
    fixed draw (the same motor in every trial)."""
    if variation <= 0.0:
        return np.ones(n)
    rng = np.random.default_rng([seed, 2])
    k = np.arange(n // 2 + 1)                      # cycles per revolution
    lo = bars
    hi = min(n // 2 - 1, int(2.0 * math.pi * radius / wavelength_min))
    spec = np.zeros(n // 2 + 1, complex)
    band = (k >= lo) & (k <= hi)
    spec[band] = rng.standard_normal(band.sum()) + 1j * rng.standard_normal(band.sum())
    x = np.fft.irfft(spec, n)
    x *= variation / x.std()
    return np.clip(1.0 + x, 0.0, None)


@numba.njit(cache=True)
def _reported(p, i, kin_a, kin_q):
    # axis i of the position the PHANToM's kinematics report for the true position p:
    # p + A p + 0.5 Q(p, p) (sensor.Encoders.kinematic_error)
    r = p[i]
    for j in range(3):
        r += kin_a[i, j] * p[j]
        for k in range(3):
            r += 0.5 * kin_q[i, j, k] * p[j] * p[k]
    return r


@numba.njit(cache=True)
def _smoothstep(t):
    # C1 blend 3t^2 - 2t^3 on [0, 1] and its derivative
    return t * t * (3.0 - 2.0 * t), 6.0 * t * (1.0 - t)


@numba.njit(cache=True)
def commutation_gain(theta, n_events):
    """Torque per unit current of a brushed, ironless motor at shaft angle ``theta`` (rad),
    relative to its mean, with ``n_events`` commutation events per revolution (0: ideal,
    1.0).  Between events the current pattern turns with the rotor, its axis sweeping
    +-pi/n about quadrature: cos of that angle, a cusped ripple of 1 - cos(pi/n) peak-to-peak
    (``constants.COMMUTATION_RIPPLE_PP``), normalised by its mean sin(a)/a, a = pi/n."""
    if n_events <= 0:
        return 1.0
    half = math.pi / n_events
    u = (n_events * theta) % (2.0 * math.pi)
    return math.cos((u - math.pi) / n_events) * half / math.sin(half)


@numba.njit(cache=True)
def _ratchet(mu, slope):
    # Coulomb friction mu on an asperity flank rising by ``slope`` (tan theta) along the
    # sliding direction: apparent macroscopic coefficient (mu + t) / (1 - mu t), >= 0.
    # Patch-averaged slopes are small (rms <= 0.11 for the materials here), so the
    # denominator guard (jamming at mu t -> 1) never acts in practice.
    den = 1.0 - mu * slope
    if den < 0.1:
        den = 0.1
    r = (mu + slope) / den
    return r if r > 0.0 else 0.0



# ---------------- the integrator's state, as named records of arrays ----------------------------


class _Bodies(NamedTuple):
    # positions and velocities (3,) of the drive (xr: the rotors, where the motors' force, the
    # friction and the encoders act), the arm behind the cables (xa), the link's tip (xl,
    # carrying the sensor's base) and the shell (x); a rigid cable or link merges its bodies
    xr: np.ndarray
    vr: np.ndarray
    xa: np.ndarray
    va: np.ndarray
    xl: np.ndarray
    vl: np.ndarray
    x: np.ndarray
    v: np.ndarray


class _Chain(NamedTuple):
    # constants of the step derived from the records: gravity, its compensation, the drive's
    # chain (module docstring, "The drive's structure")
    gvec: np.ndarray
    gcomp: np.ndarray
    has_cable: bool
    has_link: bool
    m_d: float
    m_a: float


class _ServoState(NamedTuple):
    # what the servo sees (sensor module docstring, Encoders): the encoder-quantised robot
    # position and its first difference, lowpassed by a biquad (state vz1, vz2), both at the
    # servo rate; the desired position (integral force controller state xi_int, held x_hold)
    # and the motor command wr
    xm: np.ndarray
    xm_prev: np.ndarray
    vm: np.ndarray
    vz1: np.ndarray
    vz2: np.ndarray
    xi_int: np.ndarray
    x_hold: np.ndarray
    xd_now: np.ndarray
    wr: np.ndarray


class _Contacts(NamedTuple):
    # per plane: in contact, sticking, the tangential spring's displacement, the last normal
    # force, the implicit parts of the normal and tangential springs, the normal, the
    # velocities before the explicit step; the total contact force and friction torque
    active: np.ndarray
    stick: np.ndarray
    tdisp: np.ndarray
    last_fn: np.ndarray
    kn_imp: np.ndarray
    cn_imp: np.ndarray
    kt_imp: np.ndarray
    ct_imp: np.ndarray
    nrm: np.ndarray
    vn_old: np.ndarray
    vt_old: np.ndarray
    fc_tot: np.ndarray
    ft_torque: np.ndarray


class _TextureCache(NamedTuple):
    # per plane (:func:`_texture_cached`): (material id, s1, s2, steps since the exact
    # evaluation), each mode's (sin, cos) of its phase, and each material's largest wavenumber
    key: np.ndarray
    sh: np.ndarray
    ch: np.ndarray
    sm: np.ndarray
    cm: np.ndarray
    kmax: np.ndarray


@numba.njit(cache=True, fastmath=_FAST, inline="always")
def _contact_forces(j, dt, n_sub, radius, surf, lab, x, v, cs, tc, o_fc):
    """Every plane's contact force on the shell at this step (module docstring, "Contacts" and
    "Friction"): where the sphere touches the plane and the texture there (blended across a
    texture boundary), the Hertz + Hunt-Crossley normal force, the stick/slip state machine of
    the tangential spring; their sum and the friction torque about the centre in ``cs``, the
    explicit part of each plane's force added to its output ``o_fc[j]``.  Returns the contact
    event (0, 1: impact, 2: loaded loss)."""
    geo, mat_ids, props = surf.geo, surf.mat_ids, surf.props
    hk1, hk2, hamp, hbamp, hph, mk1, mk2, mamp, mph, etab, epar = surf.texture
    active, stick, tdisp = cs.active, cs.stick, cs.tdisp
    cs.fc_tot[:] = 0.0
    cs.ft_torque[:] = 0.0
    event = 0
    for p in range(surf.n_planes):
        cs.kn_imp[p] = 0.0; cs.cn_imp[p] = 0.0; cs.kt_imp[p] = 0.0; cs.ct_imp[p] = 0.0
        n0 = geo[p, GEO_NORMAL]; n1 = geo[p, GEO_NORMAL + 1]; n2 = geo[p, GEO_NORMAL + 2]
        dist = n0 * x[0] + n1 * x[1] + n2 * x[2] - geo[p, GEO_OFFSET]
        was = active[p]
        fn = 0.0
        ok = dist < radius + lab.margin
        pc0 = x[0] - radius * n0; pc1 = x[1] - radius * n1; pc2 = x[2] - radius * n2
        if ok:
            if (pc0 < geo[p, GEO_LOWER] or pc1 < geo[p, GEO_LOWER + 1] or pc2 < geo[p, GEO_LOWER + 2]
                    or pc0 > geo[p, GEO_UPPER] or pc1 > geo[p, GEO_UPPER + 1] or pc2 > geo[p, GEO_UPPER + 2]):
                ok = False
        delta = 0.0
        if ok:
            s1 = geo[p, GEO_U] * pc0 + geo[p, GEO_U + 1] * pc1 + geo[p, GEO_U + 2] * pc2
            s2 = geo[p, GEO_V] * pc0 + geo[p, GEO_V + 1] * pc1 + geo[p, GEO_V + 2] * pc2
            mid = mat_ids[p, 0] if s1 < geo[p, GEO_SPLIT] else mat_ids[p, 1]
            h, g1, g2, b1, b2, mu_f = _texture_cached(p, mid, s1, s2, tc.key, tc.sh, tc.ch, tc.sm,
                                                      tc.cm, tc.kmax, hk1, hk2, hamp, hbamp, hph,
                                                      mk1, mk2, mamp, mph, etab, epar)
            edge_width = geo[p, GEO_EDGE]
            xs = (s1 - geo[p, GEO_SPLIT]) / edge_width
            if -0.5 < xs < 0.5 and mat_ids[p, 0] != mat_ids[p, 1]:
                # the sphere straddles the texture boundary: blend the followed heights
                ha, g1a, g2a, _, _, _ = _texture_at(mat_ids[p, 0], s1, s2, hk1, hk2, hamp, hbamp, hph,
                                                   mk1, mk2, mamp, mph, etab, epar)
                hb, g1b, g2b, _, _, _ = _texture_at(mat_ids[p, 1], s1, s2, hk1, hk2, hamp, hbamp, hph,
                                                   mk1, mk2, mamp, mph, etab, epar)
                lam, dlam = _smoothstep(xs + 0.5)
                h = (1.0 - lam) * ha + lam * hb
                g1 = (1.0 - lam) * g1a + lam * g1b + (hb - ha) * dlam / edge_width
                g2 = (1.0 - lam) * g2a + lam * g2b
            delta = radius + h - dist
            if delta <= 0.0:
                ok = False
        if not ok:
            if was:
                active[p] = False
                if cs.last_fn[p] > lab.loss_force:
                    event = 2
            cs.last_fn[p] = 0.0
            continue
        vn = n0 * v[0] + n1 * v[1] + n2 * v[2]
        if not was:
            active[p] = True
            stick[p] = True
            tdisp[p, :] = 0.0
            if -vn > lab.impact_speed:
                event = 1
        cs.nrm[p, 0] = n0; cs.nrm[p, 1] = n1; cs.nrm[p, 2] = n2
        vt0 = v[0] - vn * n0; vt1 = v[1] - vn * n1; vt2 = v[2] - vn * n2
        hdot = (g1 * (geo[p, GEO_U] * vt0 + geo[p, GEO_U + 1] * vt1 + geo[p, GEO_U + 2] * vt2)
                + g2 * (geo[p, GEO_V] * vt0 + geo[p, GEO_V + 1] * vt1 + geo[p, GEO_V + 2] * vt2))
        ddot = -vn + hdot
        sq = math.sqrt(delta)
        kh = props[mid, PROP_HERTZ]
        alpha = props[mid, PROP_ALPHA]
        kloc = 1.5 * kh * sq
        cn = 1.5 * alpha * kh * delta * sq
        fn = kh * delta * sq + cn * ddot
        if fn < 0.0:
            fn = 0.0
            cn = 0.0
        cs.kn_imp[p] = kloc
        cs.cn_imp[p] = cn
        # friction
        fac = 1.0 + mu_f
        if fac < 0.0:
            fac = 0.0
        mus = props[mid, PROP_MU_STATIC] * fac
        muk = props[mid, PROP_MU_KINETIC] * fac
        # keep the tangential spring in the current tangent plane
        dn = tdisp[p, 0] * n0 + tdisp[p, 1] * n1 + tdisp[p, 2] * n2
        tdisp[p, 0] += (vt0 * dt - dn * n0)
        tdisp[p, 1] += (vt1 * dt - dn * n1)
        tdisp[p, 2] += (vt2 * dt - dn * n2)
        kt = lab.tangential_ratio * kloc
        ct = lab.tangential_ratio * cn
        ft0 = -kt * tdisp[p, 0] - ct * vt0
        ft1 = -kt * tdisp[p, 1] - ct * vt1
        ft2 = -kt * tdisp[p, 2] - ct * vt2
        mag = math.sqrt(ft0 * ft0 + ft1 * ft1 + ft2 * ft2)
        if mag > 0.0:
            # bridged roughness: flank slope along the (impending) sliding direction -ft/|ft|,
            # plus the tilt of the contact normal on the followed height (the sphere's arcs
            # over the lay ridges): the same ratchet geometry
            e1 = -(geo[p, GEO_U] * ft0 + geo[p, GEO_U + 1] * ft1 + geo[p, GEO_U + 2] * ft2) / mag
            e2 = -(geo[p, GEO_V] * ft0 + geo[p, GEO_V + 1] * ft1 + geo[p, GEO_V + 2] * ft2) / mag
            slope = (b1 + g1) * e1 + (b2 + g2) * e2
            mus = _ratchet(mus, slope)
            muk = _ratchet(muk, slope)
        lim = (mus if stick[p] else muk) * fn
        if mag > lim:
            stick[p] = False
            sc = muk * fn / mag
            ft0 *= sc; ft1 *= sc; ft2 *= sc
            if kt > 0.0:
                tdisp[p, 0] = -ft0 / kt; tdisp[p, 1] = -ft1 / kt; tdisp[p, 2] = -ft2 / kt
        else:
            stick[p] = True
            cs.kt_imp[p] = kt
            cs.ct_imp[p] = ct
        cs.last_fn[p] = fn
        f0 = fn * n0 + ft0; f1 = fn * n1 + ft1; f2 = fn * n2 + ft2
        cs.fc_tot[0] += f0; cs.fc_tot[1] += f1; cs.fc_tot[2] += f2
        # torque of friction about the sphere centre: (-R n) x F_t
        cs.ft_torque[0] += -radius * (n1 * ft2 - n2 * ft1)
        cs.ft_torque[1] += -radius * (n2 * ft0 - n0 * ft2)
        cs.ft_torque[2] += -radius * (n0 * ft1 - n1 * ft0)
        o_fc[j, p, 0] += f0 / n_sub; o_fc[j, p, 1] += f1 / n_sub; o_fc[j, p, 2] += f2 / n_sub
    return event


@numba.njit(cache=True, fastmath=_FAST, inline="always")
def _servo_tick(k, holding, mech, drive, servo, chain, b, sv):
    """One servo tick (module docstring, "Servo" and "Motors"): what the encoders and the
    velocity filter report, the desired position (held, tracked, or integrated from the force
    error by the integral force controller) and the motor command.  Returns ``holding``."""
    ctl = servo.controller
    servo_rate = mech.servo_rate
    vfilt = servo.velocity_filter
    xm, vm = sv.xm, sv.vm
    for a in range(3):
        xm[a] = _quantise(_reported(b.xr, a, servo.kin_a, servo.kin_q), servo.encoder_resolution)
        dv = (xm[a] - sv.xm_prev[a]) * servo_rate
        sv.xm_prev[a] = xm[a]
        vm[a] = vfilt[0] * dv + sv.vz1[a]
        sv.vz1[a] = vfilt[1] * dv - vfilt[3] * vm[a] + sv.vz2[a]
        sv.vz2[a] = vfilt[2] * dv - vfilt[4] * vm[a]
    if ctl.feedback == 1:
        for a in range(3):
            xm[a] = b.xr[a]
            vm[a] = b.vr[a]
    fs_now = mech.sensor_stiffness * (b.x - b.xl) + mech.sensor_damping * (b.v - b.vl)
    xd_now = sv.xd_now
    if ctl.hold[k] != 0:
        if not holding:
            holding = True
            sv.x_hold[:] = xm
        for a in range(3):
            xd_now[a] = sv.x_hold[a]
        vdk = np.zeros(3)
    else:
        holding = False
        vdk = ctl.vd[k].copy()
        if ctl.kind == 1:
            f_app = -fs_now + mech.shell_mass * chain.gvec
            for a in range(3):
                sv.xi_int[a] += ctl.ki[a] * (ctl.fd[k, a] - f_app[a]) / servo_rate
                xd_now[a] = sv.xi_int[a] + ctl.xd[k, a]
        else:
            for a in range(3):
                xd_now[a] = ctl.xd[k, a]
    for a in range(3):
        # the motor command leaves the force DAC in steps of f_res (its error is a
        # function of the command: constant while the command is) and the current
        # amplifiers add their own random noise (noise, constants.AMPLIFIER_FORCE_NOISE)
        sv.wr[a] = _quantise(ctl.kp[a] * (xd_now[a] - xm[a]) + ctl.bp[a] * (vdk[a] - vm[a])
                             + ctl.fff[k, a] + chain.gcomp[a], drive.force_resolution) + servo.noise[k, a]
    return holding


@numba.njit(cache=True, fastmath=_FAST, inline="always")
def _drive_friction(dt, drive, m_d, vr, zb, ftr, rstuck, r_path):
    """The PHANToM's own losses on the drive (module docstring): viscous back-EMF damping
    (implicitly), then the backdrive friction -- elasto-plastic with its pre-sliding
    compliance, or as a rigid set-valued law (if the friction impulse available in the step can
    stop the robot, it sticks, v_r = 0; otherwise it is reduced by that impulse); static
    breakaway while stuck, kinetic friction times the brush/cable ripple of the shaft angle
    while sliding.  Updates ``vr`` and the bristle ``zb``; returns (stuck, path travelled)."""
    br = drive.damping
    fr = drive.friction
    frs = drive.static_friction
    kb = drive.presliding_stiffness
    cb = drive.presliding_damping
    if br > 0.0:
        for a in range(3):
            vr[a] /= 1.0 + dt * br / m_d
    if fr > 0.0:
        brush_tab = drive.brush_table
        nb = brush_tab.shape[0]
        ub = (drive.motor_gain * r_path) % (2.0 * math.pi) * nb / (2.0 * math.pi)
        ib = int(ub)
        fb = ub - ib
        ripple = brush_tab[ib % nb] * (1.0 - fb) + brush_tab[(ib + 1) % nb] * fb
        sp = math.sqrt(vr[0] * vr[0] + vr[1] * vr[1] + vr[2] * vr[2])
        if kb > 0.0:
            # elasto-plastic friction (module docstring, "pre-sliding"): the bristle
            # deflection zb follows the robot; its force -kb zb - cb v_r holds the robot
            # while inside the static limit (stuck) and is clipped to the kinetic value
            # (with the brush ripple) while sliding; it re-sticks when the trial force
            # falls back inside the kinetic limit
            for a in range(3):
                zb[a] += dt * vr[a]
                ftr[a] = -kb * zb[a] - cb * vr[a]
            mag = math.sqrt(ftr[0] * ftr[0] + ftr[1] * ftr[1] + ftr[2] * ftr[2])
            fk = fr * ripple
            if mag > (frs if rstuck else fk):
                rstuck = False
                sc = fk / mag
                for a in range(3):
                    ftr[a] *= sc
                    zb[a] = -ftr[a] / kb
            else:
                rstuck = True
            for a in range(3):
                vr[a] += dt * ftr[a] / m_d
        elif rstuck and sp <= dt * frs / m_d:
            vr[:] = 0.0
        else:
            cap = dt * fr * ripple / m_d
            if sp <= cap:
                vr[:] = 0.0
                rstuck = True
            else:
                rstuck = False
                for a in range(3):
                    vr[a] *= 1.0 - cap / sp
        r_path += dt * math.sqrt(vr[0] * vr[0] + vr[1] * vr[1] + vr[2] * vr[2])
    return rstuck, r_path


@numba.njit(cache=True, fastmath=_FAST, inline="always")
def _drive_forces(dt, mf, drive, chain, b, fs, fc_tot, wr, fcab, flnk):
    """The explicit velocity step of every body: the motors deliver the commanded force times
    the commutation ripple of their shaft angle (module docstring, "Motors"), each body passes
    on to the one before it the cable's, the link's or (rigid) the sensor's force."""
    gvec = chain.gvec
    kc = drive.cable_stiffness; cc = drive.cable_damping
    kl = drive.link_stiffness; cl = drive.link_damping
    xr, vr, xa, va, xl, vl = b.xr, b.vr, b.xa, b.va, b.xl, b.vl
    for a in range(3):
        fm = wr[a]
        if drive.commutation_events > 0:
            fm *= commutation_gain(drive.motor_gain * xr[a] + drive.commutation_phase[a],
                                   drive.commutation_events)
        flnk[a] = kl * (xl[a] - xa[a]) + cl * (vl[a] - va[a]) if chain.has_link else fs[a]
        fcab[a] = kc * (xa[a] - xr[a]) + cc * (va[a] - vr[a]) if chain.has_cable else flnk[a]
        vr[a] += dt * ((fm + fcab[a]) / chain.m_d + gvec[a])
        if chain.has_cable:
            va[a] += dt * ((flnk[a] - fcab[a]) / chain.m_a + gvec[a])
        if chain.has_link:
            vl[a] += dt * ((fs[a] - flnk[a]) / drive.link_tip_mass + gvec[a])
        b.v[a] += dt * ((fc_tot[a] - fs[a]) / mf + gvec[a])


@numba.njit(cache=True, fastmath=_FAST, inline="always")
def _record(j, b, fs, r_os, sv, cs, n_planes, out):
    """Point-sample the state into output row ``j`` (the interval's first step)."""
    for a in range(3):
        out.robot_position[j, a] = b.xr[a]; out.robot_velocity[j, a] = b.vr[a]
        out.shell_position[j, a] = b.x[a]; out.shell_velocity[j, a] = b.v[a]
        out.wrench[j, a] = fs[a]
        out.control_wrench[j, a] = sv.wr[a]; out.desired_position[j, a] = sv.xd_now[a]
    # torque at the sensor origin: r_os x w_m + friction torque about the centre
    ft_torque = cs.ft_torque
    out.wrench[j, 3] = r_os[1] * fs[2] - r_os[2] * fs[1] + ft_torque[0]
    out.wrench[j, 4] = r_os[2] * fs[0] - r_os[0] * fs[2] + ft_torque[1]
    out.wrench[j, 5] = r_os[0] * fs[1] - r_os[1] * fs[0] + ft_torque[2]
    for p in range(n_planes):
        out.active[j, p] = cs.active[p]
        out.slipping[j, p] = cs.active[p] and not cs.stick[p]


@numba.njit(cache=True, fastmath=_FAST, inline="always")
def _record_material(j, x, radius, surf, active, o_mat):
    """The material under the finger, per plane, into output row ``j``."""
    geo = surf.geo
    for p in range(surf.n_planes):
        if active[p]:
            pc0 = x[0] - radius * geo[p, GEO_NORMAL]
            s1 = (geo[p, GEO_U] * pc0 + geo[p, GEO_U + 1] * (x[1] - radius * geo[p, GEO_NORMAL + 1])
                  + geo[p, GEO_U + 2] * (x[2] - radius * geo[p, GEO_NORMAL + 2]))
            o_mat[j, p] = surf.mat_ids[p, 0] if s1 < geo[p, GEO_SPLIT] else surf.mat_ids[p, 1]


@numba.njit(cache=True, fastmath=_FAST, inline="always")
def _texture_cache(npl, tex):
    """An empty :class:`_TextureCache` for ``npl`` planes (material -1 forces an exact first call)."""
    hk1, hk2, mk1, mk2 = tex.h_k1, tex.h_k2, tex.m_k1, tex.m_k2
    key = np.zeros((npl, 4))
    key[:, 0] = -1.0
    kmax = np.zeros(hk1.shape[0])
    for mm in range(hk1.shape[0]):
        for jj in range(hk1.shape[1]):
            kmax[mm] = max(kmax[mm], abs(hk1[mm, jj]) + abs(hk2[mm, jj]))
        for jj in range(mk1.shape[1]):
            kmax[mm] = max(kmax[mm], abs(mk1[mm, jj]) + abs(mk2[mm, jj]))
    return _TextureCache(key, np.zeros((npl, hk1.shape[1])), np.zeros((npl, hk1.shape[1])),
                         np.zeros((npl, mk1.shape[1])), np.zeros((npl, mk1.shape[1])), kmax)


@numba.njit(cache=True, fastmath=_FAST, inline="always")
def _outputs(n_out, npl):
    return Outputs(np.zeros((n_out, 3)), np.zeros((n_out, 3)), np.zeros((n_out, 3)), np.zeros((n_out, 3)),
                   np.zeros((n_out, 6)), np.zeros((n_out, 3)), np.zeros((n_out, 3)),
                   np.zeros((n_out, npl), np.bool_), np.zeros((n_out, npl), np.bool_),
                   -np.ones((n_out, npl), np.int64), np.zeros((n_out, npl, 3)), np.zeros(n_out, np.int64),
                   np.zeros(n_out))


@numba.njit(cache=True, fastmath=_FAST, inline="always")
def _initial_state(mech, drive, servo, start, npl):
    """The chain's constants, the bodies at rest (each spring of the drive stretched by the
    weight it carries), the servo's state at rest on the initial velocity, no contact; the
    cable's and the link's forces."""
    xr0, vr0 = start.robot_position, start.robot_velocity
    mr, mf = mech.robot_mass, mech.shell_mass
    m_rot, m_tip = drive.rotor_mass, drive.link_tip_mass
    kc, kl = drive.cable_stiffness, drive.link_stiffness
    gvec = np.array([0.0, 0.0, -mech.gravity])
    gcomp = -(mr + mf) * gvec
    has_cable = kc > 0.0
    has_link = kl > 0.0
    m_arm = mr - (m_rot if has_cable else 0.0) - (m_tip if has_link else 0.0)
    m_d = m_rot if has_cable else (m_arm if has_link else mr)
    m_a = m_arm if has_link else mr - m_rot
    chain = _Chain(gvec, gcomp, has_cable, has_link, m_d, m_a)
    xa = xr0.copy(); va = vr0.copy()
    if has_cable:
        for a in range(3):
            xa[a] += (mr - m_rot + mf) * gvec[a] / kc
    xl = xa.copy(); vl = va.copy()
    if has_link:
        for a in range(3):
            xl[a] += (m_tip + mf) * gvec[a] / kl
    bodies = _Bodies(xr0.copy(), vr0.copy(), xa, va, xl, vl, start.shell_position.copy(),
                     start.shell_velocity.copy())
    vfilt = servo.velocity_filter
    sv = _ServoState(np.zeros(3), np.zeros(3), np.zeros(3), np.zeros(3), np.zeros(3),
                     xr0.copy(), xr0.copy(), xr0.copy(), np.zeros(3))
    for a in range(3):
        sv.xm_prev[a] = _quantise(_reported(xr0 - vr0 / mech.servo_rate, a, servo.kin_a, servo.kin_q),
                                  servo.encoder_resolution)
        # filter state at rest on the initial velocity (steady state of the biquad)
        sv.vm[a] = vr0[a]
        sv.vz2[a] = (vfilt[2] - vfilt[4]) * vr0[a]
        sv.vz1[a] = (vfilt[1] - vfilt[3]) * vr0[a] + sv.vz2[a]
    cs = _Contacts(np.zeros(npl, np.bool_), np.ones(npl, np.bool_), np.zeros((npl, 3)), np.zeros(npl),
                   np.zeros(npl), np.zeros(npl), np.zeros(npl), np.zeros(npl), np.zeros((npl, 3)),
                   np.zeros(npl), np.zeros((npl, 3)), np.zeros(3), np.zeros(3))
    return chain, bodies, sv, cs, np.zeros(3), np.zeros(3)


@numba.njit(cache=True, fastmath=_FAST)
def integrate(n_out, n_sub, dt, mech, drive, surf, servo, start, lab):
    """Run the apparatus for ``n_out`` output samples of ``n_sub`` steps of ``dt``.

    ``mech`` :class:`Mechanics`, ``drive`` :class:`Drive`, ``surf`` :class:`Surfaces`,
    ``servo`` :class:`Servo`, ``start`` :class:`Start`, ``lab`` :class:`Labelling`.  Returns
    the :class:`Outputs`, per output sample: states, sensor wrench, controller output and
    ground truth.  See :func:`contactlab.sim.simulate.simulate` for meanings.
    """
    mf, ks, bs, radius, servo_rate = (mech.shell_mass, mech.sensor_stiffness, mech.sensor_damping,
                                      mech.radius, mech.servo_rate)
    n_planes = surf.n_planes
    vr0 = start.robot_velocity
    npl = max(n_planes, 1)
    nk = servo.controller.xd.shape[0]
    out = _outputs(n_out, npl)
    o_fc, o_mat, o_event, o_ring = out.contact_force, out.material, out.event, out.ring
    chain, b, sv, cs, fcab, flnk = _initial_state(mech, drive, servo, start, npl)
    tc = _texture_cache(npl, surf.texture)
    xr, vr, xa, va, xl, vl, x, v = b
    m_d, has_cable, has_link = chain.m_d, chain.has_cable, chain.has_link
    wr = sv.wr
    active, nrm, vn_old, vt_old = cs.active, cs.nrm, cs.vn_old, cs.vt_old
    kn_imp, cn_imp, kt_imp, ct_imp = cs.kn_imp, cs.cn_imp, cs.kt_imp, cs.ct_imp
    holding = False
    last_k = -1
    rstuck = (vr0[0] == 0.0 and vr0[1] == 0.0 and vr0[2] == 0.0)
    r_path = 0.0
    zb = np.zeros(3)             # pre-sliding (bristle) deflection of the drive's friction
    ftr = np.zeros(3)
    fs = ks * (x - xl) + bs * (v - vl)
    f_lp = fs.copy()
    a_lp = dt / (lab.ring_tau + dt)
    r_os = np.array([0.0, 0.0, -mech.origin_offset])

    n_steps = n_out * n_sub
    for i in range(n_steps):
        t = i * dt
        j = i // n_sub
        first = (i % n_sub) == 0
        # ---------------- controller at the servo rate -----------------
        k = int(t * servo_rate + 1e-9)
        if k > nk - 1:
            k = nk - 1
        if k != last_k:
            last_k = k
            holding = _servo_tick(k, holding, mech, drive, servo, chain, b, sv)

        event = _contact_forces(j, dt, n_sub, radius, surf, lab, x, v, cs, tc, o_fc)

        # ---------------- sensor ----------------------------------------
        for a in range(3):
            fs[a] = ks * (x[a] - xl[a]) + bs * (v[a] - vl[a])
            f_lp[a] += a_lp * (fs[a] - f_lp[a])
        ring = math.sqrt((fs[0] - f_lp[0]) ** 2 + (fs[1] - f_lp[1]) ** 2 + (fs[2] - f_lp[2]) ** 2)
        if ring > o_ring[j]:
            o_ring[j] = ring
        if event > o_event[j]:
            o_event[j] = event
        if first:
            _record(j, b, fs, r_os, sv, cs, n_planes, out)
        # ---------------- integrate --------------------------------------
        for p in range(n_planes):
            if active[p]:
                d = v[0] * nrm[p, 0] + v[1] * nrm[p, 1] + v[2] * nrm[p, 2]
                vn_old[p] = d
                for a in range(3):
                    vt_old[p, a] = v[a] - d * nrm[p, a]
        _drive_forces(dt, mf, drive, chain, b, fs, cs.fc_tot, wr, fcab, flnk)
        rstuck, r_path = _drive_friction(dt, drive, m_d, vr, zb, ftr, rstuck, r_path)
        # linearly implicit correction of the stiff contact springs (module docstring,
        # "Integrator"); kept in this loop: as a helper of its own the compiler's fast-math
        # reassociation rounds its products differently (tests/test_sim_checksums.py)
        for p in range(n_planes):
            if not active[p]:
                continue
            if kn_imp[p] > 0.0:
                d = v[0] * nrm[p, 0] + v[1] * nrm[p, 1] + v[2] * nrm[p, 2]
                dnew = (mf * d + dt * cn_imp[p] * vn_old[p]) / (mf + dt * dt * kn_imp[p] + dt * cn_imp[p])
                for a in range(3):
                    v[a] += (dnew - d) * nrm[p, a]
                    # the implicit part of the contact force, so recorded impulses are exact
                    o_fc[j, p, a] += (dnew - d) * nrm[p, a] * mf / dt / n_sub
            if kt_imp[p] > 0.0:
                d = v[0] * nrm[p, 0] + v[1] * nrm[p, 1] + v[2] * nrm[p, 2]
                den = mf + dt * dt * kt_imp[p] + dt * ct_imp[p]
                for a in range(3):
                    vt = v[a] - d * nrm[p, a]
                    vtn = (mf * vt + dt * ct_imp[p] * vt_old[p, a]) / den
                    v[a] += vtn - vt
                    o_fc[j, p, a] += (vtn - vt) * mf / dt / n_sub
        for a in range(3):
            xr[a] += dt * vr[a]
            if has_cable:
                xa[a] += dt * va[a]
            else:
                xa[a] = xr[a]
                va[a] = vr[a]
            if has_link:
                xl[a] += dt * vl[a]
            else:
                xl[a] = xa[a]
                vl[a] = va[a]
            x[a] += dt * v[a]
        if first:
            # the material under the finger, per plane, after the interval's first step
            _record_material(j, x, radius, surf, active, o_mat)
    return out
