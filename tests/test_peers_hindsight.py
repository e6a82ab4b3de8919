"""The hindsight change points: where a signal's mean changes near each labelled transition."""

import numpy as np
import pytest

from contactlab.observer.recognize import detection_delays
from contactlab.peers.hindsight import hindsight_path

NAMES = ["rest", "moving"]


def _steps(changes, levels, n, seed=0, sd=0.2):
    """A piecewise-constant signal with the given change samples and levels, plus noise."""
    y = np.empty(n)
    edges = [0, *changes, n]
    for k in range(len(edges) - 1):
        y[edges[k]:edges[k + 1]] = levels[k]
    return y + sd * np.random.default_rng(seed).standard_normal(n)


def test_finds_the_signals_change_not_the_labels():
    # the signal changes at 300 and 700; the labels say 340 and 650
    y = _steps([300, 700], [0.0, 2.0, 0.0], 1000)
    truth = np.zeros(1000, np.int64)
    truth[340:650] = 1
    path = hindsight_path(y, truth, NAMES)
    assert [n for n, _ in path] == ["rest", "moving", "rest"]
    assert abs(path[1][1] - 300) <= 3 and abs(path[2][1] - 700) <= 3
    # scored like an observer's path: within 50 samples of the labels, both missed
    d = detection_delays(truth, path, NAMES, window=30)
    assert d["transitions"] == 2 and d["missed"] == 2
    assert sorted(d["missed_at"]) == [340, 650]
    d = detection_delays(truth, path, NAMES, window=60)
    assert d["missed"] == 0 and d["missed_at"] == []
    assert sorted(d["delays"]) == sorted([path[1][1] - 340, path[2][1] - 650])


def test_matches_the_least_squares_split_computed_directly():
    rng = np.random.default_rng(3)
    y = np.r_[rng.normal(0.0, 1.0, 220), rng.normal(1.5, 1.0, 180)]
    truth = np.r_[np.zeros(200, np.int64), np.ones(200, np.int64)]
    cp = hindsight_path(y, truth, NAMES)[1][1]
    # the exact two-segment split between the midpoints to the trial's ends (100, 300)
    w = y[100:300]
    sse = [np.var(w[:j]) * j + np.var(w[j:]) * (200 - j) for j in range(2, 199)]
    assert cp == 100 + 2 + int(np.argmin(sse))


def test_unlabelled_samples_and_short_runs():
    y = _steps([200], [0.0, 3.0], 600)
    truth = np.full(600, -1, np.int64)
    truth[50:200], truth[200:600] = 0, 1
    truth[400:405] = 0                       # a 5-sample flicker, merged with min_run
    path = hindsight_path(y, truth, NAMES, min_run=10)
    assert len(path) == 2 and abs(path[1][1] - 200) <= 3
    assert hindsight_path(y, np.full(600, -1), NAMES) == []
    with pytest.raises(ValueError, match="samples"):
        hindsight_path(y[:10], truth, NAMES)


def test_a_decoded_state_sequence_scores_like_an_observers_path():
    from contactlab.peers.hmm import state_path

    s = np.array([0, 0, 1, 1, 1, 0, 0])
    assert state_path(s, NAMES) == [("rest", 0), ("moving", 2), ("rest", 5)]
    assert state_path(np.zeros(0, np.int64), NAMES) == []
    truth = np.array([0, 0, 0, 1, 1, 1, 0])
    d = detection_delays(truth, state_path(s, NAMES), NAMES, window=2)
    assert d["missed"] == 0 and sorted(d["delays"]) == [-1, -1]
