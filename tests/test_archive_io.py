"""Writer -> reader round trips, storage layout, atomic and incremental writing."""

from __future__ import annotations

import re

import h5py
import numpy as np
import pytest
from conftest import LABEL_NAMES, RATE_HZ, synthetic_measurements, write_archive

from contactlab import __version__
from contactlab.archive import create_archive, open_archive, validate_archive, writer
from contactlab.errors import DataError, UsageError

FIELDS = ("time", "strain", "wrench", "position", "velocity", "action", "command")


def _leftovers(directory):
    return sorted(p.name for p in directory.iterdir() if p.name.endswith(".tmp"))


def test_round_trip_values_dtypes_and_attributes(tmp_path):
    path = tmp_path / "a.h5"
    written = write_archive(path, trials=("b", "a"))
    with open_archive(path) as archive:
        assert archive.trial_ids == ["a", "b"]
        assert archive.attrs["format"] == "contactlab-archive"
        assert archive.attrs["format_version"] == "1.0"
        assert archive.attrs["software_version"] == __version__
        assert archive.attrs["title"] == "fixture"
        assert re.fullmatch(r"\d{4}-\d\d-\d\dT\d\d:\d\d:\d\dZ", archive.attrs["created"])
        assert [t.id for t in archive] == ["a", "b"]
        for tid, data in written.items():
            trial = archive.trial(tid)
            for field in FIELDS:
                np.testing.assert_array_equal(getattr(trial, field), data[field])
            assert trial.time.dtype == np.float64 and trial.strain.dtype == np.float64
            assert trial.action.dtype == np.int16 and trial.labels.dtype == np.int16
            np.testing.assert_array_equal(trial.calibration, data["calibration"])
            np.testing.assert_array_equal(trial.labels, data["labels"])
            assert trial.label_names == LABEL_NAMES
            assert trial.rate_hz == RATE_HZ and trial.n_samples == len(data["time"])
            assert trial.duration_s == pytest.approx(len(data["time"]) / RATE_HZ)
            assert trial.attrs["seed"] == (0 if tid == "b" else 1)
            assert trial.attrs["controller"] == "position" and trial.attrs["complete"] is True
            seg = trial.segments
            assert list(seg["label"]) == LABEL_NAMES
            np.testing.assert_allclose(seg["start_s"], [s[0] for s in data["segments"]])
            np.testing.assert_allclose(seg["end_s"], [s[1] for s in data["segments"]])
            assert trial.dataset_attrs("wrench")["columns"] == ["fx", "fy", "fz", "tx", "ty", "tz"]
            assert trial.dataset_attrs("wrench")["units"] == "N,N,N,N*m,N*m,N*m"
            assert trial.dataset_attrs("command") == {"units": "m", "columns": ["x", "y", "z"]}
            assert trial.dataset_attrs("action")["names"] == ["approach", "press"]
            assert trial.result_stages() == []


def test_datasets_are_chunked_compressed_where_it_pays_and_appendable(archive_path):
    with h5py.File(archive_path, "r") as f:
        for name in FIELDS:
            ds = f[f"trials/t01/measurements/{name}"]
            assert ds.chunks is not None and ds.chunks[0] == 1024
            packed = writer.compresses(writer.probe_rows(ds[()], 1024))
            assert ds.compression == ("gzip" if packed else None)
            assert ds.fletcher32 == (not packed)       # raw chunks carry a checksum
            assert ds.maxshape[0] is None and ds.maxshape[1:] == ds.shape[1:]
        assert f["trials/t01/ground_truth/labels"].compression == "gzip"


@pytest.mark.parametrize("kind", ["noise", "quantised", "ramp", "labels"])
def test_compression_test_agrees_with_hdf5s_own_filters(tmp_path, kind):
    """``compresses`` emulates shuffle + deflate; HDF5's filters are the oracle."""
    rng = np.random.default_rng(3)
    data = {"noise": np.round(rng.standard_normal((1024, 8)), 6),
            "quantised": np.round(rng.standard_normal((1024, 8)) * 20) / 2 ** 15,
            "ramp": np.arange(1024) / 1000.0,
            "labels": np.repeat(np.arange(4, dtype=np.int16), 256)}[kind]
    with h5py.File(tmp_path / "x.h5", "w") as f:
        ds = f.create_dataset("d", data=data, chunks=data.shape, **writer.COMPRESSION)
        ratio = ds.id.get_storage_size() / data.nbytes
    assert writer.compresses(data) == (ratio <= writer.COMPRESS_BELOW)
    assert writer.compresses(data) == (kind != "noise")


def test_compression_is_judged_on_chunks_spread_over_the_whole(tmp_path):
    """A recording that rests (and deflates) at its start, middle and end but is noise
    everywhere else is judged as HDF5 stores the whole of it."""
    rng = np.random.default_rng(4)
    rows, n_chunks = 1024, 64
    data = np.round(rng.standard_normal((rows * n_chunks, 4)), 6)
    for c in (0, 31, 32, 63):                          # at rest: a constant pose
        data[c * rows:(c + 1) * rows] = 0.25
    with h5py.File(tmp_path / "x.h5", "w") as f:
        ds = f.create_dataset("d", data=data, chunks=(rows, 4), **writer.COMPRESSION)
        ratio = ds.id.get_storage_size() / data.nbytes
    assert ratio > writer.COMPRESS_BELOW
    assert not writer.compresses(writer.probe_rows(data, rows))
    ends = np.concatenate([data[:rows], data[(n_chunks * rows - rows) // 2:][:rows],
                           data[-rows:]])
    assert writer.compresses(ends)                     # first, middle and last alone


def test_appending_in_chunks_equals_one_big_write(tmp_path):
    one, many = tmp_path / "one.h5", tmp_path / "many.h5"
    write_archive(one, trials=("t",), n=2600, chunks=1)
    write_archive(many, trials=("t",), n=2600, chunks=7)
    with open_archive(one) as a, open_archive(many) as b:
        for field in FIELDS:
            x, y = getattr(a.trial("t"), field), getattr(b.trial("t"), field)
            assert x.dtype == y.dtype and x.tobytes() == y.tobytes()


def test_writer_output_validates(archive_path):
    assert validate_archive(archive_path) == []


def test_a_wrench_only_trial_without_ground_truth_validates(tmp_path):
    path = tmp_path / "w.h5"
    data = synthetic_measurements(300)
    with create_archive(path) as archive:
        with archive.add_trial("w", rate_hz=RATE_HZ) as trial:
            trial.append(time=data["time"], wrench=data["wrench"])
    assert validate_archive(path) == []
    with open_archive(path) as archive:
        trial = archive.trial("w")
        assert trial.strain is None and trial.labels is None and trial.segments is None
        assert trial.calibration is None and trial.label_names is None
        assert trial.attrs["seed"] == -1


def test_refuses_to_overwrite_without_force(archive_path):
    before = archive_path.read_bytes()
    with pytest.raises(DataError) as err:
        create_archive(archive_path)
    assert str(archive_path) in str(err.value) and "exists" in str(err.value)
    assert archive_path.read_bytes() == before
    write_archive(archive_path, trials=("only",), force=True)
    with open_archive(archive_path) as archive:
        assert archive.trial_ids == ["only"]


def test_failure_inside_with_leaves_no_file_and_no_temp(tmp_path):
    path = tmp_path / "a.h5"
    data = synthetic_measurements(100)
    with pytest.raises(RuntimeError, match="boom"):
        with create_archive(path) as archive:
            with archive.add_trial("t", rate_hz=RATE_HZ) as trial:
                trial.append(time=data["time"], wrench=data["wrench"])
            raise RuntimeError("boom")
    assert not path.exists()
    assert list(tmp_path.iterdir()) == []


def test_incremental_keeps_finished_trials_after_an_interrupt(tmp_path):
    path = tmp_path / "acq.h5"
    data = synthetic_measurements(400)
    with pytest.raises(KeyboardInterrupt):
        with create_archive(path, incremental=True) as archive:
            for tid in ("t1", "t2"):
                with archive.add_trial(tid, rate_hz=RATE_HZ, source="phantom") as trial:
                    trial.append(time=data["time"], wrench=data["wrench"])
            unfinished = archive.add_trial("t3", rate_hz=RATE_HZ)
            unfinished.append(time=data["time"][:100], wrench=data["wrench"][:100])
            raise KeyboardInterrupt
    assert _leftovers(tmp_path) == []
    assert validate_archive(path) == []
    with open_archive(path) as archive:
        assert archive.trial_ids == ["t1", "t2"]
        np.testing.assert_array_equal(archive.trial("t2").wrench, data["wrench"])


def test_incremental_with_no_finished_trial_leaves_nothing(tmp_path):
    path = tmp_path / "acq.h5"
    data = synthetic_measurements(50)
    with pytest.raises(ValueError):
        with create_archive(path, incremental=True) as archive:
            archive.add_trial("t1", rate_hz=RATE_HZ).append(time=data["time"],
                                                            wrench=data["wrench"])
            raise ValueError
    assert list(tmp_path.iterdir()) == []


def test_incremental_puts_finished_trials_in_place_and_rolls_back_the_rest(tmp_path):
    path = tmp_path / "acq.h5"
    data = synthetic_measurements(3000)
    archive = create_archive(path, incremental=True)
    assert not path.exists()  # nothing finished yet: only a temporary file
    with archive.add_trial("t1", rate_hz=RATE_HZ) as trial:
        trial.append(time=data["time"], wrench=data["wrench"])
    committed = path.read_bytes()  # what a crash right now would leave: a whole archive
    assert validate_archive(path) == []
    with h5py.File(path, "r") as f:
        assert f["trials/t1"].attrs["complete"]
        np.testing.assert_array_equal(f["trials/t1/measurements/wrench"][()], data["wrench"])
    unfinished = archive.add_trial("t2", rate_hz=RATE_HZ)
    unfinished.append(time=data["time"], wrench=data["wrench"])
    archive.flush()  # the unfinished trial reaches the file in place ...
    assert path.read_bytes() != committed
    assert archive.abort() == path
    assert path.read_bytes() == committed  # ... and is undone, byte for byte
    assert _leftovers(tmp_path) == []


@pytest.mark.parametrize("call, fragment, field", [
    (lambda t, d: t.append(time=d["time"], wrench=d["wrench"][:, :5]), "expected (rows, 6)",
     "wrench"),
    (lambda t, d: t.append(time=d["time"], wrench=d["wrench"][:-1]), "rows, but time has",
     "wrench"),
    (lambda t, d: t.append(time=d["time"][::-1], wrench=d["wrench"]), "strictly increasing",
     "time"),
    (lambda t, d: t.append(time=d["time"], velocity=d["velocity"]),
     "needs strain, wrench or position", "strain"),
    (lambda t, d: t.append(time=d["time"], strain=d["strain"][:, :3]), "expected (rows, 8)",
     "strain"),
])
def test_append_rejects_malformed_rows_naming_the_dataset(tmp_path, call, fragment, field):
    data = synthetic_measurements(20)
    with create_archive(tmp_path / "a.h5") as archive:
        trial = archive.add_trial("t", rate_hz=RATE_HZ, strain_channels=8)
        with pytest.raises(DataError) as err:
            call(trial, data)
        assert fragment in err.value.message
        assert err.value.field == f"/trials/t/measurements/{field}"
        trial.append(time=data["time"], wrench=data["wrench"])


def test_every_append_must_give_the_same_datasets(tmp_path):
    data = synthetic_measurements(20)
    with create_archive(tmp_path / "a.h5") as archive:
        trial = archive.add_trial("t", rate_hz=RATE_HZ)
        trial.append(time=data["time"][:10], wrench=data["wrench"][:10],
                     position=data["position"][:10])
        with pytest.raises(DataError, match="missing position"):
            trial.append(time=data["time"][10:], wrench=data["wrench"][10:])
        with pytest.raises(DataError, match="strictly increasing"):
            trial.append(time=data["time"][:10], wrench=data["wrench"][:10],
                         position=data["position"][:10])


def test_close_checks_the_trial_is_whole(tmp_path):
    data = synthetic_measurements(20)
    with pytest.raises(DataError, match="no samples appended"):
        with create_archive(tmp_path / "a.h5") as archive:
            archive.add_trial("t", rate_hz=RATE_HZ)
    with pytest.raises(DataError, match="19 labels, but time has 20"):
        with create_archive(tmp_path / "b.h5") as archive:
            trial = archive.add_trial("t", rate_hz=RATE_HZ)
            trial.append(time=data["time"], wrench=data["wrench"])
            trial.set_ground_truth(labels=np.zeros(19, int), names=["a"])
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("kwargs", [
    {"rate_hz": 0.0},
    {"rate_hz": float("nan")},
    {"rate_hz": 1000.0, "calibration": np.ones((5, 8))},
    {"rate_hz": 1000.0, "calibration": np.ones((6, 8)), "strain_channels": 7},
])
def test_add_trial_rejects_bad_arguments(tmp_path, kwargs):
    with create_archive(tmp_path / "a.h5") as archive:
        with pytest.raises((UsageError, DataError)):
            archive.add_trial("t", **kwargs)
        with pytest.raises(UsageError):
            archive.add_trial("a/b", rate_hz=1.0)
        with archive.add_trial("ok", rate_hz=RATE_HZ) as trial:
            trial.append(time=np.arange(3.0) / RATE_HZ, wrench=np.zeros((3, 6)))
    with open_archive(tmp_path / "a.h5") as archive:
        assert archive.trial_ids == ["ok"]  # the refused trial left nothing behind


def test_label_codes_are_checked_when_written(tmp_path):
    data = synthetic_measurements(10)
    with create_archive(tmp_path / "a.h5") as archive:
        trial = archive.add_trial("t", rate_hz=RATE_HZ)
        trial.append(time=data["time"], wrench=data["wrench"])
        with pytest.raises(DataError, match=r"codes in \[-1, 2\)"):
            trial.set_ground_truth(labels=np.full(10, 2), names=["a", "b"])
        with pytest.raises(DataError, match="not one of the names"):
            trial.set_ground_truth(labels=np.zeros(10, int), names=["a", "b"],
                                   segments=[(0.0, 0.005, "c")])
        trial.set_ground_truth(labels=np.zeros(10, int), names=["a", "b"])


@pytest.mark.parametrize("content, fragment", [
    (b"time,fx\n0,1\n", "not an HDF5 file"),
    (b"", "not an HDF5 file"),
])
def test_open_archive_rejects_non_hdf5_in_one_line(tmp_path, content, fragment):
    path = tmp_path / "x.h5"
    path.write_bytes(content)
    with pytest.raises(DataError) as err:
        open_archive(path)
    assert str(err.value) == f"{path}: {fragment}"


def test_open_archive_rejects_truncated_and_foreign_hdf5(tmp_path, archive_path):
    data = archive_path.read_bytes()
    truncated = tmp_path / "cut.h5"
    truncated.write_bytes(data[: len(data) // 2])
    with pytest.raises(DataError, match="truncated"):
        open_archive(truncated)
    foreign = tmp_path / "foreign.h5"
    with h5py.File(foreign, "w") as f:
        f["x"] = np.arange(3)
    with pytest.raises(DataError, match="not a contactlab archive"):
        open_archive(foreign)
    with pytest.raises(DataError, match="no such file"):
        open_archive(tmp_path / "missing.h5")
    with open_archive(archive_path) as archive, pytest.raises(DataError, match="no such trial"):
        archive.trial("nope")
