"""What a new user reads: bundled graph names, label-map hints, --no-write for segment,
counts in the right number, train's wording."""

from __future__ import annotations

import numpy as np
import pandas as pd

from contactlab.archive import open_archive
from contactlab.cli.common import count
from contactlab.synthetic.free_contact import free_contact_recording

from conftest import one_json_object, run_cli


def test_count_says_one_in_the_singular_and_takes_irregular_plurals():
    assert count(1, "channel") == "1 channel" and count(0, "channel") == "0 channels"
    assert count(1, "boundary", "boundaries") == "1 boundary"
    assert count(3, "boundary", "boundaries") == "3 boundaries"


def test_misspelt_bundled_graph_is_a_usage_error(archive_path, tmp_path):
    r = run_cli("train", archive_path, "--graph", "free-contct", "--out", tmp_path / "m.h5")
    assert r.exit_code == 2
    assert "no bundled graph 'free-contct' (did you mean free-contact?)" in r.output
    assert "Traceback" not in r.output
    r = run_cli("train", archive_path, "--graph", tmp_path / "mine.toml", "--out",
                tmp_path / "m.h5")
    assert r.exit_code == 1 and "mine.toml: no such file" in r.output


def test_segment_no_write_prints_and_leaves_the_archive(archive_path):
    r = run_cli("segment", archive_path, "--signal", "wrench", "--no-write", "-q")
    assert r.exit_code == 0, r.output
    assert "results written" not in r.output and "t01: " in r.output
    with open_archive(archive_path) as archive:
        assert all(t.result_stages() == [] for t in archive)
    r = run_cli("segment", archive_path, "--signal", "wrench", "--no-write", "--json", "-q")
    assert r.exit_code == 0 and "trials" in one_json_object(r.stdout)


def _integer_labelled(tmp_path):
    """A recording whose labels are integer codes with 0 for unlabelled samples."""
    cols = pd.DataFrame(free_contact_recording(seed=3, fs=100.0, cycles=2).csv_columns())
    cols.loc[: len(cols) // 10, "state"] = 0
    cols.to_csv(tmp_path / "rec.csv", index=False)
    r = run_cli("import", tmp_path / "rec.csv", "--out", tmp_path / "rec.h5", "-q",
                "--columns", "time=t;wrench=fx,fy,fz,tx,ty,tz;position=x,y,z;labels=state")
    assert r.exit_code == 0, r.output
    return tmp_path / "rec.h5"


def test_label_map_hint_never_suggests_label_0_and_train_names_what_it_fitted(tmp_path):
    rec = _integer_labelled(tmp_path)
    r = run_cli("train", rec, "--graph", "free-contact", "--out", tmp_path / "m.h5", "-q")
    assert r.exit_code == 1 and "labels: 0, 1, 2, 3" in r.output
    assert '--label-map "1=' in r.output and '"0=' not in r.output
    r = run_cli("train", rec, "--graph", "free-contact", "--out", tmp_path / "m.h5", "-q",
                "--label-map", "1=free,2=contact,3=free")
    assert r.exit_code == 0, r.output
    lines = r.output.splitlines()
    free = next(x for x in lines if x.startswith("free: constraint"))
    assert free.startswith("free: constraint degree 0 (normals none), signal contact-compensated, from ")
    assert free.endswith(" labelled free")
    assert " on contact" not in r.output


def test_an_impact_node_without_labels_of_its_own_keeps_the_stated_limit(tmp_path):
    """free-contact's impact model is trained on the contact's labels; the node itself is
    never labelled, so training records no duration for it and recognize holds it at
    most the stated default (not the longest contact)."""
    from contactlab.defaults import OBSERVER_TRANSIENT_MAX_S
    from contactlab.observer import load_graph
    from contactlab.observer.recognize import transient_limits
    from contactlab.observer.training import GraphModels

    rec = _integer_labelled(tmp_path)
    r = run_cli("train", rec, "--graph", "free-contact", "--out", tmp_path / "m.h5", "-q",
                "--label-map", "1=free,2=contact,3=free")
    assert r.exit_code == 0, r.output
    models = GraphModels.load(tmp_path / "m.h5")
    assert models.provenance["transient_longest_s"] == {}
    assert transient_limits(load_graph("free-contact"), models) == {
        "impact": OBSERVER_TRANSIENT_MAX_S}
