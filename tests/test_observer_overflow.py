"""The compiled core's overflow-and-resume path, forced.

:func:`~contactlab.observer.engine.run_core` stops with ``FULL`` at an event that could
overflow one of its preallocated arrays (paths, instances, segments, the event tables,
the log-likelihood history's slots); :meth:`~contactlab.observer.engine.Core.ensure_room`
grows them and the core resumes with the event.  With the default capacities that
happens only on busy runs, by chance.  Here every array of the core starts with room
for one row (the history with the initial paths' slots) and every growth is to exactly
what the pending event needs, so most events stop the core, and the results must be
those of the default capacities to the bit.
"""

from __future__ import annotations

import numpy as np
import pytest

from contactlab.observer import Observer, engine, observe
from contactlab.observer.engine import Core
from tests.conftest import assert_same_observer_results
from tests.test_observer_core import _held_impact, ar_models, graph, simulate

#: four AR processes (with the all-to-all graph: four successors per alarm)
PARAMS4 = {"A": (0.0, 0.5, 1.0), "B": (3.0, 0.5, 1.0), "C": (0.0, 0.5, 6.0),
           "D": (-3.0, 0.3, 2.0)}


def tiny_capacities(monkeypatch) -> list:
    """Make every :class:`Core` start with one row per array and grow to exactly what is
    needed; return the list that records each ``ensure_room`` call (core, sample, paths
    held to their transient node's longest duration at that sample)."""
    def first_alloc_of_one(name, attr):
        orig = getattr(Core, name)

        def alloc(self, *sizes):
            if getattr(self, attr, None) is None:          # the constructor's allocation
                sizes = (1,) * len(sizes)
            orig(self, *sizes)
        monkeypatch.setattr(Core, name, alloc)

    first_alloc_of_one("_alloc_paths", "paths_")
    first_alloc_of_one("_alloc_units", "units_")
    first_alloc_of_one("_alloc_segs", "segs_")
    first_alloc_of_one("_alloc_events", "ev")
    monkeypatch.setattr(engine, "_cap", lambda need, have: max(need, have))

    calls = []
    ensure_room = Core.ensure_room

    def counted(self, hist):
        t = self._t_event
        # one growth must be enough: the core never stops twice at one sample (a second
        # stop would repeat forever)
        assert (id(self), t) not in {(c, s) for c, s, _ in calls}, f"stopped twice at {t}"
        nP = int(self.cnt[engine.C_P])
        tmax = self.cfg.max_duration[self.paths_["node"][:nP]]
        held = int(((tmax > 0) & (t - self.paths_["start"][:nP] >= tmax)).sum())
        calls.append((id(self), t, held))
        ensure_room(self, hist)
    monkeypatch.setattr(Core, "ensure_room", counted)
    return calls


def assert_identical(tiny, default) -> None:
    """Events, paths, path log-likelihoods, MAP path, labels and node probabilities, all
    to the bit."""
    assert_same_observer_results(tiny, default)
    np.testing.assert_array_equal(tiny.node_prob, default.node_prob)
    np.testing.assert_array_equal(tiny.labels, default.labels)
    assert [p.probability for p in tiny.paths] == [p.probability for p in default.paths]


def switching_ar(n=8000, seed=21):
    """A segment of a random one of the four processes every 100-250 samples."""
    rng = np.random.default_rng(seed)
    truth, s, prev = [], 0, None
    while s < n:
        k = rng.choice([c for c in "ABCD" if c != prev])
        truth.append((str(k), s))
        prev = k
        s += int(rng.integers(100, 250))
    return simulate(truth, n, seed, PARAMS4)


@pytest.mark.parametrize("p_prune", [0.99, 0.9999])
def test_tiny_capacities_give_the_default_results_on_a_switching_ar_stream(monkeypatch,
                                                                             p_prune):
    y = switching_ar()
    g = graph(list("ABCD"))

    def run():
        obs = Observer(g, ar_models(PARAMS4), sides="both", p_prune=p_prune)
        res = observe(obs, y, chunk=257)
        assert obs._core is not None                    # the compiled core ran
        return obs, res

    _, default = run()
    calls = tiny_capacities(monkeypatch)
    obs, tiny = run()
    assert_identical(tiny, default)
    assert sum(1 for e in default.events if e.model is not None) >= 60
    assert len(calls) >= 50                             # the core stopped for room
    assert {c for c, _, _ in calls} == {id(obs._core)}


def test_tiny_capacities_give_the_default_results_with_a_transient_node(monkeypatch):
    """A transient node held to its longest duration: some of the core's stops are at a
    sample where a path reaches that limit (an alarm with no detector crossed, which
    ``ensure_room`` counts with the crossed tests)."""
    y, g, models, _ = _held_impact(1)
    y = np.tile(y, 4)                                   # four impacts, contact to rest
    default = observe(Observer(g, models, transient_max=60), y, chunk=257)
    calls = tiny_capacities(monkeypatch)
    tiny = observe(Observer(g, models, transient_max=60), y, chunk=257)
    assert_identical(tiny, default)
    assert any(e.model == "I" for e in default.events)
    assert len(calls) >= 50
    assert any(held for _, _, held in calls)            # stops sized for a held path
