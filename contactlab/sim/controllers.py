"""Robot controllers (thesis 4.12, 7.2, 7.3, 9.1).

A controller is a plain object holding its parameters; :meth:`servo_arrays`
turns it into per-servo-tick arrays that the compiled integrator runs at the
PHANToM's 1 kHz servo rate:

  w_r = Kp (x_d - x_r) + Bp (v_d - v_r) + f_ff + G_r + G + w      (4.12)

with gravity compensation of both masses and the random control error w.

- :class:`PositionController`  PD position control along a trajectory of
  moves with a sinusoidal acceleration profile (7.3), optional 2 mm
  sinusoidal exploration (9.1.1).  With the default low stiffness it shows
  stick-slip on surfaces (9.1.2).
- :class:`StrokeController`  the stroking experiment (7.2): open-loop force
  control along z (zero stiffness and damping, constant downward force) and
  position control along x and y; a move of ``command_s`` seconds, then the
  command freezes the robot where it is.
- :class:`IntegralForceController`  the integral endpoint force controller with
  position feedback of fig 9.3: the desired position integrates the force error,
  x_d' = Ki (f_d - f), and a PD loop tracks x_d (its stiffness set by a cascade
  rule so the force loop stays slower than the tracking loop).  In free space a force command
  becomes a constant velocity; in contact it holds the supported part of the
  force and moves along the rest: a generalized damper.

Times are relative to the start of the recorded trial; negative times (the
settling pre-roll) see the initial command.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from contactlab.sim import constants as C

KIND_POSITION = 0
KIND_INTEGRAL_FORCE = 1

FEEDBACK = {"encoder": 0, "true": 1}
"""What the servo loop feeds back (``feedback`` of every controller):

- ``"encoder"``: what the real PHANToM servo sees, the encoder-quantised robot
  position (``constants.ENCODER_RESOLUTION``) and its first difference lowpassed
  like the recorded velocity (``Encoders``), both at the 1 kHz servo rate;
- ``"true"``: the true robot position and velocity sampled at the servo tick,
  the idealised controller of (4.12) that the chapter-4 analysis assumes
  (e.g. the free-flight covariance 4.19-4.21).
"""


def _feedback_code(name: str) -> int:
    try:
        return FEEDBACK[name]
    except KeyError:
        raise ValueError(f"feedback must be one of {sorted(FEEDBACK)}, got {name!r}") from None


PROFILES = ("sinusoidal", "constant_velocity")
"""Command profiles (``shape``) of a :class:`Move`:

- ``"sinusoidal"``: a sinusoidal acceleration profile (7.3), a(t) ~ sin(2 pi t / T):
  velocity and acceleration are continuous at both ends;
- ``"constant_velocity"``: the desired position ramps at constant speed |d| / T
  (linear interpolation, the simplest position command): the desired velocity
  steps up at the start and down at the end.
"""


@dataclass(frozen=True)
class Move:
    """A straight move by ``displacement`` (m, 3-vector) starting at ``start_s`` lasting
    ``duration_s``, with the velocity profile ``shape`` of :data:`PROFILES` (default the
    sinusoidal acceleration profile of 7.3)."""

    displacement: tuple[float, float, float]
    duration_s: float
    start_s: float = 0.0
    shape: str = "sinusoidal"

    def __post_init__(self):
        if self.shape not in PROFILES:
            raise ValueError(f"shape must be one of {PROFILES}, got {self.shape!r}")

    def profile(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Displacement and velocity (n, 3) at times ``t``."""
        tau = np.clip((np.asarray(t, float) - self.start_s) / self.duration_s, 0.0, 1.0)
        inside = (tau > 0.0) & (tau < 1.0)
        if self.shape == "constant_velocity":
            s = tau
            ds = np.where(inside, 1.0 / self.duration_s, 0.0)
        else:
            s = tau - np.sin(2.0 * math.pi * tau) / (2.0 * math.pi)
            ds = np.where(inside, (1.0 - np.cos(2.0 * math.pi * tau)) / self.duration_s, 0.0)
        d = np.asarray(self.displacement, float)
        return s[:, None] * d, ds[:, None] * d


@dataclass(frozen=True)
class Exploration:
    """Small sinusoidal exploratory motion added to the command (9.1.1: amplitude 2 mm in
    all three directions).  Distinct frequencies per axis so the motion spans 3-D."""

    amplitude: float = 0.002
    frequencies_hz: tuple[float, float, float] = (1.0, 1.4, 1.8)

    def offset(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        t = np.asarray(t, float)[:, None]
        w = 2.0 * math.pi * np.asarray(self.frequencies_hz, float)
        on = (t >= 0.0)
        return on * self.amplitude * np.sin(w * t), on * self.amplitude * w * np.cos(w * t)


class ServoArrays(NamedTuple):
    """Per-servo-tick controller description consumed by the integrator (a named tuple, so
    that the compiled integrator takes it as it is): the controller's kind (``KIND_*``), its
    gains per axis (kp, bp, ki), per tick the desired position and velocity, the force
    feedforward, the desired force and whether to hold the position, and what it feeds back
    (:data:`FEEDBACK`)."""

    kind: int
    kp: np.ndarray
    bp: np.ndarray
    ki: np.ndarray
    xd: np.ndarray
    vd: np.ndarray
    fff: np.ndarray
    fd: np.ndarray
    hold: np.ndarray
    feedback: int = 0


def _trajectory(moves, t, start):
    x = np.tile(np.asarray(start, float), (len(t), 1))
    v = np.zeros((len(t), 3))
    for m in moves:
        dx, dv = m.profile(t)
        x += dx
        v += dv
    return x, v


def _critical_damping(stiffness, mass=C.ROBOT_MASS + C.SHELL_MASS, ratio=0.7):
    return tuple(2.0 * ratio * math.sqrt(k * mass) for k in stiffness)


@dataclass(frozen=True)
class PositionController:
    """PD position control (4.12) along ``moves`` from the start position.

    ``stiffness`` defaults to 100 N/m per axis, about 3 % of the PHANToM's
    3.5 N/mm: the "low stiffness" position controller of 9.1.2.  ``damping``
    defaults to the damping ratio ``constants.POSITION_DAMPING_RATIO`` (0.2) on
    the total moving mass.  A guarded move simply commands a target beyond the
    surface.
    """

    moves: tuple[Move, ...] = ()
    stiffness: tuple[float, float, float] = (100.0, 100.0, 100.0)
    damping: tuple[float, float, float] | None = None
    exploration: Exploration | None = None
    feedforward: tuple[float, float, float] = (0.0, 0.0, 0.0)
    name: str = "position"
    feedback: str = "encoder"

    def servo_arrays(self, start, t: np.ndarray) -> ServoArrays:
        xd, vd = _trajectory(self.moves, t, start)
        if self.exploration is not None:
            dx, dv = self.exploration.offset(t)
            xd += dx
            vd += dv
        damping = (self.damping if self.damping is not None
                   else _critical_damping(self.stiffness, ratio=C.POSITION_DAMPING_RATIO))
        n = len(t)
        return ServoArrays(KIND_POSITION, np.asarray(self.stiffness, float), np.asarray(damping, float),
                           np.zeros(3), xd, vd, np.tile(np.asarray(self.feedforward, float), (n, 1)),
                           np.zeros((n, 3)), np.zeros(n, np.int64), _feedback_code(self.feedback))

    def command(self, start, t):
        """The commanded action per sample: desired position (n, 3)."""
        return self.servo_arrays(start, t).xd


@dataclass(frozen=True)
class StrokeController:
    """The stroking experiment of 7.2.

    z: open-loop force control, ``normal_force`` N pressing down, zero stiffness
    and damping.  x, y: PD position control (``stiffness`` N/m) along a move of
    ``stroke_length`` m in +x that starts at ``command_start_s`` and takes
    ``command_s`` s (sinusoidal acceleration profile); when it ends the command
    freezes the robot at its current position (7.2: "switches to a command
    which freezes the robot in its current position").  ``damping`` defaults
    to a damping ratio of 0.7 (a controller setting: the thesis describes
    steady motion over the textures in this experiment, not stick-slip).

    ``shape`` is the command's velocity profile (:data:`PROFILES`).  The default,
    the sinusoidal acceleration profile the thesis used for its trajectories (7.3),
    starts without a burst: y_h at the command start stays at the resting level, and
    friction holds the finger for ~0.6 s while the P term builds the strain (7.2's
    third phase).  7.2's second phase, an "impact-like burst caused by the start of
    the motion command" (and 9.1.1: "the initial acceleration to start the motion
    generated an impact"), appears with ``"constant_velocity"``: the desired
    velocity steps, the servo's damping term kicks the robot by b v (~65 mN), and
    the sensor rings; but then the P term ramps at Kp v and the finger breaks away
    after only ~50 ms.  The thesis does not say which profile 7.2 used, so the
    default stays the documented one (tests/test_sim_losses.py measures both).
    """

    normal_force: float = 0.200
    stroke_length: float = 0.045
    command_start_s: float = 0.5
    command_s: float = 5.0
    direction: tuple[float, float] = (1.0, 0.0)
    stiffness: float = 300.0
    damping: float | None = None
    name: str = "stroke"
    feedback: str = "encoder"
    shape: str = "sinusoidal"

    def servo_arrays(self, start, t: np.ndarray) -> ServoArrays:
        d = np.asarray(self.direction, float)
        d = d / np.linalg.norm(d)
        move = Move((self.stroke_length * d[0], self.stroke_length * d[1], 0.0), self.command_s, self.command_start_s,
                    self.shape)
        xd, vd = _trajectory([move], t, start)
        b = self.damping if self.damping is not None else _critical_damping([self.stiffness])[0]
        n = len(t)
        fff = np.zeros((n, 3))
        fff[:, 2] = -self.normal_force
        hold = (t >= self.command_start_s + self.command_s).astype(np.int64)
        return ServoArrays(KIND_POSITION, np.array([self.stiffness, self.stiffness, 0.0]),
                           np.array([b, b, 0.0]), np.zeros(3), xd, vd, fff, np.zeros((n, 3)), hold,
                           _feedback_code(self.feedback))

    def command(self, start, t):
        return self.servo_arrays(start, t).xd


@dataclass(frozen=True)
class IntegralForceController:
    """Integral endpoint force controller with position feedback (fig 9.3).

    ``forces`` is a sequence of (start_s, (fx, fy, fz)) desired forces, N, that
    the fingertip should apply to the world (the thesis's commands are in mN,
    e.g. (100, -100, 200)); each holds until the next.  x_d' = Ki (f_d - f)
    with f estimated from the sensor (shell gravity compensated), and a PD loop
    tracks x_d.  ``integral_gain`` Ki (m/(N s)) sets the damper: free-space
    speed = ``Ki |f_d|``.  ``damping`` defaults to a damping ratio of 0.7 on the
    tracking loop.

    ``stiffness`` (N/m) defaults to the cascade rule 1 / (4 Ki^2 m) (m the moving
    mass): the outer force loop, whose rate in contact is Kp Ki (the motor force
    is Kp x_d there), must stay below half the natural frequency sqrt(Kp / m) of
    the tracking loop it drives, Kp Ki <= sqrt(Kp / m) / 2.  For Ki = 0.1 that is
    294 N/m.  A stiffer loop (an earlier default was 800 N/m, Kp Ki = 80 /s
    against sqrt(Kp/m) = 97 rad/s) has no separation: on encoder feedback the
    finger then hops off a stiff contact at ~30 Hz in a limit cycle (wind-up of
    x_d below the surface during each flight, a nearly elastic bounce of the
    robot on the sensor spring).  With the cascade rule the controller holds a
    steady contact force under the default encoder feedback (:data:`FEEDBACK`).
    """

    forces: tuple[tuple[float, tuple[float, float, float]], ...] = ((0.0, (0.0, 0.0, -0.2)),)
    integral_gain: float = 0.1
    stiffness: float | None = None
    damping: float | None = None
    exploration: Exploration | None = None
    name: str = "integral_force"
    feedback: str = "encoder"

    @property
    def tracking_stiffness(self) -> float:
        """The PD loop's stiffness, N/m (``stiffness`` or the cascade rule)."""
        if self.stiffness is not None:
            return float(self.stiffness)
        return 1.0 / (4.0 * self.integral_gain**2 * (C.ROBOT_MASS + C.SHELL_MASS))

    def desired_force(self, t: np.ndarray) -> np.ndarray:
        t = np.asarray(t, float)
        fd = np.zeros((len(t), 3))
        for t0, f in sorted(self.forces, key=lambda x: x[0]):
            fd[t >= t0] = f
        first = sorted(self.forces, key=lambda x: x[0])[0]
        fd[t < first[0]] = 0.0
        return fd

    def servo_arrays(self, start, t: np.ndarray) -> ServoArrays:
        n = len(t)
        xd = np.zeros((n, 3))
        vd = np.zeros((n, 3))
        if self.exploration is not None:
            xd, vd = self.exploration.offset(t)
        k = self.tracking_stiffness
        b = self.damping if self.damping is not None else _critical_damping([k])[0]
        return ServoArrays(KIND_INTEGRAL_FORCE, np.array([k, k, k]), np.array([b, b, b]),
                           np.full(3, self.integral_gain), xd, vd, np.zeros((n, 3)),
                           self.desired_force(t), np.zeros(n, np.int64), _feedback_code(self.feedback))

    def command(self, start, t):
        """The commanded action per sample: desired force (n, 3)."""
        return self.desired_force(t)
