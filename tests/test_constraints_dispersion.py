"""The between-block spread of constraint frames (DerSimonian-Laird for tilt vectors) and
the widened standard errors of ``estimate --block`` on contacts the rigid form does not
model."""

from __future__ import annotations

import numpy as np
import pytest

from contactlab.constraints.dispersion import between_block_variance


def _draw(rng, K, tau, s):
    """Angles (deg) of K blocks' 2-d tilts from their pooled (fixed-effect) mean: each
    block's frame is tilted by N(0, tau^2 I) and estimated with noise N(0, s_b^2 I)."""
    est = rng.normal(0.0, tau, (K, 2)) + rng.normal(0.0, 1.0, (K, 2)) * s[:, None]
    w = 1.0 / s ** 2
    pooled = (w[:, None] * est).sum(axis=0) / w.sum()
    return np.linalg.norm(est - pooled, axis=1)


@pytest.mark.parametrize("tau", [0.5, 1.0, 2.0])
def test_the_spread_between_blocks_is_recovered_on_average(tau):
    rng = np.random.default_rng(11)
    s = rng.uniform(0.3, 1.0, 40)
    est = [between_block_variance(_draw(rng, 40, tau, s), s) for _ in range(400)]
    assert np.mean(est) == pytest.approx(tau ** 2, rel=0.1)


def test_no_spread_beyond_the_noise_gives_next_to_nothing():
    rng = np.random.default_rng(12)
    s = rng.uniform(0.3, 1.0, 40)
    est = np.array([between_block_variance(_draw(rng, 40, 0.0, s), s) for _ in range(400)])
    assert np.mean(est == 0.0) > 0.4            # Q below its expectation about half the time
    assert np.mean(est) < 0.05 * np.mean(s ** 2)


def test_degenerate_inputs():
    assert between_block_variance([1.0], [0.5]) == 0.0
    assert between_block_variance([1.0, np.nan, 2.0], [0.5, 0.5, 0.0]) == 0.0
    # two blocks 2 deg apart from their mean with sd 0.1: tau^2 = (Q - 2) / (2 c)
    w = 1 / 0.01
    q, c = 2 * w * 4.0, 2 * w - 2 * w * w / (2 * w)
    assert between_block_variance([2.0, 2.0], [0.1, 0.1]) == pytest.approx((q - 2) / (2 * c))
    with pytest.raises(ValueError, match="differ in length"):
        between_block_variance([1.0, 2.0], [0.1])


def test_estimate_blocks_widen_their_sd_on_a_compliant_contact(tmp_path):
    """On synthetic contacts with a compliant surface, pressing 0.2-2 N, fitted by the
    rigid form, the widened sd of the sequential blocks covers the error far more often
    than the noise-only sd, and is never below it."""
    from contactlab.constraints.archive import estimate_archive
    from contactlab.synthetic import contact_trials, write_archive

    path = tmp_path / "c.h5"
    write_archive(contact_trials(4, seed=21, stiffness=2000.0, press_n=(0.2, 2.0)), path)
    out = estimate_archive(str(path), block=25, write=False, compliance=False)
    rows = [r for t in out["trials"].values() for r in t["segments"]
            if r.get("angle_error_deg") is not None and "angle_sd_noise_deg" in r]
    assert len(rows) > 40
    err = np.array([r["angle_error_deg"] for r in rows])
    wide = np.array([r["angle_sd_deg"] for r in rows])
    noise = np.array([r["angle_sd_noise_deg"] for r in rows])
    assert np.all(wide >= noise)
    assert np.mean(err <= 2 * wide) > np.mean(err <= 2 * noise) + 0.2
    for e in out["summary"]["per_true_degree"].values():     # the summary reports both
        if "angle_within_2sd_noise_only" in e:
            assert e["angle_within_2sd"] >= e["angle_within_2sd_noise_only"]
