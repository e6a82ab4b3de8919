"""recognize on a user's recording: the path as CSV (--csv), and models whose label map
names none of a recording's labels (recognised, accuracy skipped with a note)."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from contactlab.archive import open_archive
from contactlab.export import boundaries_path, boundary_table, sample_table
from contactlab.synthetic.free_contact import free_contact_recording

from conftest import one_json_object, run_cli

COLUMNS = "time=t;wrench=fx,fy,fz,tx,ty,tz;position=x,y,z;labels=state"


def _import(tmp_path, name, seed, names=None):
    cols = pd.DataFrame(free_contact_recording(seed=seed, fs=100.0, cycles=3).csv_columns())
    if names is not None:
        cols["state"] = [names[c - 1] for c in cols["state"]]
    cols.to_csv(tmp_path / f"{name}.csv", index=False)
    r = run_cli("import", tmp_path / f"{name}.csv", "--out", tmp_path / f"{name}.h5",
                "--columns", COLUMNS, "-q")
    assert r.exit_code == 0, r.output
    return tmp_path / f"{name}.h5"


@pytest.fixture(scope="module")
def trained(tmp_path_factory):
    root = tmp_path_factory.mktemp("export")
    train = _import(root, "rec1", 11)
    r = run_cli("train", train, "--graph", "free-contact", "--label-map",
                "1=free,2=contact,3=free", "--out", root / "m.h5", "-q")
    assert r.exit_code == 0, r.output
    return root


def test_csv_holds_the_path_per_sample_and_its_boundaries(trained, tmp_path):
    test = _import(tmp_path, "rec2", 12)
    out = tmp_path / "path.csv"
    args = ["recognize", test, "--graph", "free-contact", "--models", trained / "m.h5",
            "--no-write", "--csv", out, "-q"]
    r = run_cli(*args, "--json")
    assert r.exit_code == 0, r.output
    summary = one_json_object(r.stdout)
    samples = pd.read_csv(out)
    bounds = pd.read_csv(boundaries_path(out))
    assert boundaries_path(out) == tmp_path / "path-boundaries.csv"
    assert summary["csv"] == [str(out), str(boundaries_path(out))]
    assert list(samples.columns) == ["trial", "time_s", "node", "node_prob", "p_free",
                                     "p_contact", "p_impact"]
    assert list(bounds.columns) == ["trial", "time_s", "from", "to"]
    assert set(samples["trial"]) == {"rec2"}
    assert np.all(np.diff(samples["time_s"]) > 0)
    p = samples[["p_free", "p_contact", "p_impact"]].to_numpy()
    np.testing.assert_allclose(p.sum(axis=1), 1.0, atol=1e-6)
    picked = p[np.arange(len(p)), samples["node"].map(
        {"free": 0, "contact": 1, "impact": 2}).to_numpy()]
    np.testing.assert_allclose(samples["node_prob"], picked, atol=1e-9)
    # the boundaries are the path's changes, and the JSON's merged path says the same
    merged = summary["trials"]["rec2"]["merged_path"]
    assert [[b["to"], pytest.approx(b["time_s"], abs=1e-6)] for _, b in bounds.iterrows()] \
        == merged[1:]
    assert list(bounds["from"][1:]) == list(bounds["to"][:-1])
    with open_archive(test) as archive:   # --no-write: the archive is left as it was
        assert archive.trial("rec2").result_stages() == []
    # no overwrite without --force; nothing is computed first
    r = run_cli(*args)
    assert r.exit_code == 1 and "path.csv: exists; pass --force" in r.output
    r = run_cli(*args, "--force")
    assert r.exit_code == 0 and "recognised path written to" in r.output
    r = run_cli("recognize", test, "--graph", "free-contact", "--models", trained / "m.h5",
                "--force")
    assert r.exit_code == 2 and "--force goes with --csv" in r.output


def test_tables_from_codes():
    labels = np.array([0, 0, 1, 1, 1, 0])
    prob = np.tile([[0.75, 0.25]], (6, 1))
    s = sample_table("a", np.arange(6) * 0.1, labels, prob, ["free", "contact"])
    assert list(s["node"]) == ["free", "free", "contact", "contact", "contact", "free"]
    assert list(s["node_prob"]) == [0.75, 0.75, 0.25, 0.25, 0.25, 0.75]
    b = boundary_table("a", np.arange(6) * 0.1, labels, ["free", "contact"])
    assert b.to_dict("list") == {"trial": ["a", "a"], "time_s": [0.2, 0.5],
                                 "from": ["free", "contact"], "to": ["contact", "free"]}


def test_models_label_map_naming_none_of_the_labels_skips_the_accuracy(trained, tmp_path):
    other = _import(tmp_path, "named", 12, names=("air", "touch", "air"))
    r = run_cli("recognize", other, "--graph", "free-contact", "--models", trained / "m.h5",
                "--no-write", "--json", "-q")
    assert r.exit_code == 0, r.output
    out = one_json_object(r.stdout)
    assert out["accuracy"] is None and out["trials"]["named"]["accuracy"] is None
    assert out["trials"]["named"]["merged_path"][0][0] == "free"
    note = ("note: " + str(other) + ": trial named: the models' label map (1=free,2=contact,"
            "3=free) names none of its labels (air, touch); no accuracy")
    assert note in r.stderr and "Traceback" not in r.stderr
    # mapped for this run: the accuracy is back
    r = run_cli("recognize", other, "--graph", "free-contact", "--models", trained / "m.h5",
                "--no-write", "--json", "-q", "--label-map", "air=free,touch=contact")
    assert r.exit_code == 0 and one_json_object(r.stdout)["accuracy"] > 0.8
    # a map given for this run that names none of them is still an error
    r = run_cli("recognize", other, "--graph", "free-contact", "--models", trained / "m.h5",
                "--no-write", "-q", "--label-map", "1=free")
    assert r.exit_code == 1 and "maps none of the recording's labels" in r.output
