"""The maze experiment's scoring helpers: features missed in order, and which node pairs the
stand-in measurements cannot tell apart (node numbers: p fixed, P + p moving, 2P + p an
impact into p)."""

from __future__ import annotations

from contactlab.experiments.maze import _in_order, _look_alike, _missed


def test_missed_features_are_those_outside_the_longest_common_subsequence():
    truth = ["ch", "tail", "ch", "leg", "corner"]
    assert _missed(truth, truth) == []
    assert _missed(truth, ["tail", "ch", "leg", "corner"]) == ["ch #1"]
    assert _missed(truth, ["ch", "leg", "ch", "leg", "corner"]) == ["tail #2"]
    assert _missed(truth, []) == [f"{f} #{k + 1}" for k, f in enumerate(truth)]
    assert _in_order(truth, ["corner", "ch", "leg"]) == 2


def test_an_impact_looks_like_the_moving_node_it_enters_and_nothing_else():
    P = 74
    assert _look_alike(P, 2 * P + 10, P + 10)        # impact into 10, moving on 10
    assert not _look_alike(P, 2 * P + 10, 10)        # ... not fixed on 10
    assert not _look_alike(P, P + 10, 2 * P + 29)    # moving on 10, impact into 29
    assert not _look_alike(P, 25, 2 * P + 60)        # fixed in 25, impact into 60
    assert _look_alike(P, 29, 29) and not _look_alike(P, 29, P + 29)
