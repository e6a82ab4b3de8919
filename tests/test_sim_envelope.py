"""The sphere's envelope over a lay of ridges and the micro-impacts it makes (thesis 7.1-7.2, 4.40)."""

from __future__ import annotations

import numpy as np

from contactlab.conditioning import condition_strains
from contactlab.sim import StrainGaugeSensor, StrokeController, sample_a, simulate
from contactlab.sim import constants as C
from contactlab.sim.materials import get_material, shared_load_envelope, sphere_dilation, texture_modes

R = C.FINGERTIP_RADIUS


def test_sphere_dilation_is_the_exact_upper_envelope():
    rng = np.random.default_rng(0)
    du = 2e-6
    f = np.cumsum(rng.normal(0.0, 0.3e-6, 1500))
    u = np.arange(len(f)) * du
    brute = np.max(f[None, :] - (u[:, None] - u[None, :]) ** 2 / (2 * R), axis=1)
    np.testing.assert_allclose(sphere_dilation(f, du, R), brute, rtol=0, atol=1e-15)


def test_load_sharing_only_rounds_the_hand_overs():
    # a scratch-like profile: random sinusoids of 60 um - 1 mm, 2.4 um rms (smooth below the
    # ~30 um Hertz patch, as the textures are)
    rng = np.random.default_rng(1)
    du = 1e-6
    u = np.arange(0.0, 0.02, du)
    lam = np.exp(rng.uniform(np.log(60e-6), np.log(1e-3), 24))
    amp = lam**0.8 * 2.4e-6 / np.sqrt(0.5 * np.sum(lam**1.6))
    f = np.sum(amp * np.sin(np.outer(u, 2 * np.pi / lam) + rng.uniform(0.0, 2 * np.pi, 24)), axis=1)
    rigid = sphere_dilation(f, du, R)
    k_h = get_material("sanded_aluminium_80").hertz_constant(R)
    shared = shared_load_envelope(f, rigid, du, R, k_h, C.NOMINAL_NORMAL_LOAD)
    d0 = (C.NOMINAL_NORMAL_LOAD / k_h) ** (2 / 3)
    lift = shared - rigid
    # two crests carrying the load deflect less than one: the centre sits at most d0 higher
    assert lift.min() > -1e-12 and lift.max() <= d0 + 1e-12
    # ... and only near the cusps: most of the envelope is a single-crest arc
    assert np.mean(lift > 1e-12) < 0.1 and lift.max() > 0.2 * d0


def test_crosswise_scratches_are_ridden_as_an_envelope_and_polished_is_not():
    sanded = texture_modes(get_material("sanded_aluminium_80"), seed=0)
    polished = texture_modes(get_material("polished_aluminium"), seed=0)
    assert np.ptp(sanded["e_tab"]) > 2e-6 and np.all(polished["e_tab"] == 0.0)


def test_sanded_aluminium_vibrates_above_polished_and_rest_in_y_h():
    # 7.1-7.2: the log-energy y_h of the strain difference separates the textures of sample A
    env = sample_a()
    r = simulate(environment=env, controller=StrokeController(), duration_s=7.0, seed=2)
    lsb = StrainGaugeSensor().lsb_v
    c = condition_strains(r.strain, fs=r.rate_hz, log_floor=lsb / 2)
    hf = c.hf.mean(axis=1)
    idx = np.clip(np.asarray(c.hf_index), 0, len(r) - 1)
    sanded, polished = r.materials.index("sanded_aluminium_80"), r.materials.index("polished_aluminium")
    rest = hf[~r.moving[idx] & r.contact[idx, 0]].mean()
    on_sanded = hf[r.moving[idx] & (r.texture[idx] == sanded)].mean()
    on_polished = hf[r.moving[idx] & (r.texture[idx] == polished)].mean()
    assert on_sanded > on_polished + 0.1 and on_polished > rest
