"""The feature models follow scikit-learn's convention: the constructor stores the
settings, ``fit(segments)`` learns the parameters and returns the model, a model
without its parameters refuses to score, and a fitted model round-trips through the
models file."""

from __future__ import annotations

import h5py
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from contactlab.observer.kinematics import read_kinematic_models, write_kinematic_models
from contactlab.observer.models import (ConstraintFeature, FixedVelocity, ImpactFeature,
                                        MovingVelocity)
from contactlab.observer.models.gaussian import RIDGE, GaussianFeature


def _plane(rng, n, tilt_deg):
    """Samples (position, force) sliding on a plane whose normal is z tilted about x."""
    R = Rotation.from_euler("x", tilt_deg, degrees=True).as_matrix()
    t = np.linspace(0, 1, n)
    along = np.stack([0.02 * np.sin(3 * t), 0.01 * t, np.zeros(n)], axis=1)
    pos = along @ R.T + rng.normal(0, 1e-5, (n, 3))
    force = np.outer(-5 + rng.normal(0, 0.2, n), R[:, 2]) + rng.normal(0, 0.01, (n, 3))
    return np.concatenate([pos, force], axis=1)


@pytest.mark.parametrize("model", [FixedVelocity(name="F"), MovingVelocity(name="M"),
                                   GaussianFeature(name="G"), ImpactFeature(name="I"),
                                   ConstraintFeature(name="C", degree=1)])
def test_a_model_without_its_parameters_refuses_to_score(model):
    with pytest.raises(ValueError, match="call fit"):
        model.run(model.init_state(np.zeros(1, np.int64), 3), np.zeros((4, 3)), t0=0,
                  starts=np.zeros(1, np.int64))


def test_fit_returns_the_model_with_closed_form_parameters():
    rng = np.random.default_rng(3)
    still = [rng.normal(0, 0.002, (400, 3)), rng.normal(0, 0.004, (100, 3))]
    F = FixedVelocity(name="F")
    assert F.fit(still) is F
    pooled = np.concatenate(still)
    assert F.sigma == pytest.approx(np.sqrt(np.mean(pooled ** 2)), rel=1e-12)
    assert (F.n_samples_, F.n_segments_) == (500, 2)

    x = rng.normal(size=(300, 2)) @ np.array([[1.0, 0.4], [0.0, 0.5]]) + [3.0, -1.0]
    G = GaussianFeature(name="G", signal="x").fit([x[:100], x[100:]])
    cov = np.cov(x, rowvar=False)
    np.testing.assert_allclose(G.mean, x.mean(axis=0), rtol=1e-12)
    np.testing.assert_allclose(G.cov, cov + np.diag(RIDGE * np.diag(cov) + 1e-12), rtol=1e-12)
    # the fitted model scores like scipy's normal
    from scipy.stats import multivariate_normal

    ll, _ = G.score(x[:5])
    np.testing.assert_allclose(ll, multivariate_normal(G.mean, G.cov).logpdf(x[:5]), rtol=1e-10)


def test_refitting_learns_the_same_from_the_same_data_and_a_given_frame_stays():
    rng = np.random.default_rng(5)
    segs = [_plane(rng, 300, 12.0) for _ in range(3)]
    C = ConstraintFeature(name="c", degree=1, position_sd=1e-5, force_sd=0.01)
    first = C.fit(segs).normals.copy(), C.V.copy()
    C.fit(segs)
    np.testing.assert_array_equal(C.normals, first[0])
    np.testing.assert_array_equal(C.V, first[1])
    true = Rotation.from_euler("x", 12.0, degrees=True).as_matrix()[:, 2]
    assert abs(abs(C.normals[:, 0] @ true) - 1) < 1e-3
    z = np.array([[0.0], [0.0], [1.0]])
    fixed = ConstraintFeature(name="z", normals=z, position_sd=1e-5, force_sd=0.01).fit(segs)
    np.testing.assert_array_equal(fixed.normals, z)
    assert fixed.frame_given and not C.frame_given
    with pytest.raises(ValueError, match="degree 2 but 1 normals"):
        ConstraintFeature(name="bad", normals=z, degree=2)
    with pytest.raises(ValueError, match="give the normals, or the degree"):
        ConstraintFeature(name="bad")


def test_fitted_models_round_trip_through_the_models_file(tmp_path):
    rng = np.random.default_rng(9)
    models = {"constraint": {"contact": ConstraintFeature(
                  name="contact", degree=1, position_sd=1e-5, force_sd=0.01).fit(
                  [_plane(rng, 200, 20.0) for _ in range(2)])},
              "velocity": {"F": FixedVelocity(name="F").fit([rng.normal(0, 1e-3, (50, 3))]),
                           "M": MovingVelocity(name="M").fit([rng.uniform(-0.02, 0.02, (90, 3))])},
              "gaussian": {"G": GaussianFeature(name="G").fit([rng.normal(size=(40, 3))])}}
    path = tmp_path / "m.h5"
    with h5py.File(path, "w") as h5:
        write_kinematic_models(h5, models)
    with h5py.File(path, "r") as h5:
        back = read_kinematic_models(h5, path)
    c0, c1 = models["constraint"]["contact"], back["constraint"]["contact"]
    np.testing.assert_array_equal(c1.normals, c0.normals)
    np.testing.assert_array_equal(c1.V, c0.V)
    for k in ("F", "M"):
        assert back["velocity"][k].params() == models["velocity"][k].params()
    np.testing.assert_array_equal(back["gaussian"]["G"].cov, models["gaussian"]["G"].cov)
    x = np.concatenate([_plane(rng, 20, 20.0)])
    s0, s1 = (m.init_state(np.zeros(1, np.int64), 6) for m in (c0, c1))
    np.testing.assert_array_equal(c0.run(s0, x, t0=0, starts=np.zeros(1))[0],
                                  c1.run(s1, x, t0=0, starts=np.zeros(1))[0])


def test_an_impact_prior_needs_three_segments():
    rng = np.random.default_rng(1)
    segs = [4.0 - 0.05 * np.arange(60) + rng.normal(0, 0.1, 60) for _ in range(2)]
    with pytest.raises(ValueError, match="at least 3 segments"):
        ImpactFeature(name="I").fit(segs)
    with pytest.raises(ValueError, match="together"):
        ImpactFeature(name="I", theta_mean=[1.0, 0.0])
