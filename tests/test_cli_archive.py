"""contactlab validate / info / import: exit codes, one-line errors, one JSON object."""

from __future__ import annotations

import json
import shutil
import subprocess
import sys

import h5py
import pytest
from test_archive_import import MAP, write_csv

from contactlab.archive import summarize, validate_archive
from contactlab.cli.common import to_jsonable
from conftest import one_json_object, run_cli


run = run_cli


@pytest.fixture
def broken_path(tmp_path, archive_path):
    path = tmp_path / "broken.h5"
    shutil.copyfile(archive_path, path)
    with h5py.File(path, "r+") as f:
        del f["trials/t02/measurements/time"]
        f["trials/t01"].attrs["rate_hz"] = 100.0
    return path


def test_validate_ok_is_one_line_and_exit_0(archive_path):
    result = run("validate", archive_path)
    assert result.exit_code == 0
    assert result.stdout.strip().splitlines() == [
        f"{archive_path}: ok, 2 trials, 3000 samples (3 s), format 1.0"]


def test_validate_lists_problems_on_stdout_and_exits_1(broken_path):
    result = run("validate", broken_path)
    assert result.exit_code == 1
    expected = [str(p) for p in validate_archive(broken_path)]
    assert len(expected) == 2
    assert result.stdout.strip().splitlines() == expected
    assert result.stderr.strip().splitlines() == [
        f"contactlab: {broken_path}: does not conform (2 problems)"]


def test_validate_json_is_one_object(archive_path, broken_path):
    good = run("validate", archive_path, "--json")
    assert good.exit_code == 0
    assert one_json_object(good.stdout) == {"file": str(archive_path), "ok": True,
                                            "problems": [], "trials": 2}
    bad = run("validate", broken_path, "--json")
    assert bad.exit_code == 1
    obj = one_json_object(bad.stdout)
    assert obj["ok"] is False and obj["file"] == str(broken_path) and obj["trials"] == 2
    assert [(p["path"], p["message"]) for p in obj["problems"]] == \
        [(p.path, p.message) for p in validate_archive(broken_path)]


def test_validate_a_text_file_named_h5(tmp_path):
    path = tmp_path / "notes.h5"
    path.write_text("hello\n")
    result = run("validate", path)
    assert result.exit_code == 1
    assert result.stdout.strip() == f"{path}: not an HDF5 file"


def test_info_table_and_json(archive_path):
    result = run("info", archive_path)
    assert result.exit_code == 0
    lines = result.stdout.strip().splitlines()
    assert lines[0].startswith(f"{archive_path} - fixture: 2 trials, format 1.0")
    assert lines[1].split()[:3] == ["trial", "duration", "(s)"]
    t01 = next(line for line in lines if line.startswith("t01 "))
    assert "1.500" in t01 and "1500" in t01 and "strain 8, wrench 6" in t01
    assert "free 499, contact 500, sliding 500, unlabelled 1" in t01
    as_json = run("info", archive_path, "--json")
    assert as_json.exit_code == 0
    assert one_json_object(as_json.stdout) == to_jsonable(summarize(archive_path))


@pytest.mark.parametrize("verb", ["info", "validate"])
def test_missing_file(tmp_path, verb):
    missing = tmp_path / "nope.h5"
    result = run(verb, missing)
    assert result.exit_code == 1
    assert result.stderr.strip().splitlines() == [f"contactlab: error: {missing}: no such file"]
    assert result.stdout == ""


def test_info_on_a_non_archive_is_one_line_without_traceback(tmp_path):
    path = tmp_path / "plain.h5"
    with h5py.File(path, "w") as f:
        f["x"] = [1, 2, 3]
    proc = subprocess.run([sys.executable, "-m", "contactlab", "info", str(path)],
                          capture_output=True, text=True)
    assert proc.returncode == 1
    assert proc.stderr.strip().splitlines() == [
        f"contactlab: error: {path}: not a contactlab archive (no root attribute 'format')"]
    assert proc.stdout == ""


def test_import_then_validate_and_info(tmp_path):
    write_csv(tmp_path / "a.csv", n=200)
    write_csv(tmp_path / "b.csv", n=300, seed=4)
    out = tmp_path / "runs.h5"
    result = run("import", tmp_path / "a.csv", tmp_path / "b.csv", "--out", out,
                 "--columns", MAP, "--quiet", "--json")
    assert result.exit_code == 0, result.output
    assert one_json_object(result.stdout) == {"file": str(out), "trials": ["a", "b"],
                                              "n_samples": 500, "duration_s": 1.0,
                                              "repairs": {"a": {}, "b": {}}}
    assert validate_archive(out) == []
    again = run("import", tmp_path / "a.csv", "--out", out, "--columns", MAP, "--quiet")
    assert again.exit_code == 1
    assert again.stderr.strip().splitlines() == [
        f"contactlab: error: {out}: exists; pass --force to overwrite"]
    forced = run("import", tmp_path / "a.csv", "--out", out, "--columns", MAP, "-q", "--force")
    assert forced.exit_code == 0
    assert forced.stdout.strip() == f"{out}: imported 1 trial, 200 samples (0.4 s)"


def test_import_warns_of_a_time_base_below_50_hz(tmp_path):
    """A time column in milliseconds reads as 0.5 Hz: imported, with one warning line."""
    write_csv(tmp_path / "ms.csv", n=100, rate_hz=0.5)
    write_csv(tmp_path / "s.csv", n=100, rate_hz=500.0)
    out = tmp_path / "runs.h5"
    slow = run("import", tmp_path / "ms.csv", "--out", out, "--columns", MAP, "-q")
    assert slow.exit_code == 0
    assert slow.stderr.strip().splitlines() == [
        f"contactlab: warning: {out}: trial ms: 0.5 Hz, below the 50 Hz the analysis expects "
        "(time in milliseconds? give seconds, or --rate)"]
    fast = run("import", tmp_path / "s.csv", "--out", out, "--columns", MAP, "-q", "--force")
    assert fast.exit_code == 0 and fast.stderr == ""


def test_import_reads_a_json_column_map(tmp_path):
    write_csv(tmp_path / "a.csv", n=50)
    cols = tmp_path / "cols.json"
    cols.write_text(json.dumps({"time": "t", "wrench": ["fx", "fy", "fz", "tx", "ty", "tz"]}))
    result = run("import", tmp_path / "a.csv", "--out", tmp_path / "o.h5", "--columns", cols,
                 "-q")
    assert result.exit_code == 0, result.output
    assert validate_archive(tmp_path / "o.h5") == []


@pytest.mark.parametrize("columns", ["time=t;force=fx", "time", "time=t;velocity=x,y,z"])
def test_import_bad_map_is_a_usage_error(tmp_path, columns):
    write_csv(tmp_path / "a.csv", n=20)
    result = run("import", tmp_path / "a.csv", "--out", tmp_path / "o.h5", "--columns", columns)
    assert result.exit_code == 2
    assert "Invalid value for '--columns'" in result.stderr
    assert not (tmp_path / "o.h5").exists()


def test_import_missing_column_is_one_line_naming_file_and_column(tmp_path):
    write_csv(tmp_path / "a.csv", n=20)
    out = tmp_path / "o.h5"
    proc = subprocess.run([sys.executable, "-m", "contactlab", "import", str(tmp_path / "a.csv"),
                           "--out", str(out), "--columns", "time=t;wrench=fx,fy,fz,tx,ty,mz",
                           "--quiet"], capture_output=True, text=True)
    assert proc.returncode == 1
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in proc.stderr
    assert lines[0].startswith(f"contactlab: error: {tmp_path / 'a.csv'}: mz: no such column")
    assert not out.exists()


def test_info_lists_only_the_integer_codes_a_recording_uses(tmp_path):
    # codes 1 and 2 only: the archive names every code from 0 up, info shows the two used
    write_csv(tmp_path / "run.csv", states=(1, 2))
    out = tmp_path / "coded.h5"
    assert run("import", tmp_path / "run.csv", "--out", out, "--columns", MAP).exit_code == 0
    row = run("info", out).stdout.strip().splitlines()[-1]
    assert "1 195, 2 200, unlabelled 5" in row and "0 0" not in row
