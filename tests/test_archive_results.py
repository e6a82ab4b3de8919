"""write_results: stages replace only their own group, atomically."""

from __future__ import annotations

import json

import h5py
import numpy as np
import pytest

from contactlab.archive import open_archive, validate_archive, write_results
from contactlab.archive import results as results_module
from contactlab.archive.spec import to_plain
from contactlab.errors import DataError, UsageError


def _snapshot(path, prefix):
    """Every dataset and attribute under ``prefix``: values, dtype, storage, attrs and the
    compressed bytes of every stored chunk."""
    out = {}
    with h5py.File(path, "r") as f:
        out["/"] = {k: str(v) for k, v in f.attrs.items()
                    if k != results_module.COMPACTED_ATTR}   # the writer's bookkeeping

        def visit(name, obj):
            attrs = {k: repr(to_plain(v)) for k, v in obj.attrs.items()}
            if isinstance(obj, h5py.Dataset):
                stored = [obj.id.read_direct_chunk(obj.id.get_chunk_info(i).chunk_offset)
                          for i in range(obj.id.get_num_chunks())] if obj.chunks else None
                out[name] = (obj[()].tobytes(), str(obj.dtype), obj.shape, obj.chunks,
                             obj.compression, obj.maxshape, attrs, stored)
            else:
                out[name] = attrs

        f[prefix].visititems(visit)
    return out


def test_measurements_stay_byte_identical(archive_path):
    before = _snapshot(archive_path, "trials")
    write_results(archive_path, "t01", "segment",
                  datasets={"change_s": np.array([0.5, 1.0]), "statistic": np.arange(1500.0)},
                  parameters={"threshold": 200})
    after = _snapshot(archive_path, "trials")
    new = {k for k in after if k.startswith("t01/results")}
    assert new == {"t01/results", "t01/results/segment", "t01/results/segment/change_s",
                   "t01/results/segment/statistic"}
    assert {k: v for k, v in after.items() if k not in new} == before
    assert validate_archive(archive_path) == []


def test_results_round_trip_with_attrs_parameters_and_strings(archive_path):
    datasets = {"change_s": np.array([0.25, 0.75]), "labels": ["free", "contact"],
                "model/coef": np.arange(6.0).reshape(2, 3), "count": np.int64(2)}
    write_results(archive_path, "t02", "label", datasets=datasets,
                  attrs={"method": "ar2", "order": 2, "names": ["a", "b"]},
                  parameters={"threshold": np.float64(8.0), "models": ["h0", "h1"]})
    with open_archive(archive_path) as archive:
        trial = archive.trial("t02")
        assert trial.result_stages() == ["label"]
        res = trial.results("label")
        assert set(res) == set(datasets)
        np.testing.assert_array_equal(res["change_s"], datasets["change_s"])
        np.testing.assert_array_equal(res["model/coef"], datasets["model/coef"])
        assert list(res["labels"]) == ["free", "contact"] and int(res["count"]) == 2
        assert res.attrs["method"] == "ar2" and res.attrs["order"] == 2
        assert res.attrs["names"] == ["a", "b"]
        assert res.parameters == {"threshold": 8.0, "models": ["h0", "h1"]}
        assert json.loads(res.attrs["parameters"]) == res.parameters
        assert res.attrs["software_version"] and res.attrs["created"].endswith("Z")
        assert archive.trial("t01").result_stages() == []


def test_writing_a_stage_again_replaces_only_that_stage(archive_path):
    write_results(archive_path, "t01", "segment", datasets={"old": np.zeros(3)})
    write_results(archive_path, "t01", "estimate", datasets={"p": np.ones(2)})
    write_results(archive_path, "t01", "segment", datasets={"new": np.ones(4)})
    with open_archive(archive_path) as archive:
        trial = archive.trial("t01")
        assert trial.result_stages() == ["estimate", "segment"]
        assert set(trial.results("segment")) == {"new"}
        np.testing.assert_array_equal(trial.results("estimate")["p"], np.ones(2))


def test_rewriting_a_stage_leaves_no_dead_space(archive_path):
    big = {"statistic": np.random.default_rng(0).normal(size=(1500, 40))}
    write_results(archive_path, "t01", "segment", datasets=big)
    size = archive_path.stat().st_size
    for _ in range(4):
        write_results(archive_path, "t01", "segment", datasets=big)
    assert archive_path.stat().st_size <= size * 1.02


def test_a_crash_while_writing_leaves_the_archive_untouched(archive_path, monkeypatch):
    before = archive_path.read_bytes()
    calls = []

    def failing(*args, **kwargs):
        calls.append(args[1])
        raise KeyboardInterrupt

    monkeypatch.setattr(results_module, "create_dataset", failing)
    with pytest.raises(KeyboardInterrupt):
        write_results(archive_path, "t01", "segment", datasets={"x": np.zeros(3)})
    assert calls == ["x"]
    assert archive_path.read_bytes() == before
    assert sorted(p.name for p in archive_path.parent.iterdir()) == [archive_path.name]


@pytest.mark.parametrize("kwargs, error, fragment", [
    ({"trial_id": "nope", "stage": "s"}, DataError, "/trials/nope: no such trial"),
    ({"trial_id": "t01", "stage": "a/b"}, UsageError, "not a valid name"),
    ({"trial_id": "t01", "stage": "s", "attrs": {"parameters": "{}"}}, UsageError,
     "set by write_results"),
    ({"trial_id": "t01", "stage": "s", "datasets": {"x": [object()]}}, UsageError,
     "not strings"),
    ({"trial_id": "t01", "stage": "s", "parameters": {"f": object()}}, UsageError,
     "not JSON-serialisable"),
])
def test_bad_requests_are_refused_before_anything_is_written(archive_path, kwargs, error,
                                                             fragment):
    before = archive_path.read_bytes()
    kwargs = {"datasets": {"x": np.zeros(2)}, **kwargs}
    with pytest.raises(error, match=fragment):
        write_results(archive_path, **kwargs)
    assert archive_path.read_bytes() == before


def test_write_results_to_a_non_archive_is_a_data_error(tmp_path):
    path = tmp_path / "x.h5"
    path.write_text("not hdf5")
    with pytest.raises(DataError, match="not an HDF5 file"):
        write_results(path, "t", "s", datasets={})


@pytest.mark.parametrize("value", [
    np.arange(5.0), np.zeros(0), np.array(3.5), np.arange(6, dtype=np.int8).reshape(2, 3),
    np.array([True, False]), np.arange(4, dtype=">f8"), np.zeros((0, 3), np.int64),
    np.float32(2), np.arange(12.0).reshape(3, 4)[:, 1],
])
def test_results_datasets_are_what_h5py_would_make(tmp_path, value):
    """The results write's small numeric datasets (made with HDF5's own calls) equal
    h5py's create_dataset of the same array: shape, dtype, layout, no timestamps, data."""
    arr = np.asarray(value)
    with h5py.File(tmp_path / "x.h5", "w") as f:
        ours = results_module.create_dataset(f, "ours", arr)
        theirs = f.create_dataset("theirs", data=arr)
        assert (ours.shape, ours.dtype) == (theirs.shape, theirs.dtype)
        a, b = ours.id.get_create_plist(), theirs.id.get_create_plist()
        assert a.get_layout() == b.get_layout() == h5py.h5d.CONTIGUOUS
        assert not a.get_obj_track_times() and not b.get_obj_track_times()
        np.testing.assert_array_equal(ours[()], arr)


@pytest.mark.parametrize("value", ["strain", "", "é ü {\"a\": [1, 2]}", "x" * 5000])
def test_results_string_attributes_are_what_h5py_would_make(tmp_path, value):
    """The results write's string attributes (made with HDF5's own calls) equal h5py's
    ``attrs[name] = value``: variable-length UTF-8, scalar, the same value and type."""
    with h5py.File(tmp_path / "x.h5", "w") as f:
        ours, theirs = f.create_group("ours"), f.create_group("theirs")
        results_module._new_string_attr(ours.id, "a", value)
        theirs.attrs["a"] = value
        a, b = ours.attrs.get_id("a"), theirs.attrs.get_id("a")
        assert a.shape == b.shape == ()
        ta, tb = a.get_type(), b.get_type()
        assert ta.is_variable_str() and tb.is_variable_str()
        assert ta.get_cset() == tb.get_cset() == h5py.h5t.CSET_UTF8
        assert ours.attrs["a"] == theirs.attrs["a"] == value
        assert type(ours.attrs["a"]) is type(theirs.attrs["a"]) is str
