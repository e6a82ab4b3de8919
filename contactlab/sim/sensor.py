"""Measurement chain: strain gauges, ADC, encoders, velocity estimate.

Strain gauges.  The fingertip sensor's Maltese cross carries 8 strain-gauge
half-bridges (thesis 3.3): on each of the four arms (along +x, +y, -x, -y) one
bridge reads bending in the vertical plane and one bending in the horizontal
plane.  A beam model of the cross gives the calibration matrix S (8 x 6,
volts per unit wrench at the sensor origin): for arm i with radial direction
r_i and tangent t_i = z x r_i, arm length L and gauge lever l,

  vertical   s_v,i = g l ( F_z / 4   + (M . t_i) / (2 L) )
  horizontal s_h,i = g l ( F . t_i / 2 + M_z / (4 L) )

(a vertical force is shared by four arms, a moment about t_i by the two arms
along +-r_i as opposite vertical forces, a force along t_i by the two arms
perpendicular to it, M_z by all four as tangential forces).  Every wrench
component excites a different pattern of sums and differences, so S has full
column rank; its condition number after scaling each column by the full-scale
load is small (see :attr:`StrainGaugeSensor.condition_number`).  The gain g
puts a worst-case full-scale wrench at ``headroom`` of the ADC range.

ADC: ``adc_bits`` bits over +/- ``adc_range_v`` V, with the Gaussian noise of the
bridge and its amplifier (:attr:`StrainGaugeSensor.noise_v`, from excitation, gauge
factor, full-scale strain, noise density and bandwidth) added before quantisation.  The reported wrench is the
least-squares inverse of the calibration applied to the quantised strains,
as the real system computed it.

Encoders: the robot-side position quantised at the PHANToM's resolution;
velocity is the first difference of the quantised position, lowpassed with a
2nd-order Butterworth filter (thesis 1.2: "first order differenced and
lowpass filtered").  The servo loop uses the same quantised position and the
same kind of velocity estimate at its 1 kHz rate, with a faster filter
(``servo_velocity_lowpass_hz``, constants.SERVO_VELOCITY_LOWPASS_HZ).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import signal

from contactlab.sim import constants as C


def maltese_cross_matrix(arm_length: float = C.SENSOR_ARM_LENGTH) -> np.ndarray:
    """Unscaled 8 x 6 beam-model matrix (rows: v0, h0, v1, h1, ..., columns Fx Fy Fz Mx My Mz)."""
    rows = []
    for i in range(4):
        phi = i * np.pi / 2.0
        t = np.array([-np.sin(phi), np.cos(phi), 0.0])
        rows.append(np.concatenate([[0.0, 0.0, 0.25], t / (2.0 * arm_length)]))
        rows.append(np.concatenate([t / 2.0, [0.0, 0.0, 1.0 / (4.0 * arm_length)]]))
    return np.array(rows)




@dataclass(frozen=True)
class StrainGaugeSensor:
    """Six-axis fingertip sensor as 8 half-bridges into an ADC (defaults from :mod:`constants`).

    The noise chain: each half-bridge (two active gauges, ``gauge_factor``, excited at
    ``bridge_excitation_v``) gives ``excitation * gauge_factor * full_scale_strain / 2`` at
    full scale; the amplifier's gain maps that onto ``headroom`` of the converter range, and
    its input noise (``amplifier_noise_density`` with the bridge's Johnson noise, over the
    noise bandwidth pi/2 x ``amplifier_bandwidth_hz``) appears at the converter multiplied by
    that gain (:attr:`noise_v`).  ``calibration_error`` makes the true strain pattern differ
    from the nominal calibration matrix (the recorded wrench uses the nominal inverse).
    """

    force_range: float = C.SENSOR_FORCE_RANGE
    torque_range: float = C.SENSOR_TORQUE_RANGE
    arm_length: float = C.SENSOR_ARM_LENGTH
    adc_bits: int = C.ADC_BITS
    adc_range_v: float = C.ADC_RANGE_V
    headroom: float = C.ADC_HEADROOM
    bridge_excitation_v: float = C.BRIDGE_EXCITATION_V
    gauge_factor: float = C.GAUGE_FACTOR
    full_scale_strain: float = C.FULL_SCALE_STRAIN
    bridge_resistance: float = C.BRIDGE_RESISTANCE
    amplifier_noise_density: float = C.AMPLIFIER_NOISE_DENSITY
    amplifier_bandwidth_hz: float = C.AMPLIFIER_BANDWIDTH_HZ
    calibration_error: float = C.CALIBRATION_ERROR
    calibration_seed: int = C.CALIBRATION_SEED

    @property
    def full_scale(self) -> np.ndarray:
        return np.array([self.force_range] * 3 + [self.torque_range] * 3)

    @property
    def calibration(self) -> np.ndarray:
        """S (8 x 6): strain volts = S @ wrench (N, N m), the nominal (beam-model) matrix."""
        raw = maltese_cross_matrix(self.arm_length)
        worst = np.max(np.abs(raw) @ self.full_scale)
        return raw * (self.headroom * self.adc_range_v / worst)

    @property
    def true_calibration(self) -> np.ndarray:
        """The strain pattern the physical sensor really has: the nominal S plus an error of
        ``calibration_error`` times its column's largest entry per entry (gain errors and
        cross-talk of ~1 % of each wrench component's reading; one fixed draw,
        ``calibration_seed``)."""
        s = self.calibration
        if self.calibration_error <= 0.0:
            return s
        rng = np.random.default_rng(self.calibration_seed)
        return s + self.calibration_error * np.abs(s).max(axis=0) * rng.standard_normal(s.shape)

    @property
    def inverse_calibration(self) -> np.ndarray:
        """6 x 8 least-squares inverse of the nominal calibration: wrench = S^+ @ strain."""
        return np.linalg.pinv(self.calibration)

    @property
    def condition_number(self) -> float:
        """Condition number of S with columns scaled by the full-scale load."""
        return float(np.linalg.cond(self.calibration * self.full_scale))

    @property
    def lsb_v(self) -> float:
        return 2.0 * self.adc_range_v / 2**self.adc_bits

    @property
    def bridge_full_scale_v(self) -> float:
        """Half-bridge output at full-scale strain, V (two active gauges)."""
        return self.bridge_excitation_v * self.gauge_factor * self.full_scale_strain / 2.0

    @property
    def amplifier_gain(self) -> float:
        return self.headroom * self.adc_range_v / self.bridge_full_scale_v

    @property
    def noise_v(self) -> float:
        """Rms amplifier + bridge noise at the converter input, V."""
        johnson = 4.0 * C.BOLTZMANN * C.ROOM_TEMPERATURE_K * self.bridge_resistance
        density = np.sqrt(self.amplifier_noise_density**2 + johnson)
        return float(density * np.sqrt(np.pi / 2.0 * self.amplifier_bandwidth_hz) * self.amplifier_gain)

    @property
    def noise_lsb(self) -> float:
        """:attr:`noise_v` in converter steps."""
        return self.noise_v / self.lsb_v

    @property
    def wrench_noise_std(self) -> np.ndarray:
        """Standard deviation of each wrench component due to noise + quantisation (N, N m)."""
        var_v = self.noise_v**2 + self.lsb_v**2 / 12.0
        pinv = self.inverse_calibration
        return np.sqrt(var_v * np.sum(pinv**2, axis=1))

    def measure(self, wrench: np.ndarray, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
        """Strains (n, 8, volts, quantised) and the wrench computed from them (n, 6)."""
        s = wrench @ self.true_calibration.T
        s = s + rng.normal(0.0, self.noise_v, s.shape)
        lsb = self.lsb_v
        half = 2 ** (self.adc_bits - 1)
        codes = np.clip(np.round(s / lsb), -half, half - 1)
        strain = codes * lsb
        return strain, strain @ self.inverse_calibration.T


@dataclass(frozen=True)
class Encoders:
    """PHANToM position encoders and the velocity estimate."""

    resolution: float = C.ENCODER_RESOLUTION
    velocity_lowpass_hz: float = C.VELOCITY_LOWPASS_HZ
    servo_velocity_lowpass_hz: float = C.SERVO_VELOCITY_LOWPASS_HZ
    kinematic_angle_error_deg: float = C.KINEMATIC_ANGLE_ERROR_DEG
    kinematic_curvature: float = C.KINEMATIC_CURVATURE
    kinematic_seed: int = C.CALIBRATION_SEED

    def kinematic_error(self) -> tuple[np.ndarray, np.ndarray]:
        """``(A, Q)``: the reported position of a true position p is p + A p + 0.5 Q(p, p)
        (``Q[i, j, k]`` symmetric in j, k), one fixed draw (``kinematic_seed``): the PHANToM's
        kinematic calibration error (constants.KINEMATIC_ANGLE_ERROR_DEG, KINEMATIC_CURVATURE)."""
        rng = np.random.default_rng([self.kinematic_seed, 1])
        a = rng.standard_normal((3, 3)) * np.radians(self.kinematic_angle_error_deg)
        q = rng.standard_normal((3, 3, 3)) * self.kinematic_curvature
        q = 0.5 * (q + q.transpose(0, 2, 1))
        q *= np.sqrt(2.0)   # keep the off-diagonal std after symmetrising
        for i in range(3):
            q[i][np.diag_indices(3)] /= np.sqrt(2.0)
        return a, q

    def reported_position(self, p: np.ndarray) -> np.ndarray:
        """What the PHANToM's kinematics report for true positions ``p`` (n, 3), unquantised."""
        a, q = self.kinematic_error()
        p = np.asarray(p, float)
        return p + p @ a.T + 0.5 * np.einsum("ijk,nj,nk->ni", q, p, p)

    def velocity_filter(self, rate_hz: float, cutoff_hz: float | None = None) -> tuple[np.ndarray, np.ndarray]:
        """(b, a) of the 2nd-order Butterworth lowpass applied to the differenced position at
        ``rate_hz`` (cutoff ``velocity_lowpass_hz`` unless given).  The servo loop runs the same
        estimator at the servo rate with ``servo_velocity_lowpass_hz``
        (:func:`contactlab.sim.dynamics.integrate`)."""
        return signal.butter(2, self.velocity_lowpass_hz if cutoff_hz is None else cutoff_hz, fs=rate_hz)

    def measure(self, robot_position: np.ndarray, rate_hz: float) -> tuple[np.ndarray, np.ndarray]:
        """Quantised reported position (n, 3) (:meth:`reported_position`) and lowpassed
        first-difference velocity (n, 3)."""
        pos = np.round(self.reported_position(robot_position) / self.resolution) * self.resolution
        diff = np.diff(pos, axis=0, prepend=pos[:1]) * rate_hz
        b, a = self.velocity_filter(rate_hz)
        zi = signal.lfilter_zi(b, a)[:, None] * diff[:1]
        vel, _ = signal.lfilter(b, a, diff, axis=0, zi=zi)
        return pos, vel
