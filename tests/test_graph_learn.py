"""graph learn: a feature graph from labelled recordings (nodes, edges and their
probabilities from label sequences, the phase Gaussians, a train/recognize round trip)."""

from __future__ import annotations

import json
from types import SimpleNamespace

import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner

from contactlab.cli import main
from contactlab.observer.graph import parse_graph
from contactlab.observer.graph_learn import count_transitions, graph_from_labels, label_sequences
from contactlab.observer.models.gaussian import GaussianFeature, gaussian_step

COLUMNS = "time=t;wrench=fx,fy,fz,tx,ty,tz;position=x,y,z;labels=label"
MAP = "1=approach,2=engage,3=engage,4=mated"


def _trial(labels, names):
    return SimpleNamespace(labels=np.asarray(labels), label_names=names)


def test_label_sequences_merge_repeats_and_skip_unmapped():
    t = _trial([0, 0, 1, 1, -1, 2, 2, 3, 0], ["0", "1", "2", "3"])
    seq, runs = label_sequences(t, {"1": "a", "2": "b", "3": "b"})
    assert seq == ["a", "b"]
    assert runs.tolist() == [[2, 4, 0], [5, 8, 1]]


def test_edges_probabilities_and_initial_from_sequences():
    seqs = [["a", "b", "c"], ["a", "b", "c"], ["a", "c"], ["b", "c"]]
    first, pairs = count_transitions(seqs)
    assert first == {"a": 3, "b": 1} and pairs[("a", "b")] == 2 and pairs[("a", "c")] == 1
    doc = graph_from_labels(seqs, {"1": "a", "2": "b", "3": "c"}, name="g")
    g = parse_graph(doc, source="g.toml")
    assert g.node_names == ("a", "b", "c")
    assert g.initial.tolist() == [0.75, 0.25, 0.0]
    p = g.edge_probabilities[0]
    a, b, c = range(3)
    assert p == pytest.approx({(a, b): 2 / 3, (a, c): 1 / 3, (b, c): 1.0})
    assert not g.edges and g.actions == ("task",)
    assert all(not n.self_transition for n in g.nodes)
    assert {m.kind for m in g.models.values()} == {"gaussian"}


def test_gaussian_model_scores_like_its_compiled_step():
    rng = np.random.default_rng(0)
    x = rng.normal(size=(200, 4)) @ rng.normal(size=(4, 4))
    m = GaussianFeature(name="g").fit([x[:120], x[120:]])
    ll, chi = m.run({}, x[:5], t0=0, starts=np.zeros(3, np.int64))
    assert ll.shape == (5, 3) and np.all(ll[:, 0] == ll[:, 2])
    for k in range(5):
        a, b, z = gaussian_step(m._p, x[k])
        assert a == pytest.approx(ll[k, 0], rel=1e-12) and b == pytest.approx(chi[k, 0, 0])
        assert z == 0.0 and chi[k, 0, 1] == 0.0          # no rivals: no margin
    # the log-density of N(mean, cov) (mean chi-square per dof near 1 on its own data)
    from scipy.stats import multivariate_normal
    assert ll[:, 0] == pytest.approx(multivariate_normal(m.mean, m.cov).logpdf(x[:5]))
    assert 0.8 < m.score(x)[1].mean() / 4 < 1.2


def _recording(seed: int, fs: float = 100.0) -> pd.DataFrame:
    """A small assembly: rest outside the task (0), approach (1) moving down, rotation (2)
    and insertion (3) pressing, mated (4) holding a load; offsets and noise per trial."""
    rng = np.random.default_rng(seed)
    plan = [(0, 1.0, 0.0, 0.0), (1, 3.0, 0.0, -0.05), (2, 1.0, 6.0, -0.005),
            (3, 1.5, 12.0, -0.01), (4, 3.0, 3.0, 0.0), (0, 1.0, 0.0, 0.0)]
    rows, z = [], 0.3
    for label, dur, fz, vz in plan:
        n = int((dur + rng.uniform(-0.2, 0.2)) * fs)
        f = np.zeros((n, 6))
        f[:, 2] = fz
        f += rng.normal(scale=0.3, size=(n, 6))
        zz = z + vz * np.arange(1, n + 1) / fs + rng.normal(scale=1e-4, size=n)
        z = zz[-1]
        rows.append(np.column_stack([f, np.full(n, 0.4), np.full(n, -0.1), zz,
                                     np.full(n, label)]))
    a = np.vstack(rows)
    df = pd.DataFrame(a[:, :9], columns=["fx", "fy", "fz", "tx", "ty", "tz", "x", "y", "z"])
    df.insert(0, "t", np.arange(len(a)) / fs)
    df["label"] = a[:, 9].astype(int)
    return df


@pytest.fixture(scope="module")
def archive(tmp_path_factory):
    d = tmp_path_factory.mktemp("learn")
    files = []
    for k in range(4):
        f = d / f"run{k}.csv"
        _recording(k).to_csv(f, index=False)
        files.append(str(f))
    out = d / "runs.h5"
    r = CliRunner().invoke(main, ["import", *files, "--out", str(out), "-q", "--columns", COLUMNS])
    assert r.exit_code == 0, r.output
    return out


def test_graph_learn_train_recognize_round_trip(archive, tmp_path):
    g = tmp_path / "learned.toml"
    train = ["--trial", "run0", "--trial", "run1"]
    r = CliRunner().invoke(main, ["graph", "learn", str(archive), *train, "--label-map", MAP,
                                  "--out", str(g), "--json"])
    assert r.exit_code == 0, r.output
    s = json.loads(r.stdout)
    assert s["nodes"] == ["approach", "engage", "mated", "outside"]
    # each change once per training run: per sample of the node it leaves (the HMM's
    # off-diagonal transition probability), the samples counted in the runs themselves
    labels = np.concatenate([_recording(k)["label"].to_numpy() for k in (0, 1)])
    n = {"approach": np.sum(labels == 1), "engage": np.sum((labels == 2) | (labels == 3)),
         "mated": np.sum(labels == 4), "outside": np.sum(labels == 0)}
    assert s["edges"] == pytest.approx({"approach -> engage": 2 / n["approach"],
                                        "engage -> mated": 2 / n["engage"],
                                        "mated -> outside": 2 / n["mated"],
                                        "outside -> approach": 2 / n["outside"]}, rel=1e-5)
    assert s["initial"]["outside"] == 1.0
    assert s["label_map"] == MAP + ",0=outside"
    r = CliRunner().invoke(main, ["graph", "show", str(g)])
    assert r.exit_code == 0 and "approach -> engage" in r.output, r.output
    m = tmp_path / "m.h5"
    r = CliRunner().invoke(main, ["train", str(archive), *train, "--graph", str(g),
                                  "--label-map", s["label_map"], "--out", str(m), "-q"])
    assert r.exit_code == 0, r.output
    r = CliRunner().invoke(main, ["recognize", str(archive), "--trial", "run2", "--trial",
                                  "run3", "--graph", str(g), "--models", str(m),
                                  "--label-map", MAP, "--json", "-q"])
    assert r.exit_code == 0, r.output
    out = json.loads(r.stdout)
    assert out["accuracy"] > 0.85, [(e["accuracy"], e["merged_path"])
                                    for e in out["trials"].values()]
    for e in out["trials"].values():
        assert [n for n, _ in e["merged_path"]][:4] == ["outside", "approach", "engage", "mated"]
        assert e["delays"]["transitions"] == 2      # outside is not scored with MAP


def test_graph_learn_em_and_extra_models(archive, tmp_path):
    g = tmp_path / "em.toml"
    r = CliRunner().invoke(main, ["graph", "learn", str(archive), "--label-map", MAP, "--em",
                                  "--models", "constraint,velocity", "--out", str(g), "-q"])
    assert r.exit_code == 0, r.output
    from contactlab.observer.graph import load_graph
    lg = load_graph(g)
    kinds = {m.kind for m in lg.models.values()}
    assert kinds == {"gaussian", "constraint", "velocity-moving"}
    assert lg.models["engage-constraint"].params["constraint"] == "1"
    assert lg.models["approach-constraint"].params["constraint"] == "0"
    p = lg.edge_probabilities[0]
    assert all(0 <= v <= 1 for v in p.values())


def test_em_keeps_the_per_sample_measure_of_the_label_counts(archive, tmp_path):
    """graph learn's edge probabilities are per sample of the node left (n_ij / N_i, the
    supervised HMM's); EM's refinement gives the same measure (the off-diagonal of its
    per-sample transition matrix), not the probability given a change (1 along a chain,
    which would make every change free): on the labelled runs it learns from, each edge
    lands near its label count."""
    from contactlab.observer.graph import load_graph

    plain, em = tmp_path / "plain.toml", tmp_path / "em.toml"
    for out, extra in ((plain, []), (em, ["--em"])):
        r = CliRunner().invoke(main, ["graph", "learn", str(archive), "--label-map", MAP,
                                      "--out", str(out), "-q", *extra])
        assert r.exit_code == 0, r.output
    counted, learned = load_graph(plain).edge_probabilities[0], load_graph(em).edge_probabilities[0]
    assert counted and max(counted.values()) < 0.05          # changes are rare per sample
    for edge, p in counted.items():
        assert 0.2 * p < learned[edge] < 5.0 * p, (edge, p, learned[edge])
    r = CliRunner().invoke(main, ["graph", "learn", str(archive), "--label-map", MAP, "--em",
                                  "--out", str(tmp_path / "em2.toml")])
    assert "edges refined by EM" in r.output


def test_graph_learn_refuses_a_map_matching_nothing(archive, tmp_path):
    r = CliRunner().invoke(main, ["graph", "learn", str(archive), "--label-map", "7=a",
                                  "--out", str(tmp_path / "x.toml")])
    assert r.exit_code == 1 and "label-map" in r.output, r.output


def test_a_base_graph_keeps_its_models_and_learns_the_edges():
    from contactlab.observer.graph_learn import base_document

    base = base_document("hf-gaussian")
    seqs = [["H0", "H1", "H3", "H2"], ["H0", "H1", "H0"], ["H0", "H1", "H3", "H2"]]
    lmap = {n: n for n in ("H0", "H1", "H2", "H3")}
    doc = graph_from_labels(seqs, lmap, name="g", base=base)
    g = parse_graph(doc, source="g.toml")
    assert doc["models"] == base["models"]                     # the base's, as declared
    assert [n.transient for n in g.nodes] == [False, False, False, True]
    assert [n.self_transition for n in g.nodes] == [False, False, False, True]
    assert g.initial.tolist() == [1.0, 0.0, 0.0, 0.0]
    h0, h1, h2, h3 = range(4)
    assert g.edge_probabilities[0] == pytest.approx(
        {(h0, h1): 1.0, (h1, h3): 2 / 3, (h1, h0): 1 / 3, (h3, h2): 1.0})
    from contactlab.errors import DataError

    with pytest.raises(DataError, match="'outside' is not a node of graph 'hf-gaussian'"):
        graph_from_labels(seqs + [["outside", "H0"]], {**lmap, "0": "outside"}, base=base)


def test_graph_learn_models_from_a_bundled_graph(tmp_path):
    from contactlab.synthetic import write_archive
    from contactlab.synthetic.switching import switching_trials

    write_archive(switching_trials(3, seed=5), tmp_path / "tr.h5")
    lmap = "H0=H0,H1=H1,H2=H2,H3=H3"
    r = CliRunner().invoke(main, ["graph", "learn", str(tmp_path / "tr.h5"), "--models-from",
                                  "hf-gaussian", "--label-map", lmap, "--out",
                                  str(tmp_path / "g.toml"), "--json"])
    assert r.exit_code == 0, r.output
    out = json.loads(r.stdout)
    assert out["models"]["H3"] == "I" and out["models"]["H0"] == "S0"
    for args in (["train", str(tmp_path / "tr.h5"), "--graph", str(tmp_path / "g.toml"),
                  "--out", str(tmp_path / "m.h5"), "-q"],
                 ["recognize", str(tmp_path / "tr.h5"), "--graph", str(tmp_path / "g.toml"),
                  "--models", str(tmp_path / "m.h5"), "--no-write", "-q"]):
        r = CliRunner().invoke(main, args)
        assert r.exit_code == 0, r.output
    r = CliRunner().invoke(main, ["graph", "learn", str(tmp_path / "tr.h5"), "--models-from",
                                  "hf-gaussian", "--models", "velocity", "--label-map", lmap,
                                  "--out", str(tmp_path / "h.toml")])
    assert r.exit_code == 2 and "give one of them" in r.output


def test_a_phase_recorded_with_another_sensor_offset_is_still_that_phase(archive, tmp_path,
                                                                          monkeypatch):
    # a wrist sensor not zeroed again between recordings: the test recording's force sits
    # 1.5 N above the training ones'.  Trained on one recording, a phase's force is known
    # to the noise within it (0.3 N), and "mated" (3 N) lifted to 4.5 N fits the broad
    # "engage" (6-12 N) better; the phase models' offset between recordings (1 N,
    # contactlab.signals.PHASE_OFFSET_SD) keeps it mated
    import contactlab.signals as signals

    df = _recording(7)
    df["fz"] += 1.5
    f = tmp_path / "offset.csv"
    df.to_csv(f, index=False)
    other = tmp_path / "offset.h5"
    r = CliRunner().invoke(main, ["import", str(f), "--out", str(other), "-q", "--columns",
                                  COLUMNS])
    assert r.exit_code == 0, r.output
    g = tmp_path / "learned.toml"
    train = ["--trial", "run0", "--trial", "run1"]
    r = CliRunner().invoke(main, ["graph", "learn", str(archive), *train, "--label-map", MAP,
                                  "--out", str(g), "--json"])
    lmap = json.loads(r.stdout)["label_map"]

    def accuracy(offset):
        monkeypatch.setattr(signals, "PHASE_OFFSET_SD", offset)
        m = tmp_path / f"m{offset[0]}.h5"
        r = CliRunner().invoke(main, ["train", str(archive), *train, "--graph", str(g),
                                      "--label-map", lmap, "--out", str(m), "-q"])
        assert r.exit_code == 0, r.output
        r = CliRunner().invoke(main, ["recognize", str(other), "--graph", str(g), "--models",
                                      str(m), "--label-map", MAP, "--json", "-q",
                                      "--no-write"])
        assert r.exit_code == 0, r.output
        return json.loads(r.stdout)["accuracy"]

    with_offset, without = accuracy((1.0, 0.1)), accuracy((0.0, 0.0))
    assert with_offset > 0.9 and with_offset > without + 0.1, (with_offset, without)


def test_the_phase_offset_adds_its_variance_to_the_trained_covariance():
    from contactlab.signals import phase_offset_sd

    rng = np.random.default_rng(1)
    x = rng.normal(size=(500, 9))
    sd = phase_offset_sd(9)
    assert sd.tolist() == [1.0] * 3 + [0.1] * 3 + [0.0] * 3
    plain = GaussianFeature(name="a", ridge=0.0).fit([x])
    wide = GaussianFeature(name="a", ridge=0.0, offset_sd=sd).fit([x])
    assert np.allclose(wide.cov - plain.cov, np.diag(sd ** 2), atol=1e-11)
    assert np.allclose(plain.cov, np.cov(x, rowvar=False), atol=1e-11)
    with pytest.raises(ValueError):
        GaussianFeature(name="a", offset_sd=sd[:6]).fit([x])


def test_a_graph_sets_its_phase_models_offset_and_a_bad_one_names_the_field():
    from contactlab.errors import ContactlabError

    doc = graph_from_labels([["a", "b"]], {"1": "a", "2": "b"}, name="g")
    doc["models"]["a"]["wrench_offset_sd"] = [0.01, 0.001]
    g = parse_graph(doc, source="g.toml")
    assert g.models["a"].params["wrench_offset_sd"] == (0.01, 0.001)
    doc["models"]["a"]["wrench_offset_sd"] = [1.0]
    with pytest.raises(ContactlabError) as e:
        parse_graph(doc, source="g.toml")
    assert "models.a.wrench_offset_sd" in str(e.value)
    doc["models"]["a"].update(wrench_offset_sd=[0.01, 0.001], signal="hf")
    with pytest.raises(ContactlabError) as e:            # an offset of the phase stream only
        parse_graph(doc, source="g.toml")
    assert "models.a.wrench_offset_sd" in str(e.value)


def test_graph_learn_says_when_the_phases_forces_are_small_beside_the_offset(tmp_path):
    # forces of a PHANToM-sized task (phases 0.1 N apart) against the 1 N wrist-sensor
    # offset the phase models allow: graph learn says so; a wrist-scale task (the module's
    # 3-12 N phases) gets no note
    from contactlab.observer.graph_learn import small_forces_note

    df = _recording(3)
    for c in ("fx", "fy", "fz", "tx", "ty", "tz"):
        df[c] = df[c] / 100.0
    f = tmp_path / "small.csv"
    df.to_csv(f, index=False)
    arc = tmp_path / "small.h5"
    r = CliRunner().invoke(main, ["import", str(f), "--out", str(arc), "-q", "--columns", COLUMNS])
    assert r.exit_code == 0, r.output
    r = CliRunner().invoke(main, ["graph", "learn", str(arc), "--label-map", MAP, "--out",
                                  str(tmp_path / "g.toml"), "--json"])
    assert r.exit_code == 0, r.output
    notes = json.loads(r.stdout)["notes"]
    assert any("wrench_offset_sd" in n for n in notes), notes
    big = {"a": {"force": np.array([0.0, 0.0, 3.0])}, "b": {"force": np.array([0.0, 0.0, 12.0])}}
    assert small_forces_note(big) == []
