"""Impact ground truth: loss-of-contact impacts (4.52) and bounce trains (4.51)."""

from __future__ import annotations

import numpy as np
import pytest

from contactlab.sim import Apparatus, Encoders, Move, PositionController, block, simulate
from contactlab.sim import constants as C

R = C.FINGERTIP_RADIUS


def _peak_hz(strain, a, rate_hz, n=108):
    seg = np.diff(strain[a:a + n], axis=0)
    spec = np.abs(np.fft.rfft(seg * np.hamming(len(seg))[:, None], 2048, axis=0)) ** 2
    freqs = np.fft.rfftfreq(2048, 1.0 / rate_hz)
    band = (freqs > 200) & (freqs < 1350)
    return freqs[band][np.argmax(spec[band].sum(axis=1))]


def test_releasing_a_loaded_contact_is_an_impact_that_rings():
    # 4.52: the finger is pressed against the block's face (about 0.3 N through the
    # 100 N/m loop) and slid up past its top edge.  The contact vanishes while loaded: the
    # stored sensor-spring energy is released, the shell rings, and the ground truth marks
    # an impact of kind 2 at that sample.
    env = block(floor=False)                     # face y = 15 mm, top edge z = 40 mm
    face_y, top = 0.015, 0.040
    ctrl = PositionController(moves=(Move((0, 0.004, 0), 0.1, 0.0), Move((0, 0, 0.02), 0.6, 0.3)))
    # exact kinematics: the PHANToM's kinematic error (8.1.1.2) bends the slide up the face
    # away from it by a fraction of a millimetre, releasing the contact below the edge
    r = simulate(environment=env, controller=ctrl, duration_s=1.2, seed=3, rate_hz=2700.0,
                 start=(0.0, face_y - R - 0.001, 0.030),
                 encoders=Encoders(kinematic_angle_error_deg=0.0, kinematic_curvature=0.0))
    face = r.surfaces.index("block_face")
    c = r.contact[:, face]
    i = int(np.flatnonzero(np.diff(c.astype(int)) == -1)[-1]) + 1      # the final release
    assert r.fingertip_position[i, 2] == pytest.approx(top, abs=1e-4)   # at the top edge
    assert not r.contact[i:].any()                                      # and free afterwards
    loaded = r.contact_force[i - 20:i - 1, face, 1]
    assert (loaded < -0.2).all()                                        # it carried > 0.2 N
    k = int(np.flatnonzero(r.impact_intervals[:, 0] <= i)[-1])
    a, b = r.impact_intervals[k]
    assert r.impact_kinds[k] == 2 and abs(a - i) <= 1 and b > i + 10
    # the released spring energy rings the free shell: the mode of the shell against the
    # robot mass, f_shell sqrt(1 + m_shell / m_robot)
    after = np.mean(np.diff(r.strain[i:i + 108], axis=0) ** 2)
    before = np.mean(np.diff(r.strain[i - 120:i - 12], axis=0) ** 2)
    assert after > 5.0 * before
    app = Apparatus()
    f_free = app.shell_mode_hz * np.sqrt(1.0 + app.shell_mass / app.robot_mass)
    assert _peak_hz(r.strain, i, r.rate_hz) == pytest.approx(f_free, rel=0.05)
    # the sensor force falls from the load to about the shell's weight within a few ms
    assert abs(r.wrench_true[i - 5, 1]) > 0.2 and abs(r.wrench_true[i + 30:i + 300, 1].mean()) < 0.05


def test_a_guarded_move_onto_a_block_is_one_impact_from_first_bounce_to_decay():
    # 4.51: a guarded move hits the block in a train of bounces; the train is one impact
    # interval (definition: contactlab.sim.simulate._impact_intervals).
    ctrl = PositionController(moves=(Move((0, 0.03, 0), 0.5, 0.05),))
    r = simulate(environment=block(floor=False), controller=ctrl, duration_s=1.0, seed=2, start=(0, 0, 0.02))
    c = r.contact[:, r.surfaces.index("block_face")]
    gains = np.flatnonzero(np.diff(c.astype(int)) == 1) + 1
    assert len(gains) >= 3                                   # it does bounce
    assert len(r.impact_intervals) == 1 and r.impact_kinds[0] == 1
    a, b = r.impact_intervals[0]
    assert abs(a - gains[0]) <= 1                            # starts at the first contact
    assert (gains < b).all()                                 # every bounce is inside it
    max_decay = int(round(C.IMPACT_MAX_DURATION_S * r.rate_hz))
    # (`contact` is point-sampled: a last touch shorter than a sample may come a few samples later)
    assert b <= gains[-1] + max_decay + 10                   # decay after the last bounce is bounded
    assert r.impact[a:b].all() and not r.impact[:a].any() and not r.impact[b:].any()
    assert c[gains[-1]:].all()                               # resting against the face afterwards
    # where the interval ends the ringing has died down well below the impact's
    hf = np.diff(r.strain, axis=0)
    first_ms = np.mean(hf[a:a + 20] ** 2)
    rest = np.mean(hf[-200:] ** 2)
    after = np.mean(hf[b:b + 50] ** 2)
    assert first_ms > 100 * rest and after < first_ms / 20
