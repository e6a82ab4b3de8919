"""Signal conditioning of section 7.1 against scipy and closed-form expectations."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import signal

from contactlab.conditioning import (Conditioned, DEFAULT_LOG_FLOOR, LogEnergy, LowpassDecimator,
                                     StrainConditioner, VelocityEstimator, condition_strains,
                                     difference, log_energy, lowpass_decimate, lowpass_delay,
                                     velocity_from_position)

FS = 1000.0
# E[log|Z|] for Z ~ N(0, 1) is -(euler_gamma + log 2) / 2
E_LOG_ABS_NORMAL = -(np.euler_gamma + np.log(2.0)) / 2.0


def _sos():
    # the oracle: the thesis's filter written out independently
    return signal.butter(2, 125.0, btype="low", fs=FS, output="sos")


@pytest.fixture
def strains():
    rng = np.random.default_rng(11)
    # 8 channels with large offsets, a slow drift and white noise
    n = 4003
    drift = np.cumsum(rng.normal(size=(n, 8)), axis=0) * 0.1
    return 500.0 * np.arange(1, 9) + drift + rng.normal(size=(n, 8))


def test_lowpass_zero_initial_matches_butter_sosfilt_every_4th(strains):
    got = lowpass_decimate(strains, initial="zero")
    want = signal.sosfilt(_sos(), strains, axis=0)[::4]
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-12)


def test_lowpass_steady_initial_matches_sosfilt_with_steady_state(strains):
    sos = _sos()
    zi = signal.sosfilt_zi(sos)[:, :, None] * strains[0][None, None, :]
    want = signal.sosfilt(sos, strains, axis=0, zi=zi)[0][::4]
    got = lowpass_decimate(strains)
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-12)
    # and the steady start really removes the start-up transient of the offsets
    zero = lowpass_decimate(strains, initial="zero")
    assert np.max(np.abs(got[0] - strains[0])) < 1e-9
    assert np.max(np.abs(zero[0] - strains[0])) > 100


def test_lowpass_delay_is_butterworth_dc_group_delay():
    # 2nd-order Butterworth: DC delay sqrt(2)/wc with the prewarped
    # wc = 2 fs tan(pi/8) (the bilinear map keeps the DC delay); in samples
    # sqrt(2) / (2 (sqrt(2) - 1)) = 1 + 1/sqrt(2)
    assert lowpass_delay() == pytest.approx(1.0 + 1.0 / np.sqrt(2.0), abs=1e-6)


def test_difference_matches_numpy_and_prepend():
    rng = np.random.default_rng(1)
    y = rng.normal(size=(50, 3))
    np.testing.assert_array_equal(difference(y), np.diff(y, axis=0))
    np.testing.assert_array_equal(difference(y[:, 0]), np.diff(y[:, 0]))
    prev = rng.normal(size=3)
    np.testing.assert_array_equal(difference(y, prepend=prev),
                                  np.diff(np.vstack([prev, y]), axis=0))


def test_log_energy_blocks_of_8_every_4_against_a_naive_loop():
    rng = np.random.default_rng(2)
    x = rng.normal(size=(203, 2))
    got = log_energy(x)
    want = np.array([np.log(np.abs(x[4 * k:4 * k + 8])).mean(axis=0)
                     for k in range((203 - 8) // 4 + 1)])
    assert got.shape == want.shape == (49, 2)
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-12)
    assert log_energy(x[:7]).shape == (0, 2)


def test_log_energy_floor_guards_exact_zeros():
    x = np.zeros(16)
    np.testing.assert_allclose(log_energy(x), np.log(DEFAULT_LOG_FLOOR))
    x[::2] = 3.0                         # quantised data: half the differences are 0
    got = log_energy(x, floor=0.5)       # half an LSB of 1
    np.testing.assert_allclose(got, 0.5 * (np.log(3.0) + np.log(0.5)))
    with pytest.raises(ValueError, match="floor"):
        log_energy(x, floor=0.0)


def test_log_energy_of_white_noise_sits_at_log_sigma_minus_0635():
    rng = np.random.default_rng(3)
    sigma = np.array([0.01, 1.0, 30.0])
    x = rng.normal(size=(200_000, 3)) * sigma
    hf = log_energy(x)
    assert E_LOG_ABS_NORMAL == pytest.approx(-0.6352, abs=1e-4)
    np.testing.assert_allclose(hf.mean(axis=0), np.log(sigma) + E_LOG_ABS_NORMAL, atol=0.02)
    # through the whole pipeline: y_d of white noise sigma has std sigma*sqrt(2)
    cond = condition_strains(x)
    np.testing.assert_allclose(cond.hf.mean(axis=0),
                               np.log(sigma * np.sqrt(2.0)) + E_LOG_ABS_NORMAL, atol=0.02)


def test_690hz_shell_mode_attenuated_in_low_but_present_in_hf():
    # At fs = 1000 Hz a 690 Hz vibration aliases to 310 Hz, still far above 125 Hz.
    rng = np.random.default_rng(4)
    n = np.arange(20_000)
    amp, noise = 1.0, 0.01
    sine = amp * np.sin(2 * np.pi * 690.0 * n / FS + 0.3)
    quiet = noise * rng.normal(size=n.size)
    with_sine = condition_strains(sine + quiet)
    without = condition_strains(quiet)
    # y_l: amplitude = |H(310 Hz)| * amp, from scipy's frequency response
    _, h = signal.sosfreqz(_sos(), worN=[310.0], fs=FS)
    gain = abs(h[0])
    assert gain < 0.1
    rms = np.sqrt(np.mean(with_sine.low[50:] ** 2))
    assert rms == pytest.approx(gain * amp / np.sqrt(2), rel=0.05)
    # y_h: y_d = 2 amp sin(pi f/fs) cos(.), and E[log|cos U|] = -log 2
    want = np.log(2 * amp * np.sin(np.pi * 690.0 / FS)) - np.log(2.0)
    assert with_sine.hf.mean() == pytest.approx(want, abs=0.1)
    assert with_sine.hf.mean() - without.hf.mean() > 4.0


def _chunks(n, rng):
    cuts = np.sort(rng.choice(np.arange(1, n), size=12, replace=False))
    cuts = np.concatenate([[0, 0], cuts, [cuts[-1], n]])      # includes an empty chunk
    return list(zip(cuts[:-1], cuts[1:]))


def test_streaming_chunks_equal_batch_exactly(strains):
    rng = np.random.default_rng(5)
    batch = condition_strains(strains)
    conditioner = StrainConditioner()
    parts = [conditioner.update(strains[a:b]) for a, b in _chunks(len(strains), rng)]
    for field in ("low", "hf", "low_index", "hf_index"):
        joined = np.concatenate([getattr(p, field) for p in parts])
        np.testing.assert_array_equal(joined, getattr(batch, field), err_msg=field)
    # one sample at a time, too
    conditioner.reset()
    ones = [conditioner.update(strains[i:i + 1]) for i in range(200)]
    np.testing.assert_array_equal(np.concatenate([p.low for p in ones]),
                                  condition_strains(strains[:200]).low)
    np.testing.assert_array_equal(np.concatenate([p.hf for p in ones]),
                                  condition_strains(strains[:200]).hf)


def test_streaming_stages_with_odd_blocks_and_factors():
    rng = np.random.default_rng(6)
    x = rng.normal(size=(500, 2))
    for block, factor in [(8, 4), (5, 3), (2, 7), (1, 1)]:
        whole = log_energy(x, block=block, factor=factor)
        stage = LogEnergy(block=block, factor=factor)
        parts = [stage.update(x[a:b]) for a, b in _chunks(len(x), rng)]
        np.testing.assert_array_equal(np.concatenate(parts), whole)
        want = np.array([np.log(np.abs(x[factor * k:factor * k + block])).mean(axis=0)
                         for k in range((500 - block) // factor + 1)])
        np.testing.assert_allclose(whole, want, atol=1e-12)
    lp = LowpassDecimator(factor=3)
    parts = [lp.update(x[a:b]) for a, b in _chunks(len(x), rng)]
    np.testing.assert_array_equal(np.concatenate(parts), lowpass_decimate(x, factor=3))


def test_output_indices_and_times(strains):
    c = condition_strains(strains)
    assert isinstance(c, Conditioned) and c.fs_out == 250.0
    np.testing.assert_array_equal(c.low_index, 4 * np.arange(len(c.low)))
    np.testing.assert_array_equal(c.hf_index, 4 * np.arange(len(c.hf)) + 8)
    # hf[k] is the mean of log|y(n) - y(n-1)| over n = hf_index[k]-7 ... hf_index[k]
    for k in (0, 1, 17, len(c.hf) - 1):
        n1 = c.hf_index[k]
        block = np.log(np.abs(strains[n1 - 7:n1 + 1] - strains[n1 - 8:n1]))
        np.testing.assert_allclose(c.hf[k], block.mean(axis=0), atol=1e-12)
    # low[k] is the filter output at input sample low_index[k]
    zi = signal.sosfilt_zi(_sos())[:, :, None] * strains[0][None, None, :]
    full = signal.sosfilt(_sos(), strains, axis=0, zi=zi)[0]
    np.testing.assert_allclose(c.low, full[c.low_index], atol=1e-12)
    assert c.hf_delay == 3.5 and c.low_delay == pytest.approx(1.7071, abs=1e-4)
    np.testing.assert_allclose(c.low_times(t0=2.0), 2.0 + c.low_index / 1000.0)
    # one channel in, one channel out
    single = condition_strains(strains[:, 3])
    np.testing.assert_array_equal(single.low, c.low[:, 3])
    np.testing.assert_array_equal(single.hf, c.hf[:, 3])


def test_velocity_from_position_matches_difference_then_butterworth():
    rng = np.random.default_rng(7)
    t = np.arange(3000) / FS
    pos = np.stack([0.05 * np.sin(2 * np.pi * 1.5 * t), 0.2 * t], axis=1)
    pos += 1e-6 * rng.normal(size=pos.shape)
    got = velocity_from_position(pos)
    vd = FS * np.diff(pos, axis=0, prepend=pos[:1])
    want = signal.sosfilt(_sos(), vd, axis=0)[::4]
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-9)
    # the constant-velocity channel settles at 0.2 m/s
    assert np.abs(got[20:, 1] - 0.2).max() < 0.02
    # streaming
    est = VelocityEstimator()
    parts = [est.update(pos[a:b]) for a, b in _chunks(len(pos), rng)]
    np.testing.assert_array_equal(np.concatenate(parts), got)


def test_bad_parameters_are_named():
    with pytest.raises(ValueError, match="cutoff_hz"):
        lowpass_decimate(np.zeros(10), cutoff_hz=600.0)
    with pytest.raises(ValueError, match="initial"):
        lowpass_decimate(np.zeros(10), initial="warm")
    with pytest.raises(ValueError, match="block"):
        log_energy(np.zeros(10), block=0)
    with pytest.raises(ValueError, match="time first"):
        condition_strains(np.zeros((3, 3, 3)))


def test_quantisation_floor_is_half_the_converter_step():
    from contactlab.conditioning import quantisation_floor

    rng = np.random.default_rng(3)
    lsb = 10.0 / 4096
    y = np.round(rng.normal(0, 3 * lsb, size=(5000, 2)) / lsb) * lsb     # 12-bit codes
    assert quantisation_floor(y) == pytest.approx(lsb / 2, rel=1e-9)
    assert quantisation_floor(np.ones((10, 3))) == 1e-12                # constant: fallback
