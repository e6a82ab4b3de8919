"""The stage driver: serial, process-pool and Dask runs agree; failures are reported;
an interrupted stage writes nothing; read-only archives are refused; one atomic write."""

from __future__ import annotations

import json
import os
import stat

import h5py
import numpy as np
import pytest
from conftest import one_json_object, run_cli
from test_temporal_train import SEPARATED, write_ar_archive

from contactlab.archive import open_archive, validate_archive, write_results
from contactlab.fileio import stale_temp_files
from contactlab.errors import DataError
from contactlab.segmentation import SegmentStage, run_archive
from contactlab.stages import Stage, TrialOutcome, run_stage

TRIALS = ("t0", "t1", "t2")


@pytest.fixture(scope="module")
def runs(tmp_path_factory):
    """Three 2.3 s trials of three AR(2) strains changing twice (labelled)."""
    return write_ar_archive(tmp_path_factory.mktemp("stages") / "runs.h5", SEPARATED,
                            trials=3, seg=1000, rest=300)


def _stored(path, stage):
    """Every dataset of every trial's results/<stage>: bytes and dtype; parameters."""
    out = {}
    with h5py.File(path, "r") as f:
        for tid in f["trials"]:
            group = f["trials"][tid].get(f"results/{stage}")
            if group is None:
                continue
            out[tid] = {"parameters": group.attrs["parameters"]}
            group.visititems(lambda name, obj, d=out[tid]: d.__setitem__(
                name, (obj[()].tobytes(), str(obj.dtype))) if isinstance(obj, h5py.Dataset)
                else None)
    return out


def measurement_bytes(path):
    """The bytes of every trial's measurements (bit-identity checks)."""
    with h5py.File(path, "r") as f:
        return {tid: {k: f["trials"][tid]["measurements"][k][()].tobytes()
                      for k in f["trials"][tid]["measurements"]} for tid in f["trials"]}


def test_serial_workers_and_dask_cluster_give_identical_results(runs, tmp_path):
    from distributed import LocalCluster

    copies = {}
    for how in ("serial", "workers", "dask"):
        copies[how] = tmp_path / f"{how}.h5"
        copies[how].write_bytes(runs.read_bytes())
    serial = run_archive(copies["serial"], threshold=50.0)
    pooled = run_archive(copies["workers"], threshold=50.0, workers=2)
    with LocalCluster(n_workers=1, threads_per_worker=2, processes=False,
                      dashboard_address=None) as cluster:
        dask = run_archive(copies["dask"], threshold=50.0, scheduler=cluster.scheduler_address)
    assert list(serial["trials"]) == list(TRIALS)
    assert sum(len(e["boundaries_s"]) for e in serial["trials"].values()) > 0
    assert pooled == serial and dask == serial
    stored = _stored(copies["serial"], "segment")
    assert set(stored) == set(TRIALS)
    assert _stored(copies["workers"], "segment") == stored
    assert _stored(copies["dask"], "segment") == stored


class _FailsOn(Stage):
    """Stores each trial's first strain sample; raises on one trial (picklable)."""

    name = "probe"

    def __init__(self, *bad: str, error=DataError):
        self.bad, self.error = bad, error

    def run_trial(self, trial):
        if trial.id in self.bad:
            if self.error is DataError:
                raise DataError("cannot probe", field=f"/trials/{trial.id}/measurements/strain")
            raise self.error("stop")
        from contactlab.archive import TrialResults
        first = np.asarray(trial.strain[:1])
        return TrialOutcome({"first": first.tolist()}, TrialResults({"first": first}))


@pytest.mark.parametrize("workers", [1, 2])
def test_a_failed_trial_is_reported_and_the_others_land(runs, tmp_path, workers):
    path = tmp_path / "a.h5"
    path.write_bytes(runs.read_bytes())
    with pytest.raises(DataError) as info:
        run_stage(_FailsOn("t1"), [path], workers=workers)
    msg = str(info.value)
    assert msg.startswith(f"{path}: /trials/t1/measurements/strain: cannot probe")
    assert msg.endswith("(the other results were written)") and "\n" not in msg
    assert set(_stored(path, "probe")) == {"t0", "t2"}


def test_several_failed_trials_are_one_line_naming_them(runs, tmp_path):
    path = tmp_path / "a.h5"
    path.write_bytes(runs.read_bytes())
    with pytest.raises(DataError) as info:
        run_stage(_FailsOn("t0", "t2"), [path])
    assert str(info.value) == (f"{path}: /trials/t0/measurements/strain: cannot probe "
                               "(2 failed; also t2; the other results were written)")
    assert set(_stored(path, "probe")) == {"t1"}


def test_an_interrupted_stage_keeps_every_old_result(runs, tmp_path):
    path = tmp_path / "a.h5"
    path.write_bytes(runs.read_bytes())
    run_archive(path, threshold=100.0)
    old = _stored(path, "segment")

    class Interrupting(SegmentStage):
        def run_trial(self, trial):
            if trial.id == "t2":                  # after two trials were computed
                raise KeyboardInterrupt
            return super().run_trial(trial)

    with pytest.raises(KeyboardInterrupt):
        run_stage(Interrupting(threshold=300.0), [path])
    assert _stored(path, "segment") == old
    assert not stale_temp_files(path)


def test_several_archives_in_one_command(runs, tmp_path):
    paths = []
    for name in ("a.h5", "b.h5"):
        paths.append(tmp_path / name)
        paths[-1].write_bytes(runs.read_bytes())
    r = run_cli("segment", *paths, "--threshold", "50", "--json", "--quiet")
    assert r.exit_code == 0, r.output
    out = one_json_object(r.stdout)
    assert list(out["archives"]) == [str(p) for p in paths]
    assert out["archives"][str(paths[0])] == out["archives"][str(paths[1])]
    assert _stored(paths[0], "segment").keys() == _stored(paths[1], "segment").keys() \
        == set(TRIALS)
    r = run_cli("segment", *paths, "--threshold", "50", "--quiet")
    assert r.exit_code == 0 and r.stdout.count("== ") == 2


def test_read_only_archive_is_refused_with_one_line_and_left_alone(runs, tmp_path):
    path = tmp_path / "ro.h5"
    path.write_bytes(runs.read_bytes())
    os.chmod(path, 0o444)
    before = path.read_bytes()
    try:
        r = run_cli("segment", path, "--quiet")
        assert r.exit_code == 1
        lines = r.stderr.strip().splitlines() if r.stderr_bytes else r.output.strip().splitlines()
        assert len(lines) == 1 and str(path) in lines[0] and "read-only" in lines[0]
        with pytest.raises(DataError, match="read-only"):
            write_results(path, "t0", "segment", datasets={"x": np.zeros(3)})
        assert stat.S_IMODE(os.stat(path).st_mode) == 0o444
        assert path.read_bytes() == before
    finally:
        os.chmod(path, 0o644)


def test_one_atomic_write_per_stage_run_keeps_mode_and_measurements(runs, tmp_path,
                                                                    monkeypatch):
    path = tmp_path / "a.h5"
    path.write_bytes(runs.read_bytes())
    os.chmod(path, 0o640)
    before = measurement_bytes(path)
    replaced = []
    real = os.replace
    monkeypatch.setattr(os, "replace", lambda a, b: (replaced.append(b), real(a, b)))
    run_archive(path)
    assert replaced == [path]                          # one rebuild for all three trials
    assert stat.S_IMODE(os.stat(path).st_mode) == 0o640
    assert measurement_bytes(path) == before and validate_archive(path) == []


def test_stale_temporary_files_are_removed_and_noted(runs, tmp_path, capsys):
    path = tmp_path / "a.h5"
    path.write_bytes(runs.read_bytes())
    import subprocess
    import sys

    gone = subprocess.Popen([sys.executable, "-c", "pass"])   # a writer that has exited
    gone.wait()
    stale = tmp_path / f".a.h5.{gone.pid}-k1ll3d.tmp"
    stale.write_bytes(b"half an archive")
    write_results(path, "t0", "segment", datasets={"x": np.arange(3.0)})
    assert not stale.exists()
    assert stale.name in capsys.readouterr().err
    with open_archive(path) as archive:
        np.testing.assert_array_equal(archive.trial("t0").results("segment")["x"],
                                      np.arange(3.0))


def run(*, out_dir, seed, quiet):
    """A stand-in experiment (imported by name in worker processes): seeded draws."""
    values = np.random.default_rng(seed + len(out_dir.name)).normal(size=3).tolist()
    (out_dir / "results.json").write_text(json.dumps({"values": values, "seed": seed}))
    if out_dir.name == "broken":
        raise DataError("no data", file=str(out_dir))
    return {"values": values, "wall_time_s": 0.0}


def test_reproduce_on_workers_and_dask_matches_a_serial_run(tmp_path, monkeypatch):
    from distributed import LocalCluster

    from dataclasses import replace

    from contactlab.experiments import EXPERIMENTS
    from contactlab.experiments.runner import reproduce

    fake = lambda name: replace(EXPERIMENTS["ph-demo"], name=name, module=__name__)  # noqa: E731
    fakes = [fake("one"), fake("three")]
    for exp in fakes:
        monkeypatch.setitem(EXPERIMENTS, exp.name, exp)
    serial = reproduce(fakes, out=tmp_path / "serial", seed=4)
    assert reproduce(fakes, out=tmp_path / "pool", seed=4, workers=2) == serial
    with LocalCluster(n_workers=1, processes=False, dashboard_address=None) as cluster:
        assert reproduce(fakes, out=tmp_path / "dask", seed=4,
                         scheduler=cluster.scheduler_address) == serial
    assert serial["one"]["values"] != serial["three"]["values"]
    broken = fake("broken")
    monkeypatch.setitem(EXPERIMENTS, "broken", broken)
    with pytest.raises(DataError, match="no data"):
        reproduce([broken, fakes[0]], out=tmp_path / "b", seed=4, workers=2)
    assert (tmp_path / "b" / "one" / "results.json").exists()      # the other one finished


def test_a_bad_scheduler_address_is_one_line_and_writes_nothing(runs, tmp_path):
    path = tmp_path / "a.h5"
    path.write_bytes(runs.read_bytes())
    before = path.read_bytes()
    r = run_cli("segment", path, "--scheduler", "bogus://x", "--quiet")
    assert r.exit_code == 1
    lines = r.output.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(
        "contactlab: error: --scheduler: not a Dask scheduler address 'bogus://x' "
        "(transports: ") and "tcp" in lines[0]
    r = run_cli("segment", path, "--scheduler", "tcp://127.0.0.1:1", "--workers", "2")
    assert r.exit_code == 2 and "not both" in r.output
    assert path.read_bytes() == before


def test_results_through_a_symlink_replace_the_file_and_keep_the_link(runs, tmp_path):
    real = tmp_path / "real.h5"
    real.write_bytes(runs.read_bytes())
    link = tmp_path / "link.h5"
    link.symlink_to(real)
    write_results(link, "t0", "segment", datasets={"x": np.arange(2.0)})
    assert link.is_symlink() and os.readlink(link) == str(real)
    with open_archive(real) as archive:
        np.testing.assert_array_equal(archive.trial("t0").results("segment")["x"], [0.0, 1.0])
