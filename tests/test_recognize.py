"""contactlab recognize / train --graph on synthetic archives with known switching."""

from __future__ import annotations

import hashlib

import numpy as np
import pytest
from conftest import one_json_object, run_cli

from contactlab.archive import create_archive, open_archive
from contactlab.conditioning import condition_strains
from contactlab.observer.recognize import detection_delays, recognize_archive
from contactlab.observer.training import GraphModels, train_graph

RATE = 1000.0
NAMES = ["A", "B", "C", "I"]
SD = {"A": 0.01, "B": 0.1, "C": 1.0}     # log-energy levels ~2.3 apart
TAU = 40.0                               # impact decay time constant (input samples)

GRAPH = """
name = "abc"
initial = "uniform"
edges = ["* -> *"]
[models.A]
kind = "temporal"
[models.B]
kind = "temporal"
[models.C]
kind = "temporal"
[[nodes]]
name = "A"
models = "A"
[[nodes]]
name = "B"
models = "B"
[[nodes]]
name = "C"
models = "C"
"""
GRAPH_I = GRAPH + """
[models.I]
kind = "impact"
[[nodes]]
name = "I"
models = "I"
transient = true
"""


def _trial_data(plan, seed):
    """Strains (n, 8): white noise of the segment's sd; 'I' decays from sd 1 with TAU."""
    rng = np.random.default_rng(seed)
    parts, labels = [], []
    for name, n in plan:
        e = rng.normal(size=(n, 8))
        if name == "I":
            e *= np.exp(-np.arange(n) / TAU)[:, None]
        else:
            e *= SD[name]
        parts.append(np.cumsum(e, axis=0) + (parts[-1][-1] if parts else 0.0))   # diff = e
        labels += [NAMES.index(name)] * n
    return np.concatenate(parts), np.array(labels, dtype=np.int16)


def _write(path, plans, seed=0):
    out = {}
    with create_archive(path, title="synthetic switching") as arc:
        for k, (tid, plan) in enumerate(plans.items()):
            strain, labels = _trial_data(plan, seed + k)
            n = len(labels)
            t = arc.add_trial(tid, rate_hz=RATE, source="simulator", strain_channels=8)
            t.append(time=np.arange(n) / RATE, strain=strain)
            t.set_ground_truth(labels=labels, names=NAMES)
            t.close()
            out[tid] = (strain, labels)
    return out


TRAIN = {"tr0": [("A", 3000), ("B", 2500), ("C", 3000), ("A", 2000)],
         "tr1": [("C", 2500), ("A", 3000), ("B", 3000), ("C", 2000)],
         "tr2": [("B", 3000), ("C", 2500), ("A", 3000), ("B", 2000)]}
TEST = {"te0": [("A", 2000), ("C", 1500), ("B", 1800), ("A", 1700)],
        "te1": [("B", 1600), ("A", 2400), ("C", 2000)]}


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    return recognition_files(tmp_path_factory.mktemp("recog"))


def recognition_files(d):
    """A training and a test archive of synthetic switching in ``d``, the feature
    graph and the models trained on it."""
    graph = d / "abc.toml"
    graph.write_text(GRAPH)
    _write(d / "train.h5", TRAIN, seed=0)
    test_data = _write(d / "test.h5", TEST, seed=10)
    gm = train_graph(d / "train.h5", graph, order=1, mean=True, block=100, reduce="mean")
    gm.save(d / "models.h5")
    return {"dir": d, "graph": graph, "models": d / "models.h5", "test": d / "test.h5",
            "train": d / "train.h5", "test_data": test_data}


def test_recognize_synthetic_switching(files):
    s = recognize_archive(files["test"], graph=files["graph"], models=files["models"],
                          write=False)
    assert s["accuracy"] > 0.9
    m = np.array(s["confusion"]["matrix"])
    # rows = the truth counts of the conditioned points (oracle: labels at hf_index)
    want = np.zeros(3, int)
    for strain, labels in files["test_data"].values():
        idx = np.minimum(condition_strains(strain, fs=RATE).hf_index, len(labels) - 1)
        want += np.bincount(labels[idx], minlength=3)[:3]
    assert m.sum(axis=1).tolist() == want.tolist()
    assert s["accuracy"] == pytest.approx(np.trace(m) / m.sum())
    # the merged MAP path follows the true switching, boundaries within 0.1 s
    for tid, plan in TEST.items():
        path = s["trials"][tid]["merged_path"]
        assert [n for n, _ in path] == [n for n, _ in plan]
        true_starts = np.cumsum([0] + [n for _, n in plan[:-1]]) / RATE
        assert np.allclose([t for _, t in path][1:], true_starts[1:], atol=0.1)


def test_recognize_cli_json_and_results(files, tmp_path):
    import shutil
    arc = tmp_path / "test.h5"
    shutil.copy(files["test"], arc)
    r = run_cli("recognize", arc, "--graph", files["graph"], "--models", files["models"],
                "--json", "--quiet")
    assert r.exit_code == 0, r.output
    obj = one_json_object(r.stdout)
    assert obj["confusion"]["labels"] == ["A", "B", "C"]
    assert np.array(obj["confusion"]["matrix"]).shape == (3, 3)
    assert 0.9 < obj["accuracy"] <= 1.0
    assert set(obj["trials"]) == set(TEST)
    for e in obj["trials"].values():
        assert all(isinstance(n, str) and isinstance(t, float) for n, t in e["path"])
    with open_archive(arc) as a:
        res = a.trial("te0").results("recognize")
        p = np.asarray(res["node_prob"])
        assert p.shape[1] == 3 and np.allclose(p.sum(axis=1), 1.0)
        assert len(res["labels"]) == len(p)


def test_bad_graph_is_one_line_error(files, tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text(GRAPH.replace('edges = ["* -> *"]', 'edges = ["A -> Q"]'))
    r = run_cli("recognize", files["test"], "--graph", bad, "--models", files["models"],
                "--no-write")
    assert r.exit_code == 1
    lines = r.stderr.strip().splitlines() if hasattr(r, "stderr") else r.output.splitlines()
    assert len(lines) == 1 and "bad.toml" in lines[0] and "Q" in lines[0]
    assert "Traceback" not in r.output


def test_graph_models_mismatch_names_both_files(files, tmp_path):
    g = tmp_path / "more.toml"
    g.write_text(GRAPH + '[models.D]\nkind = "temporal"\n[[nodes]]\nname = "D"\nmodels = "D"\n')
    r = run_cli("recognize", files["test"], "--graph", g, "--models", files["models"],
                "--no-write")
    assert r.exit_code == 1
    msg = r.output.strip().splitlines()
    assert len(msg) == 1
    assert "more.toml" in msg[0] and "models.h5" in msg[0] and "'D'" in msg[0]


def test_train_graph_round_trip_with_impact(tmp_path):
    plans = {f"t{k}": [("A", 1500), ("I", 200), ("C", 1500), ("B", 1200), ("I", 200),
                       ("A", 1500)] for k in range(3)}
    arc = tmp_path / "imp.h5"
    data = _write(arc, plans, seed=5)
    graph = tmp_path / "abci.toml"
    graph.write_text(GRAPH_I)
    out = tmp_path / "m.h5"
    r = run_cli("train", arc, "--graph", graph, "--order", "1", "--mean", "--reduce", "mean",
                "--out", out, "--json", "--quiet")
    assert r.exit_code == 0, r.output
    obj = one_json_object(r.stdout)
    assert obj["labels"] == ["A", "B", "C", "I"]
    assert obj["impact_segments"] == {"I": 6}
    gm = GraphModels.load(out)
    # blocks per class, brute force: y_h[k] uses inputs hf_index[k] - 8 .. hf_index[k];
    # a conditioned sample is labelled only if all nine carry one label, and each run of
    # one label gives len // 100 blocks
    want = dict.fromkeys("ABC", 0)
    for strain, labels in data.values():
        idx = condition_strains(strain, fs=RATE).hf_index
        codes = [labels[i] if len(set(labels[max(i - 8, 0):i + 1])) == 1 else -1 for i in idx]
        run, prev = 0, None
        for c in codes + [None]:
            if c != prev:
                if prev is not None and 0 <= prev <= 2:
                    want[NAMES[prev]] += run // 100
                run, prev = 0, c
            run += 1
    assert {k: m.n_blocks for k, m in gm.temporal.items()} == want
    # impact prior: y_h of exp(-n/TAU) noise decays by 4/TAU per 250 Hz sample
    slope = gm.impacts["I"].theta_mean[0, 1]
    assert slope == pytest.approx(-4.0 / TAU, rel=0.15)
    assert gm.reduce == "mean"
    assert gm.provenance["graph"]["sha256"] == hashlib.sha256(graph.read_bytes()).hexdigest()
    # the plain temporal reader still reads the file
    from contactlab.temporal import ModelSet
    assert ModelSet.load(out).labels == ["A", "B", "C"]
    # refuses to overwrite
    r = run_cli("train", arc, "--graph", graph, "--out", out, "--quiet")
    assert r.exit_code != 0


def test_detection_delays_by_hand():
    truth = np.array([0] * 10 + [1] * 10 + [-1] * 3 + [2] * 10)
    path = [("A", 0), ("B", 12), ("B", 15), ("C", 30), ("A", 31)]
    d = detection_delays(truth, path, ["A", "B", "C"], window=5)
    # B true at 10, marked 12 (delay 2); C true at 23, marked 30 (7 > 5: missed); A@31 extra
    assert d["counts"] == {"0": 0, "1": 0, "2": 1, "3": 0, ">3": 0}
    assert d["missed"] == 1 and d["extra"] == 2 and d["transitions"] == 2


def test_detection_delays_take_a_short_run_as_the_run_before_it():
    # A, a 2-sample flicker of B, A again, then B for good and a 1-sample C inside it
    truth = np.array([0] * 10 + [1] * 2 + [0] * 8 + [1] * 5 + [2] + [1] * 10)
    path = [("A", 0), ("B", 21)]
    every = detection_delays(truth, path, ["A", "B", "C"], window=5)
    assert every["transitions"] == 5 and every["missed"] == 4
    d = detection_delays(truth, path, ["A", "B", "C"], window=5, min_run=3)
    # one transition left, A -> B at 20, marked at 21
    assert d["transitions"] == 1 and d["missed"] == 0
    assert d["counts"] == {"0": 0, "1": 1, "2": 0, "3": 0, ">3": 0} and d["delays"] == [1]


def test_recognize_on_two_workers_matches_a_serial_run(files):
    kw = dict(graph=files["graph"], models=files["models"], write=False)
    serial = recognize_archive(files["test"], **kw)
    assert recognize_archive(files["test"], workers=2, **kw) == serial


def test_recognize_transitions_option_weighs_edge_probabilities(files, tmp_path):
    """An action graph whose edge set carries probabilities: ``--transitions graph`` (the
    default) and ``none`` both run; each records its choice; a bad choice is refused."""
    g = tmp_path / "abc-p.toml"
    g.write_text(GRAPH.replace('edges = ["* -> *"]', 'actions = ["go"]\n'
                               '[[edge_sets]]\nactions = ["go"]\n'
                               'edges = ["A -> B", "A -> C", "B -> A", "B -> C", "C -> A", "C -> B"]\n'
                               'probabilities = [0.5, 0.5, 0.5, 0.5, 0.5, 0.5]'))
    seen = {}
    for mode in ("graph", "none"):
        r = run_cli("recognize", files["test"], "--graph", g, "--models", files["models"],
                    "--action", "go", "--transitions", mode, "--no-write", "--json", "--quiet")
        assert r.exit_code == 0, r.output
        obj = one_json_object(r.stdout)
        assert obj["parameters"]["transitions"] == mode
        seen[mode] = obj["accuracy"]
    # equal probabilities out of every node: log p is the same for every successor, so the
    # paths rank the same and the labels agree
    assert seen["graph"] == pytest.approx(seen["none"])
    r = run_cli("recognize", files["test"], "--graph", g, "--models", files["models"],
                "--action", "go", "--transitions", "hmm", "--no-write")
    assert r.exit_code != 0 and "Traceback" not in r.output


def test_explain_names_each_true_transition_and_why(files, tmp_path):
    """--explain: one entry per true label change (counted from the plan), each detected
    on clean switching; with detectors that can never cross, every change is reported
    missed with no alarm although the detectors' statistics rise far past 8."""
    import shutil
    arc = tmp_path / "test.h5"
    shutil.copy(files["test"], arc)
    args = ("recognize", arc, "--graph", files["graph"], "--models", files["models"])
    r = run_cli(*args, "--explain", "te0", "--json")
    assert r.exit_code == 0, r.output
    ex = one_json_object(r.stdout)
    plan = TEST["te0"]
    assert [(t["from"], t["to"]) for t in ex["transitions"]] == \
        [(a[0], b[0]) for a, b in zip(plan[:-1], plan[1:])]
    assert all(t["verdict"] == "detected" for t in ex["transitions"])
    assert all(abs(t["delay"]) <= ex["window_samples"] for t in ex["transitions"])
    # levels 2.3 apart: the models alone label every true segment, with a clear margin
    assert ex["segment_accuracy"] == 1.0
    assert all(s["margin"] > 10 for s in ex["segments"])
    # nothing written by --explain
    with open_archive(arc) as a:
        assert "recognize" not in a.trial("te0").result_stages()
    r = run_cli(*args, "--explain", "te0", "--json", "--threshold", "1e9")
    ex = one_json_object(r.stdout)
    assert len(ex["path"]) == 1
    for t in ex["transitions"]:
        assert t["verdict"] == "no alarm" and t["events"] == []
        assert max(d["max"] for d in t["detectors"]) > 8
        assert all(d["crossed"] is None for d in t["detectors"])
    r = run_cli(*args, "--explain", "te0")
    assert r.exit_code == 0 and "A -> C at" in r.output
    r = run_cli(*args, "--explain", "nope")
    assert r.exit_code == 2 and len(r.output.strip().splitlines()) == 1


def test_explain_text_lists_one_line_per_alarm_time_and_sums_up_the_rest():
    """An alarm crossed by several tests of one path is one line; past the first few,
    the alarms are counted by what they started and how it fared (JSON keeps all)."""
    from contactlab.observer.explain import TEXT_EVENTS, _event_lines

    def ev(t, spawned):
        return {"time": t, "path_node": "B", "model": "B", "change_time": t,
                "spawned": [{"node": "C", "start": t, "fate": f} for f in spawned]}

    events = []
    for t in range(10):
        events += [ev(t, ["pruned: gap" if t % 2 else "kept"]), ev(t, []), ev(t, [])]
    lines = _event_lines(events, fs=10.0)
    assert len(lines) == TEXT_EVENTS + 1
    assert lines[0].startswith("    alarm at 0.000s on B/B") and "C@0.000s kept" in lines[0]
    rest = range(TEXT_EVENTS, 10)
    kept = sum(1 for t in rest if t % 2 == 0)
    assert lines[-1] == (f"    {len(rest)} more alarms until 0.900s: started "
                         + ", ".join(f"{k} x{v}" for k, v in
                                     ([("C pruned: gap", len(rest) - kept), ("C kept", kept)]
                                      if TEXT_EVENTS % 2 else
                                      [("C kept", kept), ("C pruned: gap", len(rest) - kept)])))
    assert _event_lines([], fs=10.0) == []
