"""Write failures, interrupts and stale temporary files: nothing is lost, one line is said.

Read-only targets are made with mode bits (the tests run as root, who may write
anything: the refusal must come from the mode, not from the kernel). The full
disk is a small tmpfs mounted for the test when the machine allows it.
"""

from __future__ import annotations

import errno
import hashlib
import os
import re
import shutil
import signal
import subprocess
import sys
import time

import click
import h5py
import numpy as np
import pytest
from click.testing import CliRunner
from conftest import write_archive

from contactlab import interrupt
from contactlab.archive import open_archive, validate_archive
from contactlab.cli import main
from contactlab.cli.common import ContactlabGroup
from contactlab.errors import DataError
from contactlab.fileio import (atomic_path, remove_stale_temp_files, stale_temp_files,
                               write_error)

from test_acquire_cli import QUICK
from test_bad_input_corpus import assert_one_line_error, digest, run


def temp_files(folder):
    return sorted(p.name for p in folder.iterdir() if p.name.endswith(".tmp"))


def measurements_digest(path) -> str:
    """Hash of every measurement dataset (results may change, measurements never)."""
    h = hashlib.sha256()
    with h5py.File(path, "r") as f:
        for tid in sorted(f["trials"]):
            meas = f[f"trials/{tid}/measurements"]
            for name in sorted(meas):
                h.update(f"{tid}/{name}".encode())
                h.update(np.ascontiguousarray(meas[name][()]).tobytes())
    return h.hexdigest()


# -- read-only targets ----------------------------------------------------------------

@pytest.fixture
def archive(tmp_path):
    path = tmp_path / "runs.h5"
    write_archive(path, n=1500)
    return path


def test_read_only_output_file_is_refused_even_with_force(archive, tmp_path):
    out = tmp_path / "ro.h5"
    shutil.copy(archive, out)
    out.chmod(0o444)
    before = digest(out)
    line = assert_one_line_error(run("train", archive, "--out", out, "--force", "-q"), out)
    assert "read-only" in line
    assert digest(out) == before and (out.stat().st_mode & 0o777) == 0o444
    assert temp_files(tmp_path) == []


def test_stage_results_are_not_written_into_a_read_only_archive(archive, tmp_path):
    archive.chmod(0o444)
    before = digest(archive)
    assert_one_line_error(run("segment", archive, "-q"), archive)
    assert digest(archive) == before and (archive.stat().st_mode & 0o777) == 0o444
    assert temp_files(tmp_path) == []


def test_read_only_directory_is_refused(tmp_path):
    folder = tmp_path / "ro"
    folder.mkdir()
    folder.chmod(0o555)
    csv = tmp_path / "run.csv"
    csv.write_text("t,x,y,z\n0,0,0,0\n0.001,1,1,1\n0.002,2,2,2\n")
    res = run("import", csv, "--out", folder / "runs.h5", "--columns", "time=t;position=x,y,z")
    line = assert_one_line_error(res, folder)
    assert "read-only" in line and list(folder.iterdir()) == []


@pytest.fixture
def read_only_fs(tmp_path):
    """A read-only file system (a tmpfs mounted ro; skipped where mounting is not
    permitted): the kernel refuses with EROFS even the super-user."""
    yield from _tmpfs(tmp_path / "rofs", "ro,size=1m")


def _report_and_reproduce(archive, where):
    """Each report-writing call into ``where``: (arguments, the directory named)."""
    return [(("report", archive, "--out", where / "rep", "-q"), where / "rep"),
            (("reproduce", "ph-demo", "--out", where / "exp", "-q"), where / "exp")]


def test_report_and_reproduce_into_a_read_only_directory_are_refused(archive, tmp_path):
    folder = tmp_path / "ro"
    folder.mkdir()
    folder.chmod(0o555)
    for args, _ in _report_and_reproduce(archive, folder):
        line = assert_one_line_error(run(*args), folder)
        assert "read-only" in line
    assert list(folder.iterdir()) == []


def test_report_and_reproduce_on_a_read_only_file_system(archive, read_only_fs,
                                                         monkeypatch):
    for args, named in _report_and_reproduce(archive, read_only_fs):
        line = assert_one_line_error(run(*args), named)
        assert "read-only file system" in line
    monkeypatch.chdir(read_only_fs)  # no --out: reports/STEM in the working directory
    line = assert_one_line_error(run("report", archive, "-q"), "reports")
    assert "read-only file system" in line


def test_write_error_names_the_target(tmp_path):
    err = RuntimeError("Can't decrement id ref count (file write failed: errno = 28, "
                       "error message = 'No space left on device')")
    assert str(write_error(err, tmp_path / "x.h5")) == \
        f"{tmp_path / 'x.h5'}: cannot be written: no space left on the device"
    assert write_error(OSError(errno.EROFS, "Read-only file system"), "x.h5").message == \
        "cannot be written: read-only file system"
    assert write_error(ValueError("bad value"), "x.h5") is None
    assert write_error(OSError(errno.ENOENT, "No such file"), "x.h5") is None


def test_atomic_write_failure_leaves_the_original(tmp_path):
    target = tmp_path / "keep.txt"
    target.write_text("original")
    with pytest.raises(DataError, match="keep.txt: cannot be written: no space left"):
        with atomic_path(target, force=True) as tmp:
            tmp.write_text("half")
            raise OSError(errno.ENOSPC, "No space left on device")
    assert target.read_text() == "original" and temp_files(tmp_path) == []


# -- a full disk ----------------------------------------------------------------------

@pytest.fixture
def small_disk(tmp_path):
    """An 8 MiB tmpfs (skipped where mounting is not permitted)."""
    yield from _tmpfs(tmp_path / "disk", "size=8m")


def _tmpfs(mnt, options):
    """Mount a tmpfs with ``options`` at ``mnt`` for the test (skipped where mounting
    is not permitted)."""
    if os.geteuid() != 0:
        pytest.skip("mounting a tmpfs needs root")
    mnt.mkdir()
    proc = subprocess.run(["mount", "-t", "tmpfs", "-o", options, "tmpfs", str(mnt)],
                          capture_output=True, text=True)
    if proc.returncode != 0:
        pytest.skip(f"cannot mount a tmpfs here: {proc.stderr.strip()}")
    try:
        yield mnt
    finally:
        subprocess.run(["umount", "-l", str(mnt)], check=False)


def _check_kept(res, out, folder):
    line = assert_one_line_error(res, out, "no space left")
    assert "finished trial" in line and "kept in it" in line, line
    assert validate_archive(out) == []
    with open_archive(out) as a:
        assert len(a) >= 1 and all(t.attrs["complete"] for t in a)
        kept = list(a.trial_ids)
    assert temp_files(folder) == []
    return kept


def test_acquire_on_a_full_disk_keeps_the_finished_trials(small_disk, tmp_path):
    spec = tmp_path / "long.toml"
    spec.write_text(QUICK.format(duration=3.0, trials=20))  # ~0.5 MB per trial
    out = small_disk / "runs.h5"
    res = run("acquire", "--spec", spec, "--out", out, "-q")
    kept = _check_kept(res, out, small_disk)
    assert 1 <= len(kept) < 20 and ", ".join(kept) in res.stderr


def test_import_on_a_full_disk_keeps_the_finished_trials(small_disk, tmp_path):
    rng = np.random.default_rng(0)
    n = 8000
    header = "t," + ",".join(f"s{i}" for i in range(8)) + ",fx,fy,fz,tx,ty,tz"
    paths = []
    for k in range(6):
        data = np.column_stack([np.arange(n) / 1000.0, rng.normal(size=(n, 14))])
        path = tmp_path / f"run{k}.csv"
        np.savetxt(path, data, delimiter=",", header=header, comments="", fmt="%.17g")
        paths.append(path)
    out = small_disk / "runs.h5"
    res = run("import", *paths, "--out", out, "-q", "--columns",
              "time=t;strain=s*;wrench=fx,fy,fz,tx,ty,tz")
    kept = _check_kept(res, out, small_disk)
    assert 1 <= len(kept) < 6


def test_a_disk_too_full_to_start_names_the_archive_not_its_directory(small_disk, tmp_path):
    st = os.statvfs(small_disk)
    (small_disk / "filler").write_bytes(bytes(st.f_bavail * st.f_frsize - (1 << 20)))
    spec = tmp_path / "q.toml"
    spec.write_text(QUICK.format(duration=0.3, trials=1))
    out = small_disk / "runs.h5"
    line = assert_one_line_error(run("acquire", "--spec", spec, "--out", out, "-q"), out)
    assert line.startswith(f"contactlab: error: {out}: cannot be written: no space left"), line
    assert temp_files(small_disk) == []


def test_report_on_a_full_disk_leaves_no_partial_report(small_disk, tmp_path):
    big = tmp_path / "big.h5"
    write_archive(big, trials=[f"t{i}" for i in range(3)], n=1500)
    room = tmp_path / "room"
    room.mkdir()
    res = run("report", big, "--out", room, "-q")
    assert res.exit_code == 0, res.output
    needed = sum(p.stat().st_size for p in room.iterdir())
    st = os.statvfs(small_disk)
    filler = tmp_path / "disk" / "filler"  # leaves room for about half the report
    filler.write_bytes(bytes(st.f_bavail * st.f_frsize - needed // 2))
    out = small_disk / "rep"
    res = run("report", big, "--out", out, "-q")
    line = assert_one_line_error(res, "no space left")
    assert re.search(rf"{re.escape(str(out))}/[^ /]+: cannot be written", line), line
    filler.unlink()
    assert list(small_disk.iterdir()) == []  # nothing half written, no temporary directory
    filler.write_bytes(bytes(st.f_bavail * st.f_frsize - needed // 2))
    (small_disk / "rep").mkdir()
    (small_disk / "rep" / "notes.txt").write_text("mine")
    res = run("report", big, "--out", out, "-q", "--force")
    assert res.exit_code == 1 and "no space left" in res.stderr
    assert sorted(p.name for p in small_disk.rglob("*")) == ["filler", "notes.txt", "rep"]


# -- stale temporary files ------------------------------------------------------------

DEAD_PID = 4194305  # above Linux's largest pid_max: never a live process


def test_stale_temp_file_of_a_killed_run_is_removed_next_time(archive, tmp_path):
    stale = tmp_path / f".{archive.name}.{DEAD_PID}-abcd1234.tmp"
    stale.write_bytes(b"half an archive")
    sleeper = subprocess.Popen(["sleep", "30"])
    try:
        live = tmp_path / f".{archive.name}.{sleeper.pid}-efgh5678.tmp"
        live.write_bytes(b"being written")
        old = tmp_path / f".{archive.name}.zz9xq0a1.tmp"  # no pid: stale after an hour
        old.write_bytes(b"old")
        os.utime(old, (time.time() - 7200, time.time() - 7200))
        fresh = tmp_path / f".{archive.name}.aa1bb2cc.tmp"
        fresh.write_bytes(b"fresh")
        assert stale_temp_files(archive) == sorted([stale, old])
        res = run("info", archive)
        assert res.exit_code == 0
        notes = [line for line in res.stderr.splitlines() if "interrupted run" in line]
        assert len(notes) == 2 and str(stale) in res.stderr
        assert not stale.exists() and not old.exists() and live.exists() and fresh.exists()
    finally:
        sleeper.kill()
        sleeper.wait()
    assert remove_stale_temp_files(archive, notify=None) == [live]


# -- signals --------------------------------------------------------------------------

def test_an_interrupt_wrapped_by_a_compiled_function_is_still_an_interrupt():
    try:
        try:
            raise KeyboardInterrupt
        except KeyboardInterrupt as inner:
            raise SystemError("CPUDispatcher(<function integrate>) returned a result with "
                              "an exception set") from inner
    except SystemError as err:
        assert interrupt.interrupt_signal(err) == signal.SIGINT
    assert interrupt.interrupt_signal(interrupt.Terminated()) == signal.SIGTERM
    assert interrupt.interrupt_signal(ValueError()) is None


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM])
def test_a_swallowed_signal_still_ends_the_run_with_its_status(sig, capsys):
    @click.group(cls=ContactlabGroup)
    def cli():
        pass

    @cli.command()
    def swallow():
        try:
            os.kill(os.getpid(), sig)
            time.sleep(1)
        except KeyboardInterrupt:
            pass  # as in a finaliser: "Exception ignored in ..."

    with pytest.raises(SystemExit) as exit_:
        cli.main(["swallow"], prog_name="contactlab")
    assert exit_.value.code == 128 + sig
    assert capsys.readouterr().err.strip().splitlines() == [
        f"contactlab: {'terminated' if sig == signal.SIGTERM else 'interrupted'} "
        f"({signal.Signals(sig).name})"]


@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGINT])
def test_a_signal_while_a_stage_writes_leaves_no_temp_file(tmp_path, sig):
    path = tmp_path / "big.h5"
    write_archive(path, trials=[f"t{i}" for i in range(3)], n=8000)
    before = measurements_digest(path)
    proc = subprocess.Popen([sys.executable, "-m", "contactlab", "segment", str(path), "-q"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 120
    while proc.poll() is None and not temp_files(tmp_path) and time.monotonic() < deadline:
        time.sleep(0.005)  # the results are being written: the moment to interrupt
    proc.send_signal(sig)
    _, err = proc.communicate(timeout=120)
    assert proc.returncode in (0, 128 + sig), err
    if proc.returncode:
        what = "terminated" if sig == signal.SIGTERM else "interrupted"
        assert err.strip().splitlines() == [f"contactlab: {what} ({sig.name})"], err
    assert temp_files(tmp_path) == []
    assert validate_archive(path) == [] and measurements_digest(path) == before


def test_a_signal_while_an_archive_is_written_waits_for_the_writers_safe_point(tmp_path):
    from conftest import synthetic_measurements

    from contactlab.archive import create_archive

    data = synthetic_measurements(200)
    fields = ("time", "strain", "wrench", "position")
    out = tmp_path / "runs.h5"
    with interrupt.signals_as_interrupt():
        with pytest.raises(interrupt.Terminated):
            with create_archive(out, incremental=True) as archive:
                with archive.add_trial("t1", rate_hz=1000.0) as trial:
                    trial.append(**{k: data[k] for k in fields})
                trial = archive.add_trial("t2", rate_hz=1000.0)
                os.kill(os.getpid(), signal.SIGTERM)  # recorded, not raised inside h5py
                trial.append(**{k: data[k][:100] for k in fields})  # the safe point
        assert interrupt.received() == signal.SIGTERM
        interrupt.checkpoint()  # raised once: a later checkpoint is a no-op
    assert validate_archive(out) == []
    with open_archive(out) as a:
        assert a.trial_ids == ["t1"]
    assert temp_files(tmp_path) == []


def test_a_signal_during_an_atomic_write_keeps_the_original(tmp_path):
    target = tmp_path / "keep.txt"
    target.write_text("original")
    with interrupt.signals_as_interrupt():
        with pytest.raises(KeyboardInterrupt):
            with atomic_path(target, force=True) as tmp:
                tmp.write_text("half")
                os.kill(os.getpid(), signal.SIGINT)  # recorded; raised before the rename
                tmp.write_text("new")
    assert target.read_text() == "original" and temp_files(tmp_path) == []
