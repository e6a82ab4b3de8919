"""Simulated hardware from a spec's ``[apparatus]`` table.

A dataset spec may describe other hardware than the thesis's (a 12-bit board, a quieter
amplifier, an ideal drive) in an ``[apparatus]`` table; each key sets one parameter of
:class:`~contactlab.sim.dynamics.Apparatus`, :class:`~contactlab.sim.sensor.StrainGaugeSensor`
or :class:`~contactlab.sim.sensor.Encoders` (defaults and sources in
:mod:`contactlab.sim.constants`)::

    [apparatus]
    adc_bits = 12                      # the converter (default 16)
    amplifier_noise_nv_per_rthz = 10   # bridge amplifier input noise density
    commutation_ripple = false         # the motors' commutation torque ripple
    cable_stiffness_n_per_m = 40000    # the rotors ring on the capstan cables (default 0: rigid)
    link_stiffness_n_per_m = 22000     # the link mode (default 0: a rigid link)

:func:`check_apparatus` returns a one-line message per bad value (the spec loader names the
file and the field); :func:`build_hardware` makes the three objects.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

from contactlab.sim import constants as C
from contactlab.sim.dynamics import Apparatus
from contactlab.sim.sensor import Encoders, StrainGaugeSensor


@dataclass(frozen=True)
class Field:
    """One ``[apparatus]`` key: which object and attribute it sets, its unit scale and range."""

    target: str            # "apparatus", "sensor" or "encoders"
    attribute: str
    kind: type = float
    scale: float = 1.0     # spec value x scale = attribute value
    low: float = 0.0
    high: float = math.inf
    low_open: bool = False
    doc: str = ""


FIELDS: dict[str, Field] = {
    "adc_bits": Field("sensor", "adc_bits", int, 1.0, 8, 24, doc="converter bits"),
    "adc_range_v": Field("sensor", "adc_range_v", float, 1.0, 0.0, 100.0, True,
                         "converter input range +-V"),
    "bridge_excitation_v": Field("sensor", "bridge_excitation_v", float, 1.0, 0.0, 30.0, True,
                                 "bridge excitation, V"),
    "gauge_factor": Field("sensor", "gauge_factor", float, 1.0, 0.0, 200.0, True,
                          "strain-gauge factor (2 for foil, ~100 for semiconductor)"),
    "full_scale_strain": Field("sensor", "full_scale_strain", float, 1.0, 0.0, 0.01, True,
                               "strain at the full-scale wrench"),
    "amplifier_noise_nv_per_rthz": Field("sensor", "amplifier_noise_density", float, 1e-9, 0.0,
                                         1e4, doc="amplifier input noise, nV/sqrt(Hz)"),
    "amplifier_bandwidth_hz": Field("sensor", "amplifier_bandwidth_hz", float, 1.0, 0.0, 1e6, True,
                                    "amplifier bandwidth, Hz"),
    "calibration_error": Field("sensor", "calibration_error", float, 1.0, 0.0, 0.5,
                               doc="calibration-matrix error per entry, fraction of its column"),
    "encoder_resolution_m": Field("encoders", "resolution", float, 1.0, 0.0, 0.01,
                                  doc="encoder step at the tip, m (0: exact)"),
    "kinematic_angle_error_deg": Field("encoders", "kinematic_angle_error_deg", float, 1.0, 0.0,
                                       30.0, doc="linear kinematic error, deg"),
    "kinematic_curvature_per_m": Field("encoders", "kinematic_curvature", float, 1.0, 0.0, 100.0,
                                       doc="nonlinear kinematic error, 1/m"),
    "robot_friction_n": Field("apparatus", "robot_friction", float, 1.0, 0.0, 5.0,
                              doc="kinetic backdrive friction, N"),
    "robot_static_friction_n": Field("apparatus", "robot_static_friction", float, 1.0, 0.0, 5.0,
                                     doc="static backdrive friction, N"),
    "brush_friction_variation": Field("apparatus", "brush_friction_variation", float, 1.0, 0.0,
                                      1.0, doc="relative rms ripple of the kinetic friction"),
    "control_error_n": Field("apparatus", "control_error_std", float, 1.0, 0.0, 1.0,
                             doc="random (amplifier) control force per servo tick, N rms"),
    "force_resolution_n": Field("apparatus", "force_resolution", float, 1.0, 0.0, 1.0,
                                doc="force DAC step at the tip, N (0: exact)"),
    "robot_presliding_m": Field("apparatus", "robot_presliding", float, 1.0, 0.0, 1e-3,
                                doc="pre-sliding displacement of the drive friction, m (0: rigid stick)"),
    "cable_stiffness_n_per_m": Field("apparatus", "cable_stiffness", float, 1.0, 0.0, 1e8,
                                     doc="capstan cables' stiffness at the tip, N/m (0: rigid cables)"),
    "rotor_mass_kg": Field("apparatus", "rotor_mass", float, 1.0, 0.0, 0.5 * C.ROBOT_MASS, True,
                           "the motors' rotors reflected to the tip, kg"),
    "cable_damping_ratio": Field("apparatus", "cable_damping_ratio", float, 1.0, 0.0, 1.0,
                                 doc="damping of the cable mode, ratio of critical"),
    "link_stiffness_n_per_m": Field("apparatus", "link_stiffness", float, 1.0, 0.0, 1e8,
                                    doc="bending stiffness of the link at the tip, N/m (0: rigid drive)"),
    "link_tip_mass_kg": Field("apparatus", "link_tip_mass", float, 1.0, 0.0, 0.9 * C.ROBOT_MASS, True,
                              "mass of the link's tip carrying the sensor, kg (below the robot mass)"),
    "link_damping_ratio": Field("apparatus", "link_damping_ratio", float, 1.0, 0.0, 1.0,
                                doc="damping of the link mode, ratio of critical"),
    "commutation_ripple": Field("apparatus", "commutation_events", bool,
                                doc="motors' commutation torque ripple on/off"),
}


def check_apparatus(table: dict) -> tuple[str, str] | None:
    """``(key, message)`` for the first bad entry of an ``[apparatus]`` table, else None."""
    for key, value in table.items():
        f = FIELDS.get(key)
        if f is None:
            return key, f"unknown key (allowed: {', '.join(sorted(FIELDS))})"
        if f.kind is bool:
            if not isinstance(value, bool):
                return key, f"must be true or false, not {value!r}"
            continue
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            return key, f"must be a number, not {value!r}"
        if f.kind is int and not isinstance(value, int):
            return key, f"must be an integer, not {value!r}"
        too_low = value <= f.low if f.low_open else value < f.low
        if too_low or value > f.high:
            lo = "(" if f.low_open else "["
            return key, f"must be in {lo}{f.low:g}, {f.high:g}] ({f.doc}), not {value!r}"
    if table.get("robot_static_friction_n", C.ROBOT_BACKDRIVE_STATIC_FRICTION) < \
            table.get("robot_friction_n", C.ROBOT_BACKDRIVE_FRICTION):
        return "robot_static_friction_n", "must be at least robot_friction_n (static >= kinetic)"
    rotor = table.get("rotor_mass_kg", C.ROTOR_MASS)
    tip = table.get("link_tip_mass_kg", C.LINK_TIP_MASS)
    if table.get("link_stiffness_n_per_m", 0.0) > 0.0 and table.get("cable_stiffness_n_per_m", 0.0) > 0.0 \
            and rotor + tip > 0.9 * C.ROBOT_MASS:
        return "link_tip_mass_kg", (f"with rotor_mass_kg the robot leaves no arm between cables and link "
                                    f"(rotor + tip {rotor + tip:g} > {0.9 * C.ROBOT_MASS:g} kg)")
    return None


def build_hardware(table: dict | None = None) -> tuple[Apparatus, StrainGaugeSensor, Encoders]:
    """The apparatus, sensor and encoders an ``[apparatus]`` table describes (defaults for the
    keys it leaves out).  Raises ValueError on a bad table (:func:`check_apparatus`)."""
    table = dict(table or {})
    bad = check_apparatus(table)
    if bad is not None:
        raise ValueError(f"[apparatus] {bad[0]}: {bad[1]}")
    objs = {"apparatus": Apparatus(), "sensor": StrainGaugeSensor(), "encoders": Encoders()}
    for key, value in table.items():
        f = FIELDS[key]
        if f.kind is bool:
            value = C.COMMUTATION_EVENTS_PER_REV if value else 0
        elif f.kind is int:
            value = int(value)
        else:
            value = float(value) * f.scale
        objs[f.target] = replace(objs[f.target], **{f.attribute: value})
    return objs["apparatus"], objs["sensor"], objs["encoders"]
