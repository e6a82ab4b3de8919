"""CSV import: round trips, label handling, one-line errors naming file and column."""

from __future__ import annotations

import json
import re

import numpy as np
import pandas as pd
import pytest
from conftest import synthetic_measurements

from contactlab.archive import import_csv, open_archive, parse_column_map, validate_archive
from contactlab.errors import DataError, UsageError

WRENCH = ["fx", "fy", "fz", "tx", "ty", "tz"]
MAP = "time=t; wrench=fx,fy,fz,tx,ty,tz; position=x,y,z; strain=s*; labels=state; action=act"


def write_csv(path, n=400, *, rate_hz=500.0, seed=0, states=("rest", "press", "slide")):
    data = synthetic_measurements(n, rate_hz=rate_hz, seed=seed)
    frame = pd.DataFrame({"t": data["time"]})
    frame[WRENCH] = data["wrench"]
    frame[["x", "y", "z"]] = data["position"]
    for i in range(8):
        frame[f"s{i}"] = data["strain"][:, i]
    frame["act"] = data["action"]
    labels = np.array([states[min(i * len(states) // n, len(states) - 1)] for i in range(n)],
                      dtype=object)
    labels[:5] = None  # unlabelled rows
    frame["state"] = labels
    frame["note"] = "x"
    frame.to_csv(path, index=False)
    return data, labels


def test_round_trip_with_string_labels(tmp_path):
    a, labels_a = write_csv(tmp_path / "run-a.csv", seed=1, states=("rest", "press"))
    b, labels_b = write_csv(tmp_path / "run-b.csv", seed=2, states=("slide", "press", "rest"))
    out = import_csv([tmp_path / "run-a.csv", tmp_path / "run-b.csv"], out=tmp_path / "o.h5",
                     columns=parse_column_map(MAP), controller="phantom-force",
                     environment="plane", quiet=True)
    assert out == tmp_path / "o.h5"
    assert validate_archive(out) == []
    with open_archive(out) as archive:
        assert archive.trial_ids == ["run-a", "run-b"]
        for tid, data, labels in (("run-a", a, labels_a), ("run-b", b, labels_b)):
            trial = archive.trial(tid)
            assert trial.label_names == ["rest", "press", "slide"]  # order of first appearance
            assert trial.rate_hz == pytest.approx(500.0, rel=1e-9)
            assert trial.attrs["source"] == "import"
            assert trial.attrs["controller"] == "phantom-force"
            assert trial.attrs["environment"] == "plane"
            for field in ("time", "wrench", "position", "strain"):
                np.testing.assert_allclose(getattr(trial, field), data[field], rtol=1e-15,
                                           atol=0)
            np.testing.assert_array_equal(trial.action, data["action"])
            names = trial.label_names
            decoded = [None if c < 0 else names[c] for c in trial.labels]
            assert decoded == list(labels)


def test_integer_labels_without_time_column(tmp_path):
    csv = tmp_path / "r.csv"
    pd.DataFrame({"w" + str(i): np.arange(6.0) * i for i in range(6)} |
                 {"lab": [0, 0, 1, 2, np.nan, 1]}).to_csv(csv, index=False)
    out = import_csv([csv], out=tmp_path / "o.h5", rate_hz=250.0, quiet=True,
                     columns={"wrench": ["w*"], "labels": "lab"},
                     label_names=["free", "touch", "slide"])
    assert validate_archive(out) == []
    with open_archive(out) as archive:
        trial = archive.trial("r")
        np.testing.assert_allclose(trial.time, np.arange(6) / 250.0)
        np.testing.assert_array_equal(trial.labels, [0, 0, 1, 2, -1, 1])
        assert trial.label_names == ["free", "touch", "slide"]
        np.testing.assert_array_equal(trial.wrench[:, 2], np.arange(6.0) * 2)


def test_integer_labels_get_numeric_names(tmp_path):
    csv = tmp_path / "r.csv"
    pd.DataFrame({"t": np.arange(4) / 100, "fx": 1.0, "fy": 2.0, "fz": 3.0, "tx": 0.0,
                  "ty": 0.0, "tz": 0.0, "lab": [2, 0, 0, 1]}).to_csv(csv, index=False)
    out = import_csv([csv], out=tmp_path / "o.h5", quiet=True,
                     columns={"time": "t", "wrench": "fx,fy,fz,tx,ty,tz", "labels": "lab"})
    with open_archive(out) as archive:
        assert archive.trial("r").label_names == ["0", "1", "2"]
        np.testing.assert_array_equal(archive.trial("r").labels, [2, 0, 0, 1])


def _csv(tmp_path, text, name="r.csv"):
    path = tmp_path / name
    path.write_text(text)
    return path


HEADER = "t,fx,fy,fz,tx,ty,tz\n"


@pytest.mark.parametrize("text, columns, kwargs, field, fragment", [
    (HEADER.replace(",fz", "") + "0,1,2,3,4,5\n", "time=t;wrench=fx,fy,fz,tx,ty,tz", {}, "fz",
     "no such column"),
    (HEADER + "0,1,2,3,4,5,6\n", "time=t;wrench=fx,fy,fz,tx,ty,tz;strain=g*", {}, "g*",
     "no such column"),
    (HEADER + "0,1,2,3,4,5,6\n0.1,1,2,3,4,5,6\n", "time=t;wrench=fx,fy,fz,tx,ty", {}, "wrench",
     "needs 6 columns"),
    (HEADER + "0,1,2,3,4,5,6\n0.1,1,oops,3,4,5,6\n", "time=t;wrench=f*,t[xyz]", {}, "fy",
     "1 empty or non-numeric cell (first: data row 2, line 3 of the file, 'oops')"),
    (HEADER + "0,1,2,3,4,5,6\n0.1,1,,3,4,5,6\n", "time=t;wrench=f*,t[xyz]", {}, "fy",
     "1 empty or non-numeric cell (first: data row 2, line 3 of the file, empty)"),
    (HEADER + "0,1,2,3,4,5,6\n0.1,inf,2,3,4,5,6\n", "time=t;wrench=f*,t[xyz]", {}, "fx",
     "(first: data row 2, line 3 of the file, inf)"),
    (HEADER + "0,1,2,3,4,5,6\n0.1,1\n", "time=t;wrench=f*,t[xyz]", {}, "fy",
     "data row 2 ends after 2 of 7 fields"),
    (HEADER + "0.1,1,2,3,4,5,6\n0.1,1,2,3,4,5,6\n", "time=t;wrench=f*,t[xyz]", {}, "t",
     "time is not strictly increasing (data row 2, 0.1 s, repeats the time stamp 0.1 s of "
     "data row 1; 1 such row): give --repair-time"),
    (HEADER + "0,1,2,3,4,5,6\n0.1,1,2,3,4,5,6\n", "time=t;wrench=f*,t[xyz]",
     {"rate_hz": 100.0}, "t", "disagrees with the given rate 100 Hz"),
    ("t,fx,fy,fz,tx,ty,tz,lab\n0,1,2,3,4,5,6,0\n0.1,1,2,3,4,5,6,1\n",
     "time=t;wrench=f*,t*;labels=lab", {"label_names": ["a"]}, "lab", "label code 1 has no name"),
    ("t,fx,fy,fz,tx,ty,tz,s\n0,1,2,3,4,5,6,down\n1,1,2,3,4,5,6,up\n",
     "time=t;wrench=f*,t[xyz];labels=s",
     {"label_names": ["down"]}, "s", "label 'up' is not one of the label names"),
])
def test_bad_csv_is_one_data_error_naming_file_and_column(tmp_path, text, columns, kwargs,
                                                          field, fragment):
    csv = _csv(tmp_path, text)
    out = tmp_path / "o.h5"
    with pytest.raises(DataError) as err:
        import_csv([csv], out=out, columns=parse_column_map(columns), quiet=True, **kwargs)
    assert err.value.file == str(csv) and err.value.field == field
    assert fragment in err.value.message
    assert str(err.value) == f"{csv}: {field}: {err.value.message}"
    assert "\n" not in str(err.value)
    assert not out.exists()


def test_a_failure_in_a_later_file_leaves_no_archive(tmp_path):
    write_csv(tmp_path / "good.csv", n=50)
    bad = _csv(tmp_path, HEADER + "0,1,2,3,4,5,6\n", "bad.csv")
    out = tmp_path / "o.h5"
    with pytest.raises(DataError, match="no such column"):
        import_csv([tmp_path / "good.csv", bad], out=out, quiet=True,
                   columns=parse_column_map(MAP))
    assert sorted(p.name for p in tmp_path.iterdir()) == ["bad.csv", "good.csv"]


def test_import_refuses_to_overwrite_unless_forced(tmp_path):
    write_csv(tmp_path / "r.csv", n=30)
    out = tmp_path / "o.h5"
    out.write_text("keep me")
    with pytest.raises(DataError, match="exists"):
        import_csv([tmp_path / "r.csv"], out=out, columns=parse_column_map(MAP), quiet=True)
    assert out.read_text() == "keep me"
    import_csv([tmp_path / "r.csv"], out=out, columns=parse_column_map(MAP), quiet=True,
               force=True)
    assert validate_archive(out) == []


def test_parse_column_map_text_and_json_file(tmp_path):
    assert parse_column_map(" time = t ; wrench=fx, fy,fz,tx,ty,tz;strain=s* ") == {
        "time": ["t"], "wrench": WRENCH, "strain": ["s*"]}
    spec_file = tmp_path / "cols.json"
    spec_file.write_text(json.dumps({"time": "t", "wrench": WRENCH}))
    assert parse_column_map(str(spec_file)) == {"time": ["t"], "wrench": WRENCH}


@pytest.mark.parametrize("text, fragment", [
    ("time=t", "needs strain, wrench or position"),
    ("time=t;force=fx", "unknown field 'force'"),
    ("time;wrench=fx", "is not FIELD=COLUMN"),
    ("time=t,u;wrench=fx", "takes exactly one column"),
    ("wrench=a;wrench=b", "names field 'wrench' twice"),
    ("", "column map is empty"),
])
def test_parse_column_map_rejects_bad_maps(text, fragment):
    with pytest.raises(UsageError, match=fragment):
        parse_column_map(text)


@pytest.mark.parametrize("content, field, fragment", [
    ("5", None, "not int"),
    ("null", None, "not null"),
    ('{"time": 5, "wrench": "fx"}', "time", "not 5"),
    ('{"time": null, "wrench": "fx"}', "time", "not null"),
    ('{"time": "t", "wrench": ["fx", null]}', "wrench", 'not ["fx", null]'),
    ('{"time": "t", "force": "fx"}', "force", "unknown field"),
    ('{"time": "t"}', None, "needs strain, wrench or position"),
    (None, None, "cannot be read (No such file or directory)"),
])
def test_a_bad_column_map_file_is_bad_data_naming_the_file_and_the_field(tmp_path, content,
                                                                         field, fragment):
    """The README's rule: a mistake in a file exits 1 naming the file and the field, the
    same mistake typed on the command line exits 2 naming the option."""
    from test_bad_input_corpus import assert_one_line_error, run

    path = tmp_path / "cols.json"
    if content is not None:
        path.write_text(content)
    csv = tmp_path / "run.csv"
    csv.write_text("t,fx\n0,1\n0.001,2\n")
    res = run("import", csv, "--out", tmp_path / "o.h5", "--columns", path)
    line = assert_one_line_error(res, path, field and f"{path}: {field}: ", code=1)
    assert fragment in line, line
    res = run("import", csv, "--out", tmp_path / "o.h5", "--columns", "time=t;force=fx")
    assert res.exit_code == 2 and "--columns" in res.stderr
    assert not (tmp_path / "o.h5").exists()


def test_labels_give_ground_truth_segments_runs_of_equal_labels(tmp_path):
    from contactlab.archive import import_csv, open_archive, validate_archive

    labels = ["free"] * 3 + ["contact"] * 4 + [""] * 2 + ["contact"] * 2 + ["free"]
    rows = ["t,fx,state"] + [f"{0.01 * i:.2f},{i},{lab}" for i, lab in enumerate(labels)]
    (tmp_path / "run.csv").write_text("\n".join(rows) + "\n")
    out = import_csv([tmp_path / "run.csv"], out=tmp_path / "a.h5",
                     columns={"time": "t", "labels": "state", "strain": "fx"}, quiet=True)
    with open_archive(out) as archive:
        seg = archive.trial("run").segments
    # hand-written runs: [0, 3) free, [3, 7) contact, 7-8 unlabelled, [9, 11) contact, [11] free
    assert seg["label"].tolist() == ["free", "contact", "contact", "free"]
    assert seg["start_s"].round(9).tolist() == [0.0, 0.03, 0.09, 0.11]
    assert seg["end_s"].round(9).tolist() == [0.03, 0.07, 0.11, 0.12]
    assert validate_archive(out) == []


def test_imported_labels_drive_estimate_by_truth_and_segment_scoring(tmp_path):
    """A user's labelled recording: slide along x, then along y, on the z = 0 plane,
    wiggling across the slide so that the plane is explored (9.1.2)."""
    import pandas as pd
    from conftest import one_json_object, run_cli

    rng = np.random.default_rng(0)
    n = 3000
    t = np.arange(n) / 1000.0
    first = t < 1.5
    wiggle = 0.002 * np.sin(2 * np.pi * 1.5 * t)
    frame = pd.DataFrame({
        "t": t, "fx": 0.05 * rng.normal(size=n), "fy": 0.05 * rng.normal(size=n),
        "fz": -5 + 0.05 * rng.normal(size=n), "tx": 0.0, "ty": 0.0, "tz": 0.0,
        "x": np.where(first, 0.05 * t, 0.075 + wiggle) + 1e-5 * rng.normal(size=n),
        "y": np.where(first, wiggle, 0.05 * (t - 1.5)) + 1e-5 * rng.normal(size=n),
        "z": 1e-5 * rng.normal(size=n), "state": np.where(first, "slide-x", "slide-y")})
    frame.to_csv(tmp_path / "run.csv", index=False)
    out = tmp_path / "a.h5"
    r = run_cli("import", tmp_path / "run.csv", "--out", out, "--quiet", "--columns",
                "time=t;wrench=fx,fy,fz,tx,ty,tz;position=x,y,z;labels=state")
    assert r.exit_code == 0, r.output
    r = run_cli("estimate", out, "--segments", "truth", "--json", "--quiet")
    assert r.exit_code == 0, r.output
    rows = one_json_object(r.stdout)["trials"]["run"]["segments"]
    assert [row["label"] for row in rows] == ["slide-x", "slide-y"]
    assert [row["degree"] for row in rows] == [1, 1]          # one plane, explored
    for row in rows:
        assert abs(abs(row["normals"][0][2]) - 1.0) < 1e-3      # its normal is z
    r = run_cli("segment", out, "--signal", "wrench", "--json", "--quiet")
    assert r.exit_code == 0, r.output
    assert one_json_object(r.stdout)["metrics"]["overall"]["n_true"] == 1


@pytest.mark.parametrize("sep, decimal_comma", [(";", True), (";", False), ("\t", False),
                                                 (" ", False), ("|", False)])
def test_other_delimiters_read_the_same_numbers(tmp_path, sep, decimal_comma):
    # the same table written with another delimiter (and decimal commas, as spreadsheets
    # of many locales export) imports to the values of the comma file
    write_csv(tmp_path / "ref.csv", seed=3)
    frame = pd.read_csv(tmp_path / "ref.csv").drop(columns=["note", "state"])
    text = frame.to_csv(sep=sep, index=False, float_format="%.9g")
    if decimal_comma:
        text = re.sub(r"(\d)\.(\d)", r"\1,\2", text)
    (tmp_path / "other.csv").write_text(text)
    cmap = parse_column_map(MAP.replace("; labels=state", "").replace("s*", "s[0-7]"))
    ref = import_csv([tmp_path / "ref.csv"], out=tmp_path / "a.h5", columns=cmap, quiet=True)
    got = import_csv([tmp_path / "other.csv"], out=tmp_path / "b.h5", columns=cmap, quiet=True)
    with open_archive(ref) as a, open_archive(got) as b:
        ta, tb = a.trial("ref"), b.trial("other")
        for field in ("time", "wrench", "position", "strain", "action"):
            np.testing.assert_allclose(getattr(tb, field), getattr(ta, field), rtol=1e-8)


def test_a_delimiter_that_is_not_the_files_is_a_one_line_error(tmp_path):
    write_csv(tmp_path / "run.csv")
    with pytest.raises(DataError, match="run.csv"):
        import_csv([tmp_path / "run.csv"], out=tmp_path / "o.h5", columns=parse_column_map(MAP),
                   delimiter="tab", quiet=True)
    with pytest.raises(UsageError, match="unknown delimiter"):
        import_csv([tmp_path / "run.csv"], out=tmp_path / "o.h5", columns=parse_column_map(MAP),
                   delimiter="#", quiet=True)


def test_a_wrong_delimiter_names_the_one_the_file_has(tmp_path):
    write_csv(tmp_path / "run.csv")
    with pytest.raises(DataError, match="looks comma-separated") as err:
        import_csv([tmp_path / "run.csv"], out=tmp_path / "o.h5", columns=parse_column_map(MAP),
                   delimiter="semicolon", quiet=True)
    assert err.value.field == "--delimiter"


def test_mixed_label_kinds_name_both_files(tmp_path):
    write_csv(tmp_path / "named.csv")
    write_csv(tmp_path / "coded.csv", states=(1, 2))
    with pytest.raises(DataError, match="named.csv has names, coded.csv integer codes"):
        import_csv([tmp_path / "named.csv", tmp_path / "coded.csv"], out=tmp_path / "o.h5",
                   columns=parse_column_map(MAP), quiet=True)
