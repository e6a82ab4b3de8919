"""The validator names each defect at the right HDF5 path (files broken with h5py)."""

from __future__ import annotations

import shutil

import h5py
import numpy as np
import pytest

from contactlab.archive import validate_archive
from contactlab.archive.validate import Problem

T = "/trials/t01"
M = f"{T}/measurements"
G = f"{T}/ground_truth"


def _replace(f, path, data, **attrs):
    old = dict(f[path].attrs)
    del f[path]
    ds = f.create_dataset(path, data=data)
    for k, v in {**old, **attrs}.items():
        ds.attrs[k] = v


def _nan_in_strain(f):
    f[f"{M}/strain"][10, 3] = np.nan


def _inf_in_time(f):
    f[f"{M}/time"][7] = np.inf


def _swap_times(f):
    t = f[f"{M}/time"]
    t[100], t[101] = t[101], t[100]


def _segment_row(f, row, **values):
    seg = f[f"{G}/segments"]
    rec = seg[row]
    for k, v in values.items():
        rec[k] = v
    seg[row] = rec


BROKEN = [
    # (id, mutation, HDF5 path, message fragment)
    ("missing dataset", lambda f: f.__delitem__(f"{M}/time"), f"{M}/time", "missing dataset"),
    ("missing group", lambda f: f.__delitem__(f"{T}/measurements"), f"{T}/measurements",
     "missing group"),
    ("no strain, wrench or position",
     lambda f: (f.__delitem__(f"{M}/strain"), f.__delitem__(f"{M}/wrench"),
                f.__delitem__(f"{M}/position")),
     M, "needs at least one of strain, wrench, position"),
    ("wrong trailing dim", lambda f: _replace(f, f"{M}/wrench", f[f"{M}/wrench"][:, :5],
                                              columns=["a"] * 5),
     f"{M}/wrench", "expected (n, 6)"),
    ("wrong ndim", lambda f: _replace(f, f"{M}/position", f[f"{M}/position"][:, 0]),
     f"{M}/position", "1 dimensions, expected (n, 3)"),
    ("wrong dtype kind", lambda f: _replace(f, f"{M}/action", f[f"{M}/action"][()] + 0.5),
     f"{M}/action", "dtype float64, expected int"),
    ("float32 time", lambda f: _replace(f, f"{M}/time", f[f"{M}/time"][()].astype(np.float32)),
     f"{M}/time", "expected float64"),
    ("NaN", _nan_in_strain, f"{M}/strain",
     "1 non-finite values (NaN or Inf), first at index (10, 3)"),
    ("Inf in time", _inf_in_time, f"{M}/time", "non-finite"),
    ("non-increasing time", _swap_times, f"{M}/time",
     "not strictly increasing: sample 101 (0.1 s) does not follow sample 100 (0.101 s)"),
    ("bad rate", lambda f: f[T].attrs.__setitem__("rate_hz", 980.0), f"{M}/time",
     "implies 1000 Hz, but the trial's rate_hz is 980"),
    ("length mismatch", lambda f: _replace(f, f"{M}/velocity", f[f"{M}/velocity"][:-1]),
     f"{M}/velocity", "1499 along axis 0, but measurements/time has 1500 samples"),
    ("labels too short", lambda f: _replace(f, f"{G}/labels", f[f"{G}/labels"][:-3]),
     f"{G}/labels", "1497 along axis 0"),
    ("unknown label", lambda f: f[f"{G}/labels"].__setitem__(5, 7), f"{G}/labels",
     "unknown label code (first: code 7 at sample 5"),
    ("label below -1", lambda f: f[f"{G}/labels"].__setitem__(9, -2), f"{G}/labels",
     "code -2 at sample 9"),
    ("bad calibration shape", lambda f: f[f"{M}/strain"].attrs.__setitem__("calibration",
                                                                           np.zeros((6, 7))),
     f"{M}/strain", "attribute 'calibration' shape (6, 7), expected (6, c) with c = 8"),
    ("calibration not 2-D", lambda f: f[f"{M}/strain"].attrs.__setitem__("calibration",
                                                                        np.zeros(48)),
     f"{M}/strain", "attribute 'calibration' shape (48,) has 1 dimensions"),
    ("columns do not match width", lambda f: f[f"{M}/command"].attrs.__setitem__(
        "columns", np.array(["x", "y"], dtype=h5py.string_dtype())),
     f"{M}/command", "attribute 'columns' shape (2,), expected (k,) with k = 3"),
    ("missing trial attribute", lambda f: f[T].attrs.__delitem__("rate_hz"), T,
     "missing attribute 'rate_hz'"),
    ("missing units", lambda f: f[f"{M}/wrench"].attrs.__delitem__("units"), f"{M}/wrench",
     "missing attribute 'units'"),
    ("wrong units", lambda f: f[f"{M}/position"].attrs.__setitem__("units", "mm"),
     f"{M}/position", "attribute 'units': 'mm', expected 'm'"),
    ("wrong attribute type", lambda f: f[T].attrs.__setitem__("seed", "abc"), T,
     "attribute 'seed': 'abc' is not of type 'integer'"),
    ("interrupted trial", lambda f: f[T].attrs.__setitem__("complete", False), T,
     "the recording of this trial was interrupted"),
    ("segment ends before start", lambda f: _segment_row(f, 1, end_s=0.2), f"{G}/segments",
     "1 segments end before they start (first: row 1"),
    ("segment out of range", lambda f: _segment_row(f, 2, end_s=9.0), f"{G}/segments",
     "segments outside the time base"),
    ("segment unknown label", lambda f: _segment_row(f, 0, label=3), f"{G}/segments",
     "unknown label code (first: row 0, code 3"),
    ("segment NaN", lambda f: _segment_row(f, 0, start_s=np.nan), f"{G}/segments",
     "non-finite values (NaN or Inf) in field start_s"),
    ("segments without names", lambda f: f[f"{G}/segments"].attrs.__delitem__("names"),
     f"{G}/segments", "missing attribute 'names'"),
    ("group instead of dataset", lambda f: (f.__delitem__(f"{M}/position"),
                                            f.create_group(f"{M}/position")),
     f"{M}/position", "is a group, expected a dataset"),
    ("stage without parameters", lambda f: f.create_group(f"{T}/results/segment").attrs.update(
        {"created": "2025-01-01T00:00:00Z", "software_version": "0.1.0"}),
     f"{T}/results/segment", "missing attribute 'parameters'"),
    ("parameters not JSON", lambda f: f.create_group(f"{T}/results/segment").attrs.update(
        {"created": "2025-01-01T00:00:00Z", "software_version": "0.1.0", "parameters": "{x"}),
     f"{T}/results/segment", "attribute 'parameters' is not valid JSON"),
    ("missing trials group", lambda f: f.__delitem__("trials"), "/trials", "missing group"),
    ("root attribute", lambda f: f.attrs.__setitem__("created", "yesterday"), "/",
     "attribute 'created': must be an ISO-8601 time"),
]


@pytest.mark.parametrize("mutate, path, fragment", [b[1:] for b in BROKEN],
                         ids=[b[0] for b in BROKEN])
def test_each_defect_is_reported_at_its_path(tmp_path, archive_path, mutate, path, fragment):
    broken = tmp_path / "broken.h5"
    shutil.copyfile(archive_path, broken)
    with h5py.File(broken, "r+") as f:
        mutate(f)
    problems = validate_archive(broken)
    assert problems, "the defect went unnoticed"
    assert {p.path for p in problems} == {path}, problems
    assert any(fragment in p.message for p in problems), problems


def test_the_intact_copy_is_valid(archive_path):
    assert validate_archive(archive_path) == []


def test_a_rate_within_one_percent_is_accepted(tmp_path, archive_path):
    copy = tmp_path / "close.h5"
    shutil.copyfile(archive_path, copy)
    with h5py.File(copy, "r+") as f:
        f[T].attrs["rate_hz"] = 995.0
    assert validate_archive(copy) == []


def test_every_problem_is_reported_not_only_the_first(tmp_path, archive_path):
    broken = tmp_path / "broken.h5"
    shutil.copyfile(archive_path, broken)
    with h5py.File(broken, "r+") as f:
        _nan_in_strain(f)
        f["/trials/t02"].attrs["rate_hz"] = 250.0
        f["/trials/t02/ground_truth/labels"][0] = 11
    paths = [p.path for p in validate_archive(broken)]
    assert paths == [f"{M}/strain", "/trials/t02/measurements/time",
                     "/trials/t02/ground_truth/labels"]


@pytest.mark.parametrize("make, fragment", [
    (lambda p, good: p.write_text("time,fx\n0.0,1.0\n"), "not an HDF5 file"),
    (lambda p, good: p.write_bytes(good.read_bytes()[: good.stat().st_size // 2]),
     "truncated HDF5 file"),
    (lambda p, good: h5py.File(p, "w").close(), "not a contactlab archive (no root attribute "
                                                "'format')"),
    (lambda p, good: _foreign(p, format="nwb"), "root attribute format is 'nwb'"),
    (lambda p, good: _foreign(p, format="contactlab-archive", format_version="2.0"),
     "unsupported format_version '2.0'"),
    (lambda p, good: None, "no such file"),
])
def test_file_level_problems_name_the_file(tmp_path, archive_path, make, fragment):
    path = tmp_path / "bad.h5"
    make(path, archive_path)
    problems = validate_archive(path)
    assert len(problems) == 1
    assert problems[0].path == str(path) and fragment in problems[0].message
    assert str(problems[0]) == f"{path}: {problems[0].message}"


def _foreign(path, **attrs):
    with h5py.File(path, "w") as f:
        f.attrs.update(attrs)
        f.create_group("trials")


def test_problem_prints_as_path_colon_message():
    assert str(Problem("/trials/a/measurements/time", "missing dataset")) == \
        "/trials/a/measurements/time: missing dataset"


def test_extra_members_are_allowed(tmp_path, archive_path):
    copy = tmp_path / "extended.h5"
    shutil.copyfile(archive_path, copy)
    with h5py.File(copy, "r+") as f:
        f[f"{G}/contact_surface"] = np.zeros(1500, dtype=np.int16)
        f[f"{M}/temperature"] = np.zeros(3)
    assert validate_archive(copy) == []



def test_a_corrupt_chunk_is_a_problem_and_a_reader_error(tmp_path, archive_path):
    from contactlab.archive import open_archive
    from contactlab.errors import DataError

    broken = tmp_path / "corrupt.h5"
    shutil.copyfile(archive_path, broken)
    with h5py.File(broken, "r") as f:
        info = f[f"{M}/strain"].id.get_chunk_info(0)
    with open(broken, "r+b") as fh:
        fh.seek(info.byte_offset + 16)
        fh.write(b"\xff" * 64)
    problems = validate_archive(broken)
    assert [p.path for p in problems] == [f"{M}/strain"]
    assert problems[0].message.startswith("cannot be read")
    with open_archive(broken) as archive, pytest.raises(DataError) as err:
        archive.trial("t01").strain
    assert err.value.field == f"{M}/strain" and "cannot be read" in err.value.message
