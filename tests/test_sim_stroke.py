"""The stroking experiment of thesis 7.2 on the simulator: the phases that follow from physics."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import signal

from contactlab.sim import Apparatus, StrokeController, plane, sample_a, sample_b, simulate
from contactlab.sim import constants as C
from contactlab.sim.materials import MATERIALS, get_material

R = C.FINGERTIP_RADIUS


def _preprocessed_energy(strain, rate_hz):
    # 7.1: strains lowpassed by a 2nd-order 125 Hz filter and decimated 4:1 (y_l); the
    # textures are labelled on this signal (7.2).  Energy of its first difference, summed
    # over the 8 gauges, one value per 250 Hz sample.
    b, a = signal.butter(2, 125.0, fs=rate_hz)
    y = signal.lfilter(b, a, strain, axis=0)[::4]
    return np.sum(np.diff(y, axis=0) ** 2, axis=1)


@pytest.mark.parametrize("make", [sample_a, sample_b])
def test_stroke_shows_the_physical_phases_of_fig_7_5(make):
    env = make()
    ctrl = StrokeController()
    r = simulate(environment=env, controller=ctrl, duration_s=7.0, seed=1)
    t = r.time
    start, stop = ctrl.command_start_s, ctrl.command_start_s + ctrl.command_s
    rough = r.materials.index(env.planes[0].material)
    smooth = r.materials.index(env.planes[0].material_b)
    # 1 resting on the plate: in contact, not moving, on the first texture
    rest = t < start
    assert r.contact[rest, 0].all() and not r.moving[rest].any() and (r.texture[rest] == rough).all()
    # 2-3 the command starts, friction holds the finger while the strain builds up
    x0 = r.fingertip_position[int(start * r.rate_hz), 0]
    i_slide = int(np.flatnonzero((t > start) & (r.fingertip_position[:, 0] - x0 > 1e-4))[0])
    assert t[i_slide] - start > 0.1                      # a stick phase of more than 100 ms
    assert r.desired_position[i_slide, 0] - r.robot_position[i_slide, 0] > 1e-4  # robot lags: strained
    mu_k = get_material(env.planes[0].material).mu_kinetic
    assert abs(r.wrench_true[i_slide - 1, 0]) > 0.5 * mu_k * ctrl.normal_force
    # 4-5 steady sliding over both textures: contact kept, labels never drop, no impacts
    # (the finger may catch briefly on the rough wood of sample B, as in 9.1.2)
    slide = (t > t[i_slide] + 0.2) & (t < stop - 0.2)
    assert r.contact[slide, 0].all() and r.moving[slide].mean() > 0.9
    assert np.isin(r.texture[slide], [rough, smooth]).all()
    assert not r.impact[slide].any() and len(r.impact_intervals) == 0
    # the rough texture vibrates more than the smooth one at the same speeds (the stroke's
    # speed profile is symmetric about its middle, where the boundary is)
    e = _preprocessed_energy(r.strain, r.rate_hz)
    te = t[::4][1:]
    on_rough = (te > 1.5) & (te < 2.8)
    on_smooth = (te > 3.3) & (te < 4.6)
    assert (r.texture[::4][1:][on_rough] == rough).all() and (r.texture[::4][1:][on_smooth] == smooth).all()
    # (x1.5: with a dithered 16-bit converter the smooth side's floor is the drive's own
    # vibration; the 12-bit converter of earlier versions left it below one step, ~18x)
    assert e[on_rough].mean() > 1.5 * e[on_smooth].mean()
    # 6-7 the command freezes the robot: the strain drops, and the finger rests again
    end = t > stop + 0.5
    assert r.contact[end, 0].all() and not r.moving[end].any()
    # what is left is what the drive's static friction and the force DAC's constant error
    # (half a step) can hold against the loaded sensor
    held = Apparatus().robot_static_friction + 0.5 * C.FORCE_RESOLUTION
    assert abs(r.wrench_true[end, 0].mean()) < min(held + 0.005, 0.8 * abs(r.wrench_true[slide, 0].mean()))


@pytest.mark.parametrize("material", sorted(MATERIALS))
def test_stroke_at_200_mN_keeps_contact_on_every_material(material):
    # 7.2 / 9.1.1: the finger rides on the asperity tops (materials module docstring); at
    # the 200 mN of the stroking experiment it never leaves the surface, before, during
    # or after the stroke, and makes no impacts.
    r = simulate(environment=plane(material=material), controller=StrokeController(), duration_s=7.0,
                 seed=3, start=(0.0, 0.0, R + 20e-6))
    assert r.contact[:, 0].all()
    assert (r.texture == 0).all()
    assert len(r.impact_intervals) == 0 and not r.impact.any()
    assert r.slipping[1500:5000, 0].mean() > 0.95
