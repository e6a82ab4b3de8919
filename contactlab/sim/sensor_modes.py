"""The force sensor's mechanical mode that the simulator's constants imply (3.3).

Used to explain the ringing of an impact (the impact-spectrogram and
impact-envelope experiments): fixed base as in the thesis's 3.3, and free
base (a fingertip in flight), where the robot and the shell move against each
other through the sensor's stiffness.
"""

from __future__ import annotations

import math

from contactlab.sim import constants as C

__all__ = ["mode_prediction"]


def mode_prediction(apparatus=None) -> dict:
    """The sensor mode the simulator's constants imply, fixed base and free base.

    Fixed base (thesis 3.3: the shell on a fixed base): ``w^2 = K/m_s``, decay
    ``B/(2 m_s)``.  Free base (a fingertip in flight: the sensor's base m_r and shell
    m_s joined by K, B; the 1 kHz servo and the backdrive friction are far below
    this mode): relative motion with the reduced mass ``mu = m_s m_r/(m_s+m_r)``,
    ``w^2 = K/mu``, decay ``B/(2 mu)``.  ``f_damped_hz`` is ``sqrt(w^2 - s^2)/2pi``.
    The sensor's base is the arm behind the capstan cables (the rotors hang on the cables,
    whose ~380 Hz mode lies below these frequencies), the whole robot for rigid cables, or the
    link's tip with the arm's link mode (its bending spring is soft at these frequencies).
    """
    from contactlab.sim import Apparatus

    app = apparatus or Apparatus()
    K, B, ms = app.sensor_stiffness, app.sensor_damping, app.shell_mass
    mr = app.base_mass
    out = {}
    for name, m in (("fixed_base", ms), ("free_base", ms * mr / (ms + mr))):
        w, s = math.sqrt(K / m), B / (2 * m)
        out[name] = {"f_hz": w / (2 * math.pi), "f_damped_hz": math.sqrt(w * w - s * s) / (2 * math.pi),
                     "zeta": s / w, "decay_per_s": s}
    out["robot_on_sensor_hz"] = math.sqrt(K / mr) / (2 * math.pi)
    out["constants"] = {"SHELL_MODE_HZ": C.SHELL_MODE_HZ, "SHELL_DAMPING_RATIO": C.SHELL_DAMPING_RATIO,
                        "SHELL_MASS": ms, "ROBOT_MASS": mr}
    return out
