"""The bad-input corpus run against every verb that reads it.

Each case asserts the exit status, exactly one line on stderr naming the file
and the field, no "internal error", and the input bit-identical afterwards.
Archives are broken in the test run (``tests/corpus.py``); nothing binary is
committed.
"""

from __future__ import annotations

import hashlib
import shutil

import h5py
import numpy as np
import pytest
from click.testing import CliRunner
from conftest import write_archive
from corpus import ARCHIVE_CASES, T, with_h5

from contactlab.archive import validate_archive
from contactlab.cli import main

GRAPH = "datasets_spec/graphs/hf-context-free.toml"


def run(*args):
    return CliRunner().invoke(main, [str(a) for a in args])


def digest(path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def assert_one_line_error(res, *names, code=1):
    """Exit ``code``, one stderr line naming every one of ``names``, no internal error."""
    lines = res.stderr.strip().splitlines()
    assert res.exit_code == code, (res.exit_code, res.stderr, res.exception)
    assert len(lines) == 1, res.stderr
    assert lines[0].startswith("contactlab"), lines
    assert "internal error" not in lines[0] and "Traceback" not in res.stderr
    for name in names:
        if name is not None:
            assert str(name) in lines[0], (name, lines[0])
    return lines[0]


@pytest.fixture(scope="module")
def base(tmp_path_factory):
    path = tmp_path_factory.mktemp("corpus") / "base.h5"
    write_archive(path, n=1500)
    return path


@pytest.fixture(scope="module")
def models(base, tmp_path_factory):
    out = tmp_path_factory.mktemp("models") / "m.h5"
    res = run("train", base, "--out", out, "--block", 20, "--order", 1, "-q")
    assert res.exit_code == 0, res.output
    return out


@pytest.fixture(scope="module")
def fc_models(base, tmp_path_factory):
    out = tmp_path_factory.mktemp("fc") / "fc.h5"
    res = run("train", base, "--graph", "free-contact", "--label-map",
              "free=free,contact=contact,sliding=contact", "--out", out, "-q")
    assert res.exit_code == 0, res.output
    return out


def reading_verbs(tmp_path, fc_models):
    """Every verb that reads an archive, with the options it needs.  Other inputs may be
    missing where the whole archive is checked before anything else is read; recognize
    checks the archive's layout up front and each trial's values where the trial is
    read, after its models file, so it is given one."""
    return {
        "info": [], "segment": ["-q"], "train": ["--out", tmp_path / "out.h5", "-q"],
        "label": ["--models", tmp_path / "m.h5", "-q"], "estimate": ["-q"],
        "recognize": ["--graph", "free-contact", "--models", fc_models, "-q"],
        "report": ["--out", tmp_path / "rep", "-q"],
    }


@pytest.mark.parametrize("case", ARCHIVE_CASES, ids=[c[0] for c in ARCHIVE_CASES])
def test_every_verb_names_file_and_field_and_leaves_the_archive_alone(case, base, tmp_path,
                                                                     fc_models):
    _, mutate, field, fragment = case
    path = tmp_path / "case.h5"
    shutil.copy(base, path)
    mutate(path)
    before = digest(path)
    res = run("validate", path)
    assert res.exit_code == 1 and "internal error" not in res.output
    assert fragment in res.stdout + res.stderr
    assert field is None or field in res.stdout
    assert_one_line_error(res, path)
    for verb, extra in reading_verbs(tmp_path, fc_models).items():
        res = run(verb, path, *extra)
        line = assert_one_line_error(res, path, field)
        assert fragment in line, (verb, line)
    assert digest(path) == before
    assert not (tmp_path / "out.h5").exists() and not (tmp_path / "rep").exists()


def test_checks_cover_only_the_selected_trials(base, tmp_path):
    path = tmp_path / "one-bad.h5"
    shutil.copy(base, path)
    with_h5(lambda f: f["/trials/t02/measurements/strain"].__setitem__((0, 0), np.nan))(path)
    assert validate_archive(path, trials=["t01"]) == []
    assert [p.path for p in validate_archive(path)] == ["/trials/t02/measurements/strain"]
    res = run("train", path, "--trial", "t02", "--out", tmp_path / "m.h5", "-q")
    assert_one_line_error(res, path, "/trials/t02/measurements/strain")
    res = run("segment", path, "--trial", "t09", "-q")
    assert_one_line_error(res, path, "/trials/t09", "no such trial")


def test_a_lock_is_not_blamed_for_a_corrupt_superblock(base, tmp_path):
    from contactlab.archive.reader import h5_reason

    assert "locked" not in h5_reason(OSError("bad superblock version number"))
    assert "locked" in h5_reason(OSError("unable to lock file, errno = 11"))


# -- models and graph files --------------------------------------------------------------

def _models_attr(models, tmp_path, name, value):
    path = tmp_path / f"models-{name}.h5"
    shutil.copy(models, path)
    with h5py.File(path, "r+") as f:
        f.attrs[name] = value
    return path


@pytest.mark.parametrize("name,value,fragment", [
    ("signal", "telepathy", "unknown signal"),
    ("fs", -250.0, "> 0"),
    ("fs", 0.0, "> 0"),
    ("fs", np.nan, "> 0"),
    ("fs", "fast", "> 0"),
])
def test_malformed_models_file(base, models, tmp_path, name, value, fragment):
    bad = _models_attr(models, tmp_path, name, value)
    before = digest(base)
    for verb, extra in (("label", []), ("recognize", ["--graph", GRAPH])):
        res = run(verb, base, "--models", bad, *extra, "-q")
        line = assert_one_line_error(res, bad, f"/{name}")
        assert fragment in line
    assert digest(base) == before


def test_graph_with_an_unknown_signal(base, models, tmp_path):
    graph = tmp_path / "tele.toml"
    text = open(GRAPH, encoding="utf-8").read()
    graph.write_text(text.replace('signal = "hf"', 'signal = "telepathy"'), encoding="utf-8")
    assert "telepathy" in graph.read_text()
    before = digest(base)
    assert_one_line_error(run("graph", "show", graph), graph, "signal", "telepathy")
    res = run("recognize", base, "--graph", graph, "--models", models, "-q")
    assert_one_line_error(res, graph, "signal")
    assert str(base) not in res.stderr  # the graph is to blame, not the archive
    assert digest(base) == before


def test_deeply_nested_toml(tmp_path):
    graph = tmp_path / "deep.toml"
    graph.write_text("a = " + "[" * 10000 + "]" * 10000 + "\n")
    assert_one_line_error(run("graph", "show", graph), graph, "nested")


def test_graph_figure_suffix_is_checked_before_drawing(tmp_path):
    out = tmp_path / "fig.xyz"
    line = assert_one_line_error(run("graph", "show", GRAPH, "--out", out), out, "--out",
                                 code=2)
    assert ".png" in line and not out.exists()


# -- CSV import ------------------------------------------------------------------------

CSV = "t,fx,fy,fz,tx,ty,tz,lab\n" + "".join(
    f"{i / 1000:.3f},1,2,3,4,5,6,{code}\n" for i, code in enumerate([0, 1, 40000, 1, 0]))
WRENCH = "time=t;wrench=fx,fy,fz,tx,ty,tz"


@pytest.fixture
def csv_file(tmp_path):
    path = tmp_path / "run.csv"
    path.write_text(CSV)
    return path


def test_label_code_40000(csv_file, tmp_path):
    out = tmp_path / "r.h5"
    line = assert_one_line_error(run("import", csv_file, "--out", out, "-q", "--columns",
                                     f"{WRENCH};labels=lab"), csv_file, "lab", "40000")
    assert "1023" in line and not out.exists()


@pytest.mark.parametrize("content,fragment", [
    ("5", "int"), ("null", "null"), ('{"time": ["t", "u"], "wrench": "fx"}', "exactly one"),
    ('{"strain": []}', "no column"), ("[1,", "not valid JSON")])
def test_column_map_json_that_is_not_a_map(csv_file, tmp_path, content, fragment):
    cols = tmp_path / "cols.json"
    cols.write_text(content)
    res = run("import", csv_file, "--out", tmp_path / "r.h5", "--columns", cols)
    assert_one_line_error(res, cols, fragment)


def test_csv_named_dot_dot_csv(tmp_path):
    path = tmp_path / "..csv"
    path.write_text(CSV)
    res = run("import", path, "--out", tmp_path / "r.h5", "--columns", WRENCH)
    assert_one_line_error(res, path, "trial id")


@pytest.mark.parametrize("columns,field", [
    (f"{WRENCH};position=fx,fy", "position"), ("time=t;strain=zz*", "zz*")])
def test_csv_data_that_does_not_fit_is_exit_1(csv_file, tmp_path, columns, field):
    res = run("import", csv_file, "--out", tmp_path / "r.h5", "--columns", columns, "-q")
    assert_one_line_error(res, csv_file, field)


# -- outputs never replace inputs --------------------------------------------------------

def test_train_onto_its_own_archive_is_refused(base, tmp_path):
    path = tmp_path / "a.h5"
    shutil.copy(base, path)
    link = tmp_path / "alias.h5"
    link.symlink_to(path)
    before = digest(path)
    for out in (path, link, tmp_path / "." / "a.h5"):
        res = run("train", path, "--out", out, "--force", "-q")
        assert_one_line_error(res, out, "input", code=2)
    assert digest(path) == before


def test_import_onto_its_own_csv_is_refused(csv_file):
    before = digest(csv_file)
    res = run("import", csv_file, "--out", csv_file, "--force", "--columns", WRENCH)
    assert_one_line_error(res, csv_file, "input", code=2)
    assert digest(csv_file) == before


def test_report_does_not_replace_a_report_without_force(base, tmp_path):
    out = tmp_path / "rep"
    out.mkdir()
    (out / "index.html").write_text("my notes")
    res = run("report", base, "--out", out, "-q")
    assert_one_line_error(res, out, "--force")
    assert (out / "index.html").read_text() == "my notes"


def test_append_onto_a_non_conforming_archive_is_refused(base, tmp_path):
    path = tmp_path / "a.h5"
    shutil.copy(base, path)
    with_h5(lambda f: f[T].attrs.__setitem__("rate_hz", -1.0))(path)
    before = digest(path)
    res = run("acquire", "--spec", "stroke-a", "--out", path, "--append", "--trials", 1, "-q")
    assert_one_line_error(res, path, T, "rate_hz")
    assert digest(path) == before
    assert [p.name for p in tmp_path.iterdir()] == ["a.h5"]
