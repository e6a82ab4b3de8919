"""Monte Carlo forward projection of the maze (thesis 5.3.5, 9.2, 10.1.1) and its graph file."""

from __future__ import annotations

import numpy as np
import pytest

from contactlab.errors import DataError
from contactlab.maze import build_partitions
from contactlab.maze.projection import maze_graph, node_kind
from contactlab.observer.graph import load_graph, parse_graph
from contactlab.observer.graph_toml import dumps_graph, graph_document, write_graph

TAIL_END, LEG_END = 25, 29       # the concave corners at the tail's end and the right leg's upper end


@pytest.fixture(scope="module")
def small():
    parts = build_partitions()
    doc, header, fp = maze_graph(samples=12, steps=600, seed=5, actions=(1, 5), parts=parts)
    return parts, doc, fp


def _reach(graph, start, action):
    adj = graph.adjacency(action)
    seen = {start}
    todo = [start]
    while todo:
        i = todo.pop()
        for j in np.flatnonzero(adj[i]):
            if j not in seen:
                seen.add(int(j))
                todo.append(int(j))
    return seen


def test_a_small_projection_finds_the_thesis_route_and_its_return(small, tmp_path):
    parts, doc, fp = small
    assert parts.by_number(TAIL_END).point == pytest.approx((-0.010 + parts.cspace.r, -0.040 + parts.cspace.r))
    assert parts.by_number(LEG_END).point == pytest.approx((0.035 - parts.cspace.r, 0.040 - parts.cspace.r))
    g = load_graph(write_graph(doc, tmp_path / "m.toml"))
    # 9.2: action 1 takes the robot from the tail's end to the right leg's end, action 5 back
    assert g.index(str(LEG_END)) in _reach(g, g.index(str(TAIL_END)), "action-1")
    assert g.index(str(TAIL_END)) in _reach(g, g.index(str(LEG_END)), "action-5")
    # under action 1 the leg's end is absorbing: every trace that reaches it stops there
    assert not fp.counts[1][LEG_END - 1].any()
    # probabilities out of every node under an action sum to 1, and are the counts' shares
    for a in (1, 5):
        p = fp.probabilities(a)
        out = fp.counts[a].sum(axis=1) > 0
        assert p[out].sum(axis=1) == pytest.approx(1.0)
        for (i, j), q in g.edge_probabilities[g.action_index(f"action-{a}")].items():
            ni, nj = int(g.node_names[i]), int(g.node_names[j])
            assert q == pytest.approx(fp.counts[a][ni - 1, nj - 1] / fp.counts[a][ni - 1].sum(), abs=1e-4)
    # impacts: each between two partitions that gain a surface (9.2) or lose a wall (the
    # loss impact of 4.3.2), and each followed by its partition's node
    surf = parts.cspace.surfaces
    for num, p in fp.impact_of.items():
        nxt = np.flatnonzero(fp.counts[1][num - 1] + fp.counts[5][num - 1]) + 1
        assert all(node_kind(fp, int(n))[1] == p for n in nxt)
        new = set(parts.by_number(p).surfaces)
        prev = np.flatnonzero(fp.counts[1][:, num - 1] + fp.counts[5][:, num - 1]) + 1
        assert len(prev)
        for n in prev:
            old = set(parts.by_number(node_kind(fp, int(n))[1]).surfaces)
            assert new - old or any(surf[k].kind == "segment" for k in old - new)


def test_the_shipped_graph_holds_the_small_projections_common_edges(small):
    _, _, fp = small
    g = load_graph("maze")
    for a in (1, 5):
        shipped = g.active_edges(f"action-{a}")
        common = [(i, j) for i, j in fp.edges(a) if fp.counts[a][i - 1, j - 1] >= 5]
        assert len(common) > 20
        missing = [(i, j) for i, j in common if (g.index(str(i)), g.index(str(j))) not in shipped]
        assert not missing


def test_graph_documents_round_trip_and_bad_probabilities_are_one_line_errors(tmp_path):
    g = load_graph("maze")
    again = parse_graph(graph_document(g))
    assert again.nodes == g.nodes and again.action_edges == g.action_edges
    assert again.edge_probabilities == g.edge_probabilities
    doc = graph_document(load_graph("guarded-move"))
    doc["actions"] = ["go"]
    doc["edge_sets"] = [{"actions": ["go"], "edges": ["0 -> 1", "0 -> 2"], "probabilities": [0.7, 0.6]}]
    path = tmp_path / "bad.toml"
    path.write_text(dumps_graph(doc))
    with pytest.raises(DataError, match=r"bad.toml.*edge_sets\[0\].probabilities.*sum to 1.3"):
        load_graph(path)
    doc["edge_sets"][0]["probabilities"] = [0.5]
    path.write_text(dumps_graph(doc))
    with pytest.raises(DataError, match=r"must be a list of 2 numbers"):
        load_graph(path)


def test_a_measured_run_becomes_the_node_trace_its_contacts_spell(small):
    from contactlab.maze.projection import measured_trace

    parts, _, fp = small
    P = len(parts)
    wall = parts.by_number(6)                       # the tail's right wall (partition 6)
    s = parts.cspace.surfaces[wall.surfaces[0]]
    a, b, n = (np.asarray(v, float) for v in (s.a, s.b, s.normal))
    mid = 0.5 * (a + b)
    free = mid + 2e-3 * n                           # 2 mm into the channel, off the wall
    u = np.linspace(0.0, 1.0, 300)[:, None]
    approach = free + u * (mid - free)              # 0.3 s straight onto the wall, moving
    slide = mid + u * 0.3 * (b - mid)               # 0.3 s along it, moving
    held = np.repeat(slide[-1:], 300, axis=0)       # 0.3 s at rest on it
    xy = np.concatenate([approach, slide, held])
    moving = np.r_[np.ones(600, bool), np.zeros(300, bool)]
    impacts: dict = {}
    tr = measured_trace(parts, xy, moving, 1000.0, impact_number=impacts)
    # node numbers (module notes): p fixed, P + p moving, 2P + p an impact into p
    assert tr[-3:] == [2 * P + 6, P + 6, 6]
    first = tr[0] - P
    assert 1 <= first <= P and parts.by_number(first).kind == "free"
    assert impacts == {6: 2 * P + 6}
    # a free partition held under 0.1 s is no feature of the trace: 50 ms off the wall
    on, off = np.repeat(mid[None], 300, axis=0), np.repeat(free[None], 50, axis=0)
    blip = np.concatenate([on, off, on])
    assert measured_trace(parts, blip, np.zeros(650, bool), 1000.0, impact_number={}) == [6]
    long_off = np.concatenate([on, np.repeat(free[None], 150, axis=0), on])
    assert len(measured_trace(parts, long_off, np.zeros(750, bool), 1000.0, impact_number={})) > 1


def test_measured_traces_are_counted_into_the_projections_edges(small):
    from contactlab.maze.projection import with_traces

    _, _, fp = small
    before = fp.counts[1].copy()
    P = fp.n_partitions
    out = with_traces(fp, {1: [[TAIL_END, P + TAIL_END, TAIL_END]]}, {})
    assert out.counts[1][TAIL_END - 1, P + TAIL_END - 1] == before[TAIL_END - 1, P + TAIL_END - 1] + 1
    assert out.counts[1][P + TAIL_END - 1, TAIL_END - 1] == before[P + TAIL_END - 1, TAIL_END - 1] + 1
    assert (out.counts[1].sum() - before.sum()) == 2
    assert np.array_equal(fp.counts[1], before)               # the projection itself unchanged
    row = out.probabilities(1)[TAIL_END - 1]
    assert row.sum() == pytest.approx(1.0)


def test_an_impact_may_be_missed_with_the_odds_of_seeing_it(small):
    from contactlab.maze.projection import ForwardProjection, with_missed_impacts

    parts, _, fp = small
    P = len(parts)
    wall, impact = P + 6, 2 * P + 6                 # moving on the tail's right wall, its impact
    free = P + 40
    c = np.zeros((3 * P, 3 * P), np.int64)
    c[free - 1, impact - 1] = 10                    # free -> impact -> wall, ten times
    c[impact - 1, wall - 1] = 10
    toy = ForwardProjection(parts, {1: c}, 10, {impact: 6})
    out = with_missed_impacts(toy)
    assert out.counts[1][free - 1, wall - 1] == 10
    p = out.probabilities(1)
    assert p[free - 1, impact - 1] == pytest.approx(0.5)
    assert p[free - 1, wall - 1] == pytest.approx(0.5)
    assert p[impact - 1, wall - 1] == pytest.approx(1.0)
    assert toy.counts[1][free - 1, wall - 1] == 0             # the input unchanged
