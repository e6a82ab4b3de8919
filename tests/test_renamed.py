"""``fit`` means scikit-learn's (estimate, return self); former result-returning names warn."""

from __future__ import annotations

import numpy as np
import pytest

from contactlab.constraints import CartesianConstraint
from contactlab.constraints.degree import AlignmentDegreeTest
from contactlab.estimators import estimate_ar
from contactlab.estimators import models


def test_former_names_warn_and_give_the_same_result():
    rng = np.random.default_rng(0)
    x = np.column_stack([rng.uniform(0, 0.01, 40), rng.uniform(0, 0.01, 40), np.zeros(40)])
    w = np.column_stack([np.zeros(40), np.zeros(40), 1.0 + 0.01 * rng.normal(size=40)])
    est = CartesianConstraint()
    with pytest.warns(DeprecationWarning, match="CartesianConstraint.fit is now estimate"):
        old = est.fit(x, w)
    assert old.degree_ == est.estimate(x, w).degree_
    y = rng.normal(size=(300, 2))
    with pytest.warns(DeprecationWarning, match="fit_ar is now estimate_ar"):
        np.testing.assert_array_equal(models.fit_ar(y).coef, estimate_ar(y).coef)


def test_fit_returns_self():
    stats = np.random.default_rng(1).normal(size=(40, 2))
    test = AlignmentDegreeTest()
    assert test.fit(stats, np.arange(40) % 2) is test
