"""A user's wrench-and-position recording: import a CSV, train free-contact, recognise."""

import re

import h5py
import numpy as np
import pandas as pd
import pytest

from contactlab.archive import open_archive
from contactlab.peers.force_threshold import ForceThreshold
from contactlab.synthetic.free_contact import free_contact_recording

from conftest import one_json_object, run_cli

COLUMNS = "time=t;wrench=fx,fy,fz,tx,ty,tz;position=x,y,z;labels=state"
MAP = "1=free,2=contact,3=free"


def _archive(tmp_path, name, seed, fs, *, offset_n=0.0, **kw):
    rec = free_contact_recording(seed=seed, fs=fs, cycles=4, **kw)
    csv = tmp_path / f"{name}.csv"
    cols = pd.DataFrame(rec.csv_columns())
    cols["fx"] += offset_n                     # a force sensor not zeroed
    cols.to_csv(csv, index=False)
    out = tmp_path / f"{name}.h5"
    r = run_cli("import", csv, "--out", out, "--columns", COLUMNS, "-q")
    assert r.exit_code == 0, r.output
    return out


@pytest.mark.parametrize("fs", [100.0, 500.0])
def test_imported_recording_trains_and_is_recognised(tmp_path, fs):
    train = _archive(tmp_path, "rec1", 11, fs)
    test = _archive(tmp_path, "rec2", 12, fs)
    models = tmp_path / "m.h5"
    r = run_cli("train", train, "--graph", "free-contact", "--label-map", MAP,
                "--out", models, "--json", "-q")
    assert r.exit_code == 0, r.output
    info = one_json_object(r.output)
    assert info["constraints"]["contact"]["degree"] == 1
    assert info["label_map"] == {"1": "free", "2": "contact", "3": "free"}
    r = run_cli("recognize", test, "--graph", "free-contact", "--models", models, "--json",
                "-q", "--no-write")
    assert r.exit_code == 0, r.output
    out = one_json_object(r.output)
    (tid, trial), = out["trials"].items()
    path = trial["path"]
    assert path[0] == ["free", 0.0]
    assert all(isinstance(n, str) and isinstance(s, float) for n, s in path)
    assert [n for n, _ in path].count("contact") >= 4          # four touch-downs
    # chance: always the most frequent node, about half the points
    assert trial["accuracy"] > 0.9
    assert out["accuracy"] == pytest.approx(trial["accuracy"])
    # the models fit the recording: no warning, chi-square per degree of freedom near 1
    assert not trial["fit"]["misfit"] and out["warnings"] == []
    assert 0.2 < trial["fit"]["chi2_per_dof"] < 4
    assert "warning" not in r.stderr


def test_recording_the_models_do_not_fit_is_warned(tmp_path):
    """Models trained on a quiet, zeroed recording, run on one with 5x the force noise and
    a 0.2 N offset (10 trained sd): one warning line on stderr, "misfit" in the JSON."""
    train = _archive(tmp_path, "quiet", 11, 100.0)
    noisy = _archive(tmp_path, "noisy", 12, 100.0, force_sd=0.1, offset_n=0.2)
    models = tmp_path / "m.h5"
    r = run_cli("train", train, "--graph", "free-contact", "--label-map", MAP,
                "--out", models, "-q")
    assert r.exit_code == 0, r.output
    r = run_cli("recognize", noisy, "--graph", "free-contact", "--models", models, "--json",
                "-q", "--no-write")
    assert r.exit_code == 0, r.output
    out = one_json_object(r.stdout)
    (tid, trial), = out["trials"].items()
    from contactlab.observer.fit import MISFIT
    assert trial["fit"]["misfit"] and max(trial["fit"]["by_model"].values()) > MISFIT
    warn = [ln for ln in r.stderr.splitlines() if ln.startswith("warning:")]
    assert len(warn) == 1 and "noisy.h5" in warn[0] and "fit none" in warn[0]
    assert out["warnings"] == [warn[0].removeprefix("warning: ")]


def test_force_threshold_peer_on_the_same_points():
    """The peer as a library part: trained k and sigma, predictions on forces."""
    rng = np.random.default_rng(0)
    free = rng.normal(0, 0.05, (500, 3))
    contact = free[:300] + np.array([0.0, 0.0, 0.6])
    f = np.r_[free, contact]
    c = np.r_[np.zeros(500, bool), np.ones(300, bool)]
    p = ForceThreshold().fit(f, c)
    assert p.sigma_ == pytest.approx(0.05, rel=0.1)
    assert np.mean(p.predict(f) == c) > 0.97
    assert ForceThreshold(k=3).fit(f, c).k_ == 3


@pytest.mark.parametrize("args, message, code", [
    (["--label-map", "1=free,2"], "--label-map: entry 2 '2' is not LABEL=NODE", 2),
    (["--label-map", "1=free,1=contact"], "label '1' mapped twice", 2),
    (["--label-map", "1=table"], "--label-map: 1=table: 'table' is not a node or trained "
                                 "label", 2),
    (["--label-map", "1=free;2=contact"], "separate the entries with commas, not ';'", 2),
    (["--label-map", "x=free,y=contact"], "--label-map maps none of the recording's labels "
                                          "(its labels: 0, 1, 2", 1),
    (["--label-map", "one=free,2=contact"], "--label-map entries matching no label: one", 1),
])
def test_bad_label_map_is_one_line(tmp_path, args, message, code):
    """Malformed maps and misspelt node names are usage errors (exit 2); maps that name no
    label of the recording, or leave a node untrained because an entry matches nothing, name
    the archive (exit 1)."""
    train = _archive(tmp_path, "rec1", 11, 100.0)
    r = run_cli("train", train, "--graph", "free-contact", *args, "--out", tmp_path / "m.h5")
    assert r.exit_code == code
    assert message in r.output
    assert len(r.output.strip().splitlines()) == 1 and "Traceback" not in r.output


def test_recognize_refuses_a_label_map_matching_no_label(tmp_path):
    train = _archive(tmp_path, "rec1", 11, 100.0)
    test = _archive(tmp_path, "rec2", 12, 100.0)
    r = run_cli("train", train, "--graph", "free-contact", "--label-map", MAP,
                "--out", tmp_path / "m.h5")
    assert r.exit_code == 0, r.output
    r = run_cli("recognize", test, "--graph", "free-contact", "--models", tmp_path / "m.h5",
                "--label-map", "x=free", "--no-write")
    assert r.exit_code == 1
    assert "rec2.h5" in r.output and "maps none of the recording's labels" in r.output


def test_bad_graph_constraint_is_one_line(tmp_path):
    g = tmp_path / "g.toml"
    g.write_text('[models.C]\nkind = "constraint"\nconstraint = "W"\n'
                 '[[nodes]]\nname = "a"\nmodels = "C"\ninitial = 1.0\n')
    train = _archive(tmp_path, "rec1", 11, 100.0)
    r = run_cli("train", train, "--graph", g, "--out", tmp_path / "m.h5")
    assert r.exit_code != 0
    assert "g.toml" in r.output and "models.C.constraint" in r.output
    assert len(r.output.strip().splitlines()) == 1


def test_graph_sides_is_validated_and_used_by_default():
    from contactlab.errors import DataError
    from contactlab.observer import parse_graph

    doc = {"models": {"C": {"kind": "constraint", "constraint": "0"}},
           "nodes": [{"name": "a", "models": "C", "initial": 1.0}]}
    assert parse_graph(doc).sides is None
    assert parse_graph({**doc, "sides": "both"}).sides == "both"
    with pytest.raises(DataError, match="sides"):
        parse_graph({**doc, "sides": "sideways"})


def test_explain_runs_on_the_constraint_and_velocity_models(tmp_path):
    """recognize --explain on a free-contact recording: its models give a chi-square
    only (no innovation sum), which the explanation reads like the observer does."""
    train = _archive(tmp_path, "quiet", 11, 100.0)
    test = _archive(tmp_path, "other", 13, 100.0)
    models = tmp_path / "m.h5"
    r = run_cli("train", train, "--graph", "free-contact", "--label-map", MAP,
                "--out", models, "-q")
    assert r.exit_code == 0, r.output
    with open_archive(test) as a:
        tid = a.trial_ids[0]
    r = run_cli("recognize", test, "--graph", "free-contact", "--models", models, "-q",
                "--label-map", MAP, "--no-write", "--explain", tid)
    assert r.exit_code == 0, r.output
    assert "points marked correctly" in r.stdout
    assert re.search(r"detector (C0|C1|CI|M)/increase: [-0-9.]+ at the change", r.stdout)


def test_label_map_entries_matching_no_label_are_noted(tmp_path):
    """A map entry whose label no trial carries (a typo, another recording's label) is
    named on stderr by train, recognize, segment and graph learn, and in --json; the models'
    own map read into another archive is noted too."""
    train = _archive(tmp_path, "rec1", 11, 100.0)
    test = _archive(tmp_path, "rec2", 12, 100.0)
    odd = MAP + ",7=contact"
    want = "no trial of {} carries the label of 7=contact (their labels: "
    r = run_cli("train", train, "--graph", "free-contact", "--label-map", odd,
                "--out", tmp_path / "m.h5")
    assert r.exit_code == 0 and "note: --label-map: " + want.format("rec1.h5") in r.stderr
    r = run_cli("train", train, "--graph", "free-contact", "--label-map", odd,
                "--out", tmp_path / "m.h5", "--force", "--json")
    assert any(want.format("rec1.h5") in n for n in one_json_object(r.stdout)["notes"])
    r = run_cli("recognize", test, "--graph", "free-contact", "--models", tmp_path / "m.h5",
                "--label-map", odd, "--no-write")
    assert r.exit_code == 0 and want.format("rec2.h5") in r.stderr
    r = run_cli("segment", test, "--label-map", odd, "--no-write", "--tolerance", "0.25")
    assert r.exit_code == 0 and want.format("rec2.h5") in r.stderr
    r = run_cli("graph", "learn", train, "--label-map", odd, "--out", tmp_path / "g.toml")
    assert r.exit_code == 0 and want.format("rec1.h5") in r.stderr
    # the map as it should be: no note
    r = run_cli("recognize", test, "--graph", "free-contact", "--models", tmp_path / "m.h5",
                "--label-map", MAP, "--no-write")
    assert r.exit_code == 0 and "note: --label-map" not in r.stderr
    # without --label-map, another recording of the same labels: no note; one whose labels
    # the training never saw: the models' map is named
    r = run_cli("recognize", test, "--graph", "free-contact", "--models", tmp_path / "m.h5",
                "--no-write")
    assert r.exit_code == 0 and "note:" not in r.stderr
    with h5py.File(test, "a") as f:
        lab = f["trials/rec2/ground_truth/labels"]
        lab[-50:] = 4                                  # a label rec1's trials lack
        names = list(lab.attrs["names"])
        if "4" not in [str(n) for n in names]:
            lab.attrs["names"] = names + ["4"]
    r = run_cli("recognize", test, "--graph", "free-contact", "--models", tmp_path / "m.h5",
                "--no-write")
    assert r.exit_code == 0, r.output
    assert "labels read through the models' label map" in r.stderr
    assert "rec1.h5, whose trials had no label 4" in r.stderr
