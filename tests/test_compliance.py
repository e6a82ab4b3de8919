"""A compliant contact's penetration and a turning frame, estimated with the frame."""

from __future__ import annotations

import numpy as np
import pytest

from contactlab.constraints import CartesianConstraint, angular_error_deg
from contactlab.constraints.compliance import CompliantConstraint, fit_compliance
from contactlab.synthetic.contacts import contact_trial


def _plane(c: float, *, n: int = 2000, seed: int = 0, noise_m: float = 1e-5):
    """A plane z = 0 in a turned frame: sliding in x, y; pressing 0.5-2 N that changes
    with the slide (so a rigid fit tilts); the pad sinking by c * force."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) / 1000.0
    R = np.linalg.qr(rng.standard_normal((3, 3)))[0]
    N, T = R[:, :1], R[:, 1:]
    s = np.column_stack([4e-3 * np.sin(2 * np.pi * 0.7 * t),
                         3e-3 * np.sin(2 * np.pi * 1.1 * t + 1)])
    g = 1.25 + 0.5 * s[:, 0] / 4e-3 + 0.2 * np.sin(2 * np.pi * 0.4 * t)
    force = g[:, None] * N.T + rng.normal(0, 0.01, (n, 3))
    position = s @ T.T - c * g[:, None] * N.T + rng.normal(0, noise_m, (n, 3))
    return position, force, N, T


def test_compliance_recovers_the_pads_compliance():
    """c of a 2000 N/m pad (5e-4 m/N) within 4 sd and within 5 %, about the true frame
    and about the rigid fit's."""
    position, force, N, T = _plane(5e-4)
    c = fit_compliance(position, force, N, T, force_sd=0.01)
    assert c.sd < 2.5e-5
    assert abs(c.c - 5e-4) < max(4 * c.sd, 1e-6) and abs(c.c - 5e-4) < 0.05 * 5e-4
    rigid = CartesianConstraint(degree=1, position_sd=1e-5, force_sd=0.01).estimate(position,
                                                                                    force)
    c2 = fit_compliance(position, force, rigid.normals_, rigid.free_, force_sd=0.01)
    # without the noise's correction the force's noise shrinks c
    assert fit_compliance(position, force, N, T).c < c.c - 2 * c.sd
    assert abs(c2.c - 5e-4) < 0.1 * 5e-4


def test_a_rigid_contact_has_no_compliance():
    position, force, N, T = _plane(0.0, seed=3)
    c = fit_compliance(position, force, N, T, force_sd=0.01)
    assert abs(c.c) < 4 * c.sd and c.sd < 2e-5
    assert not c.turning()


def test_fit_compliance_refuses_what_it_cannot_fit():
    position, force, N, T = _plane(5e-4)
    assert fit_compliance(position, force, np.zeros((3, 0)), np.eye(3)) is None
    assert fit_compliance(position[:4], force[:4], N, T) is None
    # no motion and a constant force: nothing to tell c from a tilt
    assert fit_compliance(np.zeros((100, 3)), np.ones((100, 3)), N, T) is None


def test_compliant_fit_removes_the_tilt_and_its_sd_covers_the_error():
    """On synthetic compliant planes and edges (0.2-2 N on 2000 N/m), the compliant fit's
    error is a fraction of the rigid fit's, and within 2 of its sd in most runs, where the
    rigid fit's sd covers few."""
    est = CartesianConstraint(position_sd=0.1e-3, force_sd=0.02)
    comp = CompliantConstraint(est)
    rig_err, comp_err, comp_in, rig_in = [], [], [], []
    for seed in range(12):
        tr = contact_trial(seed=seed, degree=1 + seed % 2, stiffness=2000.0, press_n=(0.2, 2.0))
        r = est.estimate(tr.position, tr.force)
        f = comp.estimate(tr.position, tr.force)
        assert f.degree_ == r.degree_                    # the degree is 8.2's, as measured
        np.testing.assert_array_equal(f.log_likelihoods_, r.log_likelihoods_)
        if r.degree_ != tr.degree:
            continue
        assert "compliance_m_per_n" in f.parameters
        assert f.angle_sd_deg_ >= est.estimate(tr.position + f.parameters["compliance_m_per_n"]
                                               * tr.force, tr.force).angle_sd_deg_ - 1e-12
        rig_err.append(angular_error_deg(r.normals_, tr.normals))
        comp_err.append(angular_error_deg(f.normals_, tr.normals))
        rig_in.append(rig_err[-1] <= 2 * r.angle_sd_deg_)
        comp_in.append(comp_err[-1] <= 2 * f.angle_sd_deg_)
    assert len(comp_err) >= 9
    assert np.median(comp_err) < 0.3 * np.median(rig_err)
    assert np.mean(comp_in) >= 0.8 and np.mean(rig_in) <= 0.5


def test_a_turning_frame_is_followed_to_the_block():
    """A plane whose normal turns 3 deg or more over the run: the frame asked for at the
    run's end is turned by about half that from the run's average frame and is nearer
    the end's truth (median error less than half); a still plane is not turned."""
    est = CartesianConstraint(position_sd=0.1e-3, force_sd=0.02)
    comp = CompliantConstraint(est)
    tested, errs = 0, []
    for seed in range(8):
        tr = contact_trial(seed=seed, degree=1, drift_deg=6.0)
        end = tr.normals_at(len(tr.position) - 1)
        turned = angular_error_deg(tr.normals_at(0), end)
        if turned < 3.0:
            continue                      # turning mostly about the normal
        tested += 1
        avg = comp.estimate(tr.position, tr.force)
        at_end = comp.estimate(tr.position, tr.force, at=1.0)
        assert "turn_deg" in at_end.parameters and "turn_deg" not in avg.parameters
        assert at_end.parameters["turn_deg"] == pytest.approx(turned / 2, abs=0.3 * turned)
        assert at_end.angle_sd_deg_ > avg.angle_sd_deg_
        errs.append((angular_error_deg(avg.normals_, end), angular_error_deg(at_end.normals_, end)))
        assert np.linalg.norm(at_end.normals_) == pytest.approx(1.0)
    assert tested >= 3
    avg_err, end_err = np.array(errs).T
    assert np.median(end_err) < 0.5 * np.median(avg_err)
    still = contact_trial(seed=7, degree=1)
    assert "turn_deg" not in comp.estimate(still.position, still.force, at=1.0).parameters


def test_estimate_reports_compliance_and_covers_disturbed_blocks(tmp_path):
    """``estimate --block 25`` on contacts with compliance, friction and a creeping frame:
    2 sd covers at least 85 % of plane and edge blocks' errors (the rigid form: fewer),
    and each row carries the compliance."""
    from contactlab.constraints.archive import estimate_archive
    from contactlab.synthetic import contact_trials, write_archive

    path = tmp_path / "d.h5"
    write_archive(contact_trials(2, seed=31, stiffness=2000.0, press_n=(0.2, 2.0),
                                 friction=(0.0, 0.3), drift_deg=2.0), path)
    cover = {}
    for compliance in (True, False):
        out = estimate_archive(str(path), block=25, write=False, compliance=compliance)
        rows = [r for t in out["trials"].values() for r in t["segments"]
                if r.get("angle_error_deg") is not None and r.get("true_degree") in (1, 2)]
        assert len(rows) > 60
        err = np.array([r["angle_error_deg"] for r in rows])
        sd = np.array([r["angle_sd_deg"] for r in rows])
        cover[compliance] = float(np.mean(err <= 2 * sd))
        assert all(("compliance_m_per_n" in r) == compliance for r in rows)
    assert cover[True] >= 0.85 and cover[True] > cover[False] + 0.1


def test_a_turn_is_followed_only_over_enough_samples_and_within_its_linear_range():
    """No turn from fewer than TURN_MIN_SAMPLES samples, nor one larger than TURN_MAX_DEG
    (a plane turning 30 deg in a run: half of it would be 15 deg at the end)."""
    from contactlab.constraints.compliance import TURN_MAX_DEG, TURN_MIN_SAMPLES

    comp = CompliantConstraint(CartesianConstraint(position_sd=0.1e-3, force_sd=0.02))
    for seed in (0, 2, 5):
        tr = contact_trial(seed=seed, degree=1, drift_deg=6.0)
        assert "turn_deg" in comp.estimate(tr.position, tr.force, at=1.0).parameters
        short = comp.estimate(tr.position[:TURN_MIN_SAMPLES - 1], tr.force[:TURN_MIN_SAMPLES - 1],
                              at=1.0)
        assert "turn_deg" not in short.parameters
        big = contact_trial(seed=seed, degree=1, drift_deg=30.0)
        fit = comp.estimate(big.position, big.force, at=1.0)
        assert fit.parameters.get("turn_deg", 0.0) <= TURN_MAX_DEG
