"""guarded-move-multi (9.1.2): the three graphs, the surface score, noiseless training runs."""

import numpy as np
import pytest

from contactlab.constraints.cartesian import FORCE_SD, POSITION_SD
from contactlab.experiments.guarded_move_multi import THESIS_SEQUENCE, corner_graph
from contactlab.observer.corner import (CORNER_LABEL_NODES as LABEL_NODES,
                                        CORNER_SURFACES as SURFACE, score_surfaces, surfaces,
                                        truth_nodes)
from contactlab.observer.graph import parse_graph
from contactlab.observer.kinematics import fit_kinematic_models


def test_the_graphs_hold_the_thesis_sequence_and_its_variants():
    g = corner_graph("force")
    names = list(g.node_names)
    assert sorted(names, key=int) == sorted(set(THESIS_SEQUENCE), key=int)
    idx = {n: i for i, n in enumerate(names)}
    edges = g.edges
    # the thesis's sequence is a path of the graph, and so is it with every impact skipped
    for seq in (THESIS_SEQUENCE, [n for n in THESIS_SEQUENCE if n not in ("8", "9", "10")]):
        for a, b in zip(seq[:-1], seq[1:]):
            assert (idx[a], idx[b]) in edges, (a, b)
    assert all(g.nodes[idx[n]].transient for n in ("8", "9", "10"))
    p = corner_graph("position")
    pi = {n: i for i, n in enumerate(p.node_names)}
    # a stuck node per surface: a table stick slips on along the table, a wall stick
    # along the wall
    assert {(pi["3"], pi["6t"]), (pi["6t"], pi["3"]), (pi["6t"], pi["8"]),
            (pi["5"], pi["6"]), (pi["6"], pi["5"])} <= set(p.edges)
    assert not {(pi["6t"], pi["5"]), (pi["6"], pi["3"])} & set(p.edges)
    assert (idx["3"], idx["6"]) not in edges          # sticking is the position graph's
    x = corner_graph("xz")
    assert "7" in x.node_names and x.models["CXZ"].params["constraint"] == "XZ"
    with pytest.raises(ValueError):
        corner_graph("hybrid")


def test_label_map_covers_the_nodes_and_surfaces():
    assert set(LABEL_NODES.values()) <= set(corner_graph("force").node_names)
    assert set(SURFACE) == set(corner_graph("xz").node_names) | set(corner_graph("position").node_names)


def test_surfaces_merge_and_read_sticks():
    assert surfaces(["0", "1", "8", "2", "3", "9", "4", "5", "10", "6"]) == \
        ["free", "table", "wall", "corner"]
    # a stick (6) followed by more table is a stick on the table, not the corner
    assert surfaces(["0", "1", "3", "6", "3", "5", "6"], stick=True) == \
        ["free", "table", "wall", "corner"]
    assert surfaces(["0", "1", "3", "6", "3"], stick=False) == \
        ["free", "table", "corner", "table"]


def test_truth_nodes_drop_chatter():
    names = ["0", "2", "4"]
    codes = np.array([0] * 30 + [1] * 40 + [2] * 20 + [1] * 3 + [2] * 50 + [-1] * 5)
    assert truth_nodes(codes, names) == ["0", "2", "4", "2", "4"]
    assert truth_nodes(codes, names, min_run=12) == ["0", "2", "4"]


def test_score_surfaces():
    t = ["free", "table", "wall"]
    assert score_surfaces(t, t) == {"correct": True, "stuck_ok": True}
    assert score_surfaces(t + ["corner"], t) == {"correct": False, "stuck_ok": True}
    assert score_surfaces(["free", "table", "corner"], t)["stuck_ok"] is False
    assert score_surfaces(t, None)["correct"] is False


def test_noiseless_runs_fall_back_to_the_toolkit_accuracies():
    """Quantised positions smoothed by the lowpass have (near) zero second differences;
    their 'noise' must not normalise the constraint forms."""
    g = parse_graph({"name": "c", "edges": ["a -> b"],
                     "models": {"C0": {"kind": "constraint", "constraint": "0",
                                       "trained": "free"},
                                "CZ": {"kind": "constraint", "constraint": "Z",
                                       "trained": "floor"}},
                     "nodes": [{"name": "a", "models": {"c": "C0"}, "initial": 1.0},
                               {"name": "b", "models": {"c": "CZ"}}]})
    rng = np.random.default_rng(1)
    n = 400
    free = np.zeros((n, 6))
    free[:, :3] = 0.01 + 1e-13 * rng.standard_normal((n, 3))  # still: float jitter only
    floor = np.zeros((n, 6))
    floor[:, 5] = -0.2 + 1e-9 * rng.standard_normal(n)        # force with no real noise
    out = fit_kinematic_models(g, {("contact", "free"): [free], ("contact", "floor"): [floor]})
    for m in out["constraint"].values():
        assert m.position_sd == POSITION_SD and m.force_sd == FORCE_SD
    noisy = floor.copy()
    noisy[:, :3] += 2e-5 * rng.standard_normal((n, 3))
    noisy[:, 3:] += 0.01 * rng.standard_normal((n, 3))
    out = fit_kinematic_models(g, {("contact", "free"): [noisy], ("contact", "floor"): [noisy]})
    m = out["constraint"]["floor"]
    assert m.position_sd == pytest.approx(2e-5, rel=0.3)
    assert m.force_sd == pytest.approx(0.01, rel=0.3)


def test_the_action_graph_bounds_each_commands_transitions():
    """9.1.3: under each command only its guarded move's transitions (and the end of an
    impact) are possible; 'hold' connects nothing, so a tap cannot reach (S,Z,F)."""
    from contactlab.experiments.guarded_move_actions import every_edge_graph
    from contactlab.observer.graph import bundled_graphs, load_graph

    g = load_graph(bundled_graphs()["guarded-move-actions"])
    idx = {n: i for i, n in enumerate(g.node_names)}
    impacts_end = {(idx["8"], idx["2"]), (idx["8"], idx["3"]), (idx["9"], idx["4"]),
                   (idx["9"], idx["5"]), (idx["10"], idx["6"])}
    assert set(g.edges) == impacts_end
    assert set(g.active_edges("hold")) == impacts_end
    reach = {a: {j for _, j in set(g.active_edges(a)) - impacts_end}
             for a in ("down", "to-wall", "into-corner")}
    assert reach["down"] == {idx["1"], idx["8"], idx["2"]}
    assert idx["4"] not in reach["down"] and idx["6"] not in reach["to-wall"]
    assert idx["6"] in reach["into-corner"] and idx["2"] not in reach["into-corner"]
    every = every_edge_graph()
    assert not every.action_edges
    assert set(every.edges) == set().union(*(set(g.active_edges(a)) for a in g.actions))
