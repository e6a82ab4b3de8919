"""The synthetic suite's generators hold the truth they claim (contactlab.synthetic)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.signal import lfilter

from contactlab.archive import open_archive
from contactlab.synthetic import (ar2_coefficients, ar2_variance, contact_trial, piecewise_ar,
                                  texture_trial, write_archive)


def test_ar2_variance_closed_form_against_simulation():
    a1, a2 = ar2_coefficients(40.0, 0.95, 1000.0)
    e = np.random.default_rng(0).standard_normal(400000)
    y = lfilter([1.0], [1.0, -a1, -a2], e)[2000:]
    assert np.var(y) == pytest.approx(float(ar2_variance(a1, a2)), rel=0.05)


def test_piecewise_changes_are_of_their_kind():
    t = piecewise_ar(seed=3, duration_s=30.0, segment_s=(4.0, 6.0))
    edges = np.r_[0, t.boundaries, len(t.y)]
    sd = np.array([t.y[a + 200:b].std(axis=0) for a, b in zip(edges[:-1], edges[1:])])
    for j, kind in enumerate(t.kinds):
        ratio = sd[j + 1] / sd[j]
        want = t.sd[j + 1] / t.sd[j]
        assert np.allclose(ratio, want, rtol=0.35)           # the marginal level as drawn
        moved = not np.allclose(t.freq_hz[j + 1], t.freq_hz[j])
        assert moved == (kind != "variance")
        if kind == "coefficients":
            assert np.allclose(t.sd[j + 1], t.sd[j])         # level held


def test_archives_carry_the_truth(tmp_path):
    t = piecewise_ar(seed=4)
    tex = texture_trial(seed=5, duration_s=4.0)
    write_archive([t], tmp_path / "p.h5")
    write_archive([tex], tmp_path / "t.h5")
    with open_archive(tmp_path / "p.h5") as a:
        trial = a.trial(a.select(None)[0])
        assert np.allclose(trial.segments["start_s"].to_numpy()[1:], t.boundaries_s)
        assert np.array_equal(np.asarray(trial.strain), t.y)
    with open_archive(tmp_path / "t.h5") as a:
        trial = a.trial(a.select(None)[0])
        assert trial.segments["end_s"].to_numpy()[-1] == pytest.approx(len(tex.y) / tex.fs)


def test_contact_moves_only_freely_and_pushes_only_along_normals():
    for degree in (1, 2):
        t = contact_trial(seed=6, degree=degree, position_sd=0.0, force_sd=0.0,
                          friction=(0.0, 0.0))
        N = t.normals
        free = np.linalg.svd(N, full_matrices=True)[0][:, degree:]
        x = t.position - t.position.mean(axis=0)
        assert np.abs(x @ N).max() < 1e-12                     # no motion along a normal
        assert np.abs(t.force @ free).max() < 1e-12           # no force along a free direction
        assert (np.linalg.norm(t.force @ N, axis=1) > 0.1).all()


def test_compliant_drifting_contact_matches_its_closed_forms():
    # compliance: the noise-free position along the normal is -g/k (a line of slope -1/k
    # against the normal force); drift: the frame turns by drift_deg from first to last
    import numpy as np
    from contactlab.synthetic import contact_trial

    tr = contact_trial(seed=3, degree=1, stiffness=2000.0, press_n=(0.2, 2.0),
                       friction=(0.0, 0.0), position_sd=1e-9, force_sd=1e-9)
    n = tr.normals[:, 0]
    slope = np.polyfit(tr.force @ n, tr.position @ n, 1)[0]
    assert abs(slope * 2000.0 + 1.0) < 1e-3
    dr = contact_trial(seed=3, degree=2, drift_deg=5.0)
    a, b = dr.normals_at(0), dr.normals_at(len(dr.position) - 1)
    ang = np.degrees(np.arccos(np.clip(np.linalg.svd(a.T @ b, compute_uv=False).min(), -1, 1)))
    assert ang <= 5.0 + 1e-6 and np.allclose(dr.frames[0] @ dr.frames[0].T, np.eye(3))
    default = contact_trial(seed=3, degree=2)
    assert default.frames is None
