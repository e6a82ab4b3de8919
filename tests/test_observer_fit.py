"""How well a recognised path's models fit the data (contactlab.observer.fit) against
closed forms: the chi-square per degree of freedom of a fixed-velocity model is the mean
squared velocity over its variance."""

import numpy as np
import pytest
from scipy import stats

from contactlab.observer.fit import MISFIT, path_fit
from contactlab.observer.graph import parse_graph
from contactlab.observer.models.velocity import FixedVelocity, MovingVelocity

GRAPH = {"name": "still-moving", "edges": ["still -> moving", "moving -> still"],
         "models": {"F": {"kind": "velocity-fixed", "trained": "still", "signal": "velocity"},
                    "M": {"kind": "velocity-moving", "trained": "moving", "low": -0.01,
                          "high": 0.01, "signal": "velocity"}},
         "nodes": [{"name": "still", "models": {"velocity": "F"}, "initial": 1.0},
                   {"name": "moving", "models": {"velocity": "M"}}]}


def _models(sigma):
    return {"F": FixedVelocity(sigma=sigma), "M": MovingVelocity(low=-0.01, high=0.01,
                                                                  sigma=sigma)}


def test_fixed_model_fit_is_the_mean_square_over_its_variance():
    graph = parse_graph(GRAPH)
    rng = np.random.default_rng(3)
    sigma = 1e-3
    v = rng.normal(0.0, sigma, (2000, 3))
    fit = path_fit(graph, _models(sigma), {"velocity": v}, [("still", 0)])
    assert fit.by_model_mean["F"] == pytest.approx(np.mean(v ** 2) / sigma ** 2, rel=1e-12)
    # the robust level: the median chi-square(3) over the distribution's median (scipy)
    chi = np.sum(v ** 2, axis=1) / sigma ** 2
    assert fit.by_model["F"] == pytest.approx(np.median(chi) / stats.chi2(3).median(),
                                              rel=1e-12)
    # 2000 chi-square(3) values: the median's ratio is 1 within a few percent
    assert abs(fit.overall - 1.0) < 0.1 and not fit.misfit
    # three times the trained noise: nine times the chi-square, a misfit
    fit3 = path_fit(graph, _models(sigma), {"velocity": 3 * v}, [("still", 0)])
    assert fit3.overall == pytest.approx(9 * fit.overall, rel=1e-12)
    assert fit3.overall > MISFIT and fit3.misfit and fit3.worst == "F"


def test_each_segment_is_scored_by_its_node_models_only():
    graph = parse_graph(GRAPH)
    rng = np.random.default_rng(4)
    sigma = 1e-3
    still = rng.normal(0.0, sigma, (500, 3))
    moving = rng.uniform(-0.008, 0.008, (700, 3))     # far above F's noise
    v = np.r_[still, moving]
    right = path_fit(graph, _models(sigma), {"velocity": v}, [("still", 0), ("moving", 500)])
    assert right.samples == 1200
    assert right.by_model_mean["F"] == pytest.approx(np.mean(still ** 2) / sigma ** 2,
                                                     rel=1e-12)
    assert not right.misfit
    # the moving samples labelled still: F sees them, a misfit
    wrong = path_fit(graph, _models(sigma), {"velocity": v}, [("still", 0)])
    assert set(wrong.by_model) == {"F"} and wrong.misfit
    assert wrong.to_dict()["misfit"] is True and wrong.to_dict()["worst_model"] == "F"


def test_a_few_wild_samples_are_no_misfit_but_a_noisier_recording_is():
    # a recording's glitches (a position jump: one velocity of 10^4 sigma) move the mean
    # chi-square per degree of freedom past the warning level; the robust level stays at 1
    graph = parse_graph(GRAPH)
    rng = np.random.default_rng(5)
    sigma = 1e-3
    v = rng.normal(0.0, sigma, (2000, 3))
    v[[100, 900, 1500]] = 10.0
    fit = path_fit(graph, _models(sigma), {"velocity": v}, [("still", 0)])
    assert fit.by_model_mean["F"] > 100 * MISFIT
    assert abs(fit.overall - 1.0) < 0.1 and not fit.misfit
    noisy = path_fit(graph, _models(sigma), {"velocity": 4 * v}, [("still", 0)])
    assert noisy.misfit and noisy.overall == pytest.approx(16 * fit.overall, rel=1e-12)


def test_one_model_far_off_is_a_misfit_though_the_path_overall_is_not():
    # the path's other models fit; one node's model is 5x too narrow for its segment
    graph = parse_graph(GRAPH)
    rng = np.random.default_rng(6)
    sigma = 1e-3
    still = rng.normal(0.0, 5 * sigma, (300, 3))          # 25x F's chi-square
    moving = rng.uniform(-0.01, 0.01, (3000, 3))           # M fits
    fit = path_fit(graph, _models(sigma), {"velocity": np.r_[still, moving]},
                   [("still", 0), ("moving", 300)])
    assert fit.overall < MISFIT < fit.by_model["F"]
    assert fit.misfit and fit.worst == "F"


@pytest.mark.parametrize("which", ["F", "M"])
def test_the_chi_square_alone_is_the_one_the_observer_scores(which):
    """``chi2`` (what the fit reads) against the closed form and against ``run``'s second
    output, the chi-square beside each sample's log-likelihood."""
    rng = np.random.default_rng(5)
    sigma = 1e-3
    m = _models(sigma)[which]
    x = rng.uniform(-0.012, 0.012, (300, 3))
    if which == "F":
        closed = np.sum(x ** 2, axis=1) / sigma ** 2
    else:                       # the uniform band (-0.01, 0.01) plus the noise: 2nd moment
        closed = np.sum(x ** 2, axis=1) / (0.02 ** 2 / 12 + sigma ** 2)
    np.testing.assert_allclose(m.chi2(x), closed, rtol=1e-12)
    ll, chi = m.run({}, x, t0=0, starts=np.array([0]))
    np.testing.assert_array_equal(m.chi2(x), chi[:, 0])
    assert np.all(np.isfinite(ll))
