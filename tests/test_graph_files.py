"""Feature-graph files: the examples load, and each kind of mistake is one line naming it."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from click.testing import CliRunner

from contactlab.cli import main
from contactlab.errors import DataError
from contactlab.observer import load_graph

GRAPHS = Path(__file__).resolve().parents[1] / "datasets_spec" / "graphs"

GOOD = """
name = "g"
initial = "uniform"
edges = ["A -> B", "B -> A"]
[models.a]
kind = "temporal"
[models.v]
kind = "velocity-fixed"
sigma = 0.1
[[nodes]]
name = "A"
models = {hf = "a", velocity = "v"}
[[nodes]]
name = "B"
models = "a"
"""


def write(tmp_path, text, name="g.toml"):
    p = tmp_path / name
    p.write_text(text)
    return p


def test_examples_load():
    cf = load_graph(GRAPHS / "hf-context-free.toml")
    assert cf.node_names == ("H0", "H1", "H2", "H3")
    assert cf.initial.tolist() == [0.25] * 4
    assert all(cf.successors(i) == (0, 1, 2, 3) for i in range(4))
    assert [n.transient for n in cf.nodes] == [False, False, False, True]
    ctx = load_graph(GRAPHS / "hf-context.toml")
    # action-dependent edges (9.1.3): H0 -> H1 only while moving
    assert ctx.successors(0, "rest") == (0,)
    assert ctx.successors(0, "move") == (0, 1)
    assert ctx.successors(1, 1) == (0, 1, 3)
    gm = load_graph(GRAPHS / "guarded-move.toml")
    assert gm.nodes[3].models == (("hf", "S"), ("constraint", "CZ"), ("velocity", "F"))
    assert gm.successors(1) == (1, 2, 3, 4, 5)


def test_good_graph_roundtrip(tmp_path):
    g = load_graph(write(tmp_path, GOOD))
    assert g.adjacency().tolist() == [[True, True], [True, True]]
    d = g.to_dict()
    assert d["edges"] == [["A", "B"], ["B", "A"]]
    assert g.p_prune is None and d["p_prune"] is None
    g1 = load_graph(write(tmp_path, GOOD.replace(
        'initial = "uniform"\n', 'initial = "uniform"\np_prune = 1\nsides = "both"\n'), "g1.toml"))
    assert g1.p_prune == 1.0 and g1.with_initial({"A": 1.0}).p_prune == 1.0
    from contactlab.observer.graph_toml import dumps_graph, graph_document

    again = write(tmp_path, dumps_graph(graph_document(g1)), "g2.toml")
    assert load_graph(again).p_prune == 1.0 and load_graph(again).sides == "both"
    assert d["nodes"][0]["models"] == {"hf": "a", "velocity": "v"}


MISTAKES = [
    # (replace this, with that, field expected in the message, words expected)
    ('kind = "velocity-fixed"', 'kind = "velocty"', "models.v.kind", "unknown model kind"),
    ('models = "a"', 'models = "zz"', "nodes[1] (B).models", "unknown model 'zz'"),
    ('"B -> A"', '"B -> C"', "edges[1]", "dangling edge"),
    ('initial = "uniform"\n', "", "initial", "no initial probabilities"),
    ('name = "B"\n', 'name = "B"\ninitial = 1.5\n', "nodes[1] (B).initial", "must be a probability"),
    ('sigma = 0.1', 'sigma = -1.0', "models.v.sigma", "must be > 0"),
    ('"A -> B", "B -> A"', '"A -> A"', "edges[0]", "self_transition"),
    ('initial = "uniform"\n', 'initial = "uniform"\np_prune = 0\n', "p_prune", "in (0, 1]"),
    ('initial = "uniform"\n', 'initial = "uniform"\np_prune = "all"\n', "p_prune", "in (0, 1]"),
    ('kind = "velocity-fixed"\nsigma = 0.1', 'kind = "velocity-moving"\nsigma = 0.1',
     "models.v.low", "low and high (sigma trained)"),
    ('kind = "velocity-fixed"\nsigma = 0.1', 'kind = "velocity-moving"\nlow = -0.01',
     "models.v.high", "need low, high and sigma"),
]


@pytest.mark.parametrize("old,new,field,words", MISTAKES)
def test_mistakes_are_one_line(tmp_path, old, new, field, words):
    assert old in GOOD
    p = write(tmp_path, GOOD.replace(old, new, 1))
    with pytest.raises(DataError) as exc:
        load_graph(p)
    msg = str(exc.value)
    assert "\n" not in msg
    assert msg.startswith(str(p) + ": ")
    assert field in msg and words in msg


def test_probabilities_must_sum_to_one(tmp_path):
    text = GOOD.replace('initial = "uniform"\n', "").replace(
        'name = "A"\n', 'name = "A"\ninitial = 0.6\n').replace('name = "B"\n', 'name = "B"\ninitial = 0.3\n')
    with pytest.raises(DataError, match=r"nodes.initial: initial probabilities sum to 0.9, not 1"):
        load_graph(write(tmp_path, text))


def test_unreachable_node(tmp_path):
    text = GOOD.replace('initial = "uniform"\n', "").replace(
        'name = "A"\n', 'name = "A"\ninitial = 1.0\n').replace('"A -> B", "B -> A"', '"B -> A"')
    with pytest.raises(DataError, match=r"nodes\[1\] \(B\): unreachable node"):
        load_graph(write(tmp_path, text))


def test_action_edges_count_for_reachability_and_unknown_action(tmp_path):
    base = GOOD.replace('initial = "uniform"\n', 'actions = ["rest", "move"]\n').replace(
        'name = "A"\n', 'name = "A"\ninitial = 1.0\n').replace('"A -> B", "B -> A"', '"B -> A"')
    ok = base + '[[edge_sets]]\nactions = ["move"]\nedges = ["A -> B"]\n'
    g = load_graph(write(tmp_path, ok))
    assert g.successors(0, "move") == (0, 1) and g.successors(0, "rest") == (0,)
    bad = base + '[[edge_sets]]\nactions = ["run"]\nedges = ["A -> B"]\n'
    with pytest.raises(DataError, match=r"edge_sets\[0\].actions: unknown action 'run'"):
        load_graph(write(tmp_path, bad, "b.toml"))


def test_toml_syntax_and_missing_file(tmp_path):
    with pytest.raises(DataError, match="TOML syntax error"):
        load_graph(write(tmp_path, "name = \n"))
    with pytest.raises(DataError, match="no such file"):
        load_graph(tmp_path / "nope.toml")


def test_cli_show(tmp_path):
    runner = CliRunner()
    out = tmp_path / "g.png"
    r = runner.invoke(main, ["graph", "show", str(GRAPHS / "hf-context.toml"), "--out", str(out),
                             "--json"])
    assert r.exit_code == 0, r.output
    d = json.loads(r.stdout)
    assert d["name"] == "hf-context" and d["edge_sets"][0]["actions"] == ["move"]
    assert out.stat().st_size > 1000
    r = runner.invoke(main, ["graph", "show", str(GRAPHS / "hf-context.toml"), "--out", str(out)])
    assert r.exit_code == 1 and "exists" in r.stderr
    bad = write(tmp_path, GOOD.replace('"B -> A"', '"B -> Q"'), "bad.toml")
    r = runner.invoke(main, ["graph", "show", str(bad)])
    assert r.exit_code == 1
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and "bad.toml: edges[1]: dangling edge" in lines[0]


def test_bundled_graph_names_resolve_from_any_directory(tmp_path, monkeypatch):
    """Graph names are package data (importlib.resources), not paths from a checkout."""
    from contactlab.observer.graph import bundled_graphs, load_graph

    monkeypatch.chdir(tmp_path)
    assert {"hf-context", "hf-context-free"} <= set(bundled_graphs())
    for name in ("hf-context", "hf-context.toml", "datasets_spec/graphs/hf-context.toml"):
        assert load_graph(name).name == "hf-context"


@pytest.mark.parametrize("name", ["free-contact", "guarded-move"])
def test_drawing_keeps_every_word_inside_the_image(tmp_path, name):
    # long node descriptions sit beside the outer nodes: the saved image must hold them
    # whole, so a margin of white all round (nothing drawn touches the border)
    import matplotlib.image as mpimg

    from contactlab.observer.draw import draw_graph
    from contactlab.observer.graph import load_graph

    img = mpimg.imread(draw_graph(load_graph(name), tmp_path / "g.png"))[..., :3]
    for edge in (img[:4], img[-4:], img[:, :4], img[:, -4:]):
        assert edge.min() > 0.99
