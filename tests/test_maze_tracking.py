"""The observer over simulated maze trials (9.2): transition weights, wall frames, the
feature vocabulary, and one trial tracked end to end."""

from __future__ import annotations

import math

import numpy as np
import pytest

from contactlab.acquire.sim import MAZE_WALLS, maze_corners
from contactlab.maze import build_partitions
from contactlab.maze.projection import maze_graph, node_kind
from contactlab.maze.tracking import (feature_of_nodes, feature_runs, labels_present,
                                      observer_graph, track_trial, wall_rotation_deg)
from contactlab.observer import MovingVelocity, FixedVelocity, Observer, observe, parse_graph
from contactlab.observer.kinematics import fit_kinematic_models

START, GOAL = 25, 29


def _two_way_graph(p):
    doc = {"name": "two-way", "actions": ["go"],
           "models": {"F": {"kind": "velocity-fixed", "sigma": 0.001},
                      "M": {"kind": "velocity-moving", "low": -0.01, "high": 0.01, "sigma": 0.001}},
           "nodes": [{"name": "still", "models": {"velocity": "F"}, "initial": 1.0,
                      "self_transition": False},
                     {"name": "a", "models": {"velocity": "M"}, "self_transition": False},
                     {"name": "b", "models": {"velocity": "M"}, "self_transition": False}],
           "edge_sets": [{"actions": ["go"], "edges": ["still -> a", "still -> b"],
                          "probabilities": [p, 1.0 - p]}]}
    return parse_graph(doc)


@pytest.mark.parametrize("p", [0.8, 0.3])
def test_transition_probabilities_weigh_each_successor_by_log_p(p):
    rng = np.random.default_rng(3)
    v = np.zeros((400, 3))
    v[200:, 0] = 0.005                     # still, then moving at 5 mm/s
    v += rng.normal(0.0, 0.001, v.shape)
    g = _two_way_graph(p)
    models = {"F": FixedVelocity(name="F", sigma=0.001),
              "M": MovingVelocity(name="M", low=-0.01, high=0.01, sigma=0.001)}
    lls = {}
    for mode in ("graph", "none"):
        obs = Observer(g, models, transitions=mode, p_prune=1.0, gap=math.inf)
        observe(obs, {"velocity": v}, action=np.zeros(len(v), int))
        lls[mode] = {(q.node, q.start): q.loglik for q in obs.paths() if q.node in "ab"}
    a = [k for k in lls["graph"] if k[0] == "a"]
    b = [("b", s) for _, s in a]
    assert a and all(k in lls["graph"] for k in b)
    for ka, kb in zip(a, b):
        # the same data after the change: the two successors differ by log(p / (1 - p)) exactly
        assert lls["graph"][ka] - lls["graph"][kb] == pytest.approx(math.log(p / (1 - p)), abs=1e-9)
        assert lls["none"][ka] == pytest.approx(lls["none"][kb], abs=1e-9)
    with pytest.raises(ValueError, match="transitions"):
        Observer(g, models, transitions="hmm")


def test_training_fits_a_constraint_in_the_graphs_rotated_frame():
    rng = np.random.default_rng(0)
    n = 300
    pos = np.c_[np.linspace(0, 0.02, n), np.full(n, 0.01), np.full(n, 0.005)]
    pos += rng.normal(0.0, 1e-5, pos.shape)
    force = np.c_[rng.normal(0, 0.005, n), np.full(n, 0.15), np.full(n, 0.2)]   # a y wall and the floor
    doc = {"name": "w", "models": {"C": {"kind": "constraint", "constraint": "XZ", "mode": "fixed",
                                         "rotate_deg": [0.0, 0.0, 90.0], "trained": "wall"}},
           "nodes": [{"name": "w", "models": {"constraint": "C"}, "initial": 1.0}]}
    models = fit_kinematic_models(parse_graph(doc), {("contact", "wall"): [np.c_[pos, force]]})
    m = models["constraint"]["wall"]
    assert np.abs(m.normals.T @ [0.0, 1.0, 0.0]).max() == pytest.approx(1.0, abs=1e-9)
    assert np.abs(m.normals.T @ [0.0, 0.0, 1.0]).max() == pytest.approx(1.0, abs=1e-9)
    # along the (correct) normals the motion is the noise: a few units, not the 20 mm slide
    assert np.diag(m.V)[:2].max() < 10.0


@pytest.fixture(scope="module")
def small():
    parts = build_partitions()
    doc, _, fp = maze_graph(samples=12, steps=600, seed=5, actions=(1, 5), parts=parts)
    return parts, doc, fp


def test_nodes_stand_for_the_simulators_features_and_walls_get_their_own_frames(small):
    parts, doc, fp = small
    names = [n["name"] for n in doc["nodes"]]
    feats = feature_of_nodes(fp, names)
    corner_names = {f"{MAZE_WALLS[a]}+{MAZE_WALLS[b]}" for a, b in maze_corners()}
    for name, f in zip(names, feats):
        kind, p = node_kind(fp, int(name))
        part = parts.by_number(p)
        if kind == "impact":
            assert f == "impact"
        elif part.kind == "corner":
            assert f.rsplit("-", 1)[0] in corner_names
        elif part.kind == "segment":
            assert f == f"{MAZE_WALLS[part.surfaces[0]]}-{kind}"
        else:
            assert f == f"channel-{kind}"
    assert feature_of_nodes(fp, [str(START)]) == ["tail-left+tail-end-fixed"]
    assert feature_of_nodes(fp, [str(GOAL)]) == ["right-leg-outer+right-leg-top-fixed"]
    # wall 5 (the tail's right wall) faces -x, wall 12 (the crossbar's top) faces -y
    assert wall_rotation_deg(parts, 5) == pytest.approx(180.0)
    assert wall_rotation_deg(parts, 12) == pytest.approx(-90.0)
    labels = ["channel-fixed", "channel-moving", "impact", "tail-right-moving",
              "tail-left+tail-end-fixed"]
    g = observer_graph(doc, fp, labels)
    # a partition's parameters are the fixed maze's: no node re-draws them (no self-transition)
    assert all(n["self_transition"] is False for n in g["nodes"])
    assert not parse_graph(g).adjacency("action-1").diagonal().any()
    assert g["models"]["C05"]["trained"] == ["tail-right-moving"]
    assert g["models"]["C12"]["trained"] == ["channel-fixed", "channel-moving"]   # untouched wall
    with pytest.raises(ValueError, match="impact"):
        observer_graph(doc, fp, ["channel-fixed", "channel-moving", "tail-right-moving",
                                 "tail-left+tail-end-fixed"])


def test_feature_runs_drop_impacts_and_short_visits():
    x = ["a"] * 30 + ["impact"] * 40 + ["a"] * 30 + ["b"] * 5 + ["c"] * 60
    assert feature_runs(x, fs=250.0) == ["a", "c"]        # b held 20 ms < 0.1 s


def test_one_simulated_trial_is_followed_to_the_legs_end(small, tmp_path):
    from contactlab.acquire.simulated import record_spec
    from contactlab.archive import open_archive
    from contactlab.observer.recognize import bind_models
    from contactlab.observer.training import train_graph

    _, doc, fp = small
    train = record_spec("maze", tmp_path / "train.h5", seed=21, n_trials=2)
    test = record_spec("maze", tmp_path / "test.h5", seed=22, n_trials=1)
    g = parse_graph(observer_graph(doc, fp, labels_present(train)))
    g, trained, models = bind_models(g, train_graph(train, g))
    assert trained.reduce == "mean"
    with open_archive(test) as arch:
        rec = track_trial(arch.trial(arch.trial_ids[0]), g, models, fp, start_s=1.5,
                          start_node=str(START), reduce=trained.reduce)
    # reduced as in training, the sliding model S explains sliding better than the impact's
    # decay I does (on all 8 channels against channel-mean models, I won by 1.8 nats a sample)
    from contactlab.observer.models.base import ModelBank
    from contactlab.signals import trial_signals, truth_codes

    with open_archive(test) as arch:
        t = arch.trial(arch.trial_ids[0])
        data, index, _ = trial_signals(t, ["hf"], reduce=trained.reduce)
        names = [str(x) for x in t.label_names]
        codes = truth_codes(t, index, names)
    y = data["hf"]
    k = names.index("channel-moving")
    edges = np.flatnonzero(np.diff((codes == k).astype(int))) + 1
    runs = [(a, b) for a, b in zip(edges[:-1], edges[1:]) if codes[a] == k and b - a > 100]
    assert runs
    for a, b in runs:
        ll = {}
        for name in ("S", "I"):
            bank = ModelBank(models[name], y.shape[1])
            st, state = bank.new([a])
            ll[name] = bank.run(y[a - models[name].lag:b], t0=a, starts=st, state=state)[0].sum()
        assert ll["S"] > ll["I"]
    assert rec["true_features"][-1] == "right-leg-outer+right-leg-top-fixed"
    assert rec["decoded_features"][-1] == rec["true_features"][-1]
    assert rec["accuracy"] > 0.5
