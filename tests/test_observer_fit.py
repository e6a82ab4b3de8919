"""How well a recognised path's models fit the data (contactlab.observer.fit) against
closed forms: the chi-square per degree of freedom of a fixed-velocity model is the mean
squared velocity over its variance."""

import numpy as np
import pytest

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
    assert fit.by_model["F"] == pytest.approx(np.mean(v ** 2) / sigma ** 2, rel=1e-12)
    # 6000 chi-square(1) terms: mean 1, sd sqrt(2 / 6000)
    assert abs(fit.overall - 1.0) < 4 * np.sqrt(2 / 6000) and not fit.misfit
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
    assert right.by_model["F"] == pytest.approx(np.mean(still ** 2) / sigma ** 2, rel=1e-12)
    assert not right.misfit
    # the moving samples labelled still: F sees them, a misfit
    wrong = path_fit(graph, _models(sigma), {"velocity": v}, [("still", 0)])
    assert set(wrong.by_model) == {"F"} and wrong.misfit
    assert wrong.to_dict()["misfit"] is True and wrong.to_dict()["worst_model"] == "F"
