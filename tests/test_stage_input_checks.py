"""Stages check each trial where it runs, once, with the validator's words.

The commands that run a stage check the archive outside its trials up front
(``check_archive(values=False, walk_trials=False)``) and leave each trial's
layout and value checks to the stage, which runs them where the trial runs
(in a worker, with ``workers``) on the arrays it reads: each measurement is
decompressed once.
"""

from __future__ import annotations

import hashlib

import h5py
import numpy as np
import pytest
from conftest import write_archive

from contactlab.archive import validate_archive
from contactlab.archive.validate import check_archive
from contactlab.errors import DataError
from contactlab.segmentation import run_archive

M = "/trials/t02/measurements"


@pytest.fixture()
def archive(tmp_path):
    path = tmp_path / "a.h5"
    write_archive(path, trials=("t01", "t02", "t03"), n=1500)
    return path


def _digest(path):
    return hashlib.sha256(path.read_bytes()).hexdigest()


@pytest.mark.parametrize("where, value, fragment", [
    ("strain", np.nan, "non-finite"),
    ("wrench", np.inf, "non-finite"),          # a dataset the segment stage does not use
    ("time", -1.0, "not strictly increasing"),
])
def test_a_stage_reports_bad_values_like_validate_and_writes_nothing(archive, where, value,
                                                                      fragment):
    with h5py.File(archive, "r+") as f:
        ds = f[f"{M}/{where}"]
        index = (20, 1) if ds.ndim == 2 else 20
        ds[index] = value
    before = _digest(archive)
    want = validate_archive(archive)[0]
    assert want.path == f"{M}/{where}" and fragment in want.message
    check_archive(archive, values=False)           # the layout is fine
    with pytest.raises(DataError) as err:
        run_archive(archive, quiet=True)
    assert err.value.field == want.path and err.value.file == str(archive)
    assert err.value.message.startswith(want.message)
    assert _digest(archive) == before              # no trial's results were written


def test_segments_outside_a_deferred_time_base_are_still_found(archive):
    with h5py.File(archive, "r+") as f:
        seg = f["/trials/t01/ground_truth/segments"]
        row = seg[0]
        row["end_s"] = 99.0
        seg[0] = row
    assert "outside the time base" in validate_archive(archive)[0].message
    check_archive(archive, values=False)
    with pytest.raises(DataError, match="outside the time base"):
        run_archive(archive, quiet=True)


def test_measurements_are_read_once_per_stage_run(archive, monkeypatch):
    """The layout check decodes no measurement; the stage decodes each one once."""
    reads = []
    original = h5py.Dataset.__getitem__

    def counting(self, key, *args, **kw):
        if key == () and "/measurements/" in self.name:
            reads.append(self.name)
        return original(self, key, *args, **kw)

    monkeypatch.setattr(h5py.Dataset, "__getitem__", counting)
    check_archive(archive)
    assert len(reads) == 3 * 6          # the full check decodes every checked one (not action)
    reads.clear()
    check_archive(archive, values=False)
    assert reads == []
    run_archive(archive, quiet=True)
    assert len(reads) == len(set(reads)) == 3 * 6


@pytest.mark.parametrize("workers", [1, 2])
@pytest.mark.parametrize("damage, fragment", [
    ("del_attr", "missing attribute 'rate_hz'"),
    ("bad_dtype", "dtype"),
])
def test_a_stage_reports_layout_problems_where_the_trial_runs(archive, workers, damage,
                                                               fragment):
    with h5py.File(archive, "r+") as f:
        if damage == "del_attr":
            del f["/trials/t02"].attrs["rate_hz"]
        else:
            data = f[f"{M}/strain"][()]
            del f[f"{M}/strain"]
            f[f"{M}/strain"] = data.astype(np.int32)
    before = _digest(archive)
    want = validate_archive(archive)[0]
    assert fragment in want.message
    check_archive(archive, values=False, walk_trials=False)   # only the trials hold it
    with pytest.raises(DataError) as err:
        run_archive(archive, quiet=True, workers=workers)
    assert err.value.field == want.path and err.value.message.startswith(want.message)
    assert _digest(archive) == before


def test_the_up_front_check_still_names_missing_trials(archive):
    with pytest.raises(DataError) as err:
        check_archive(archive, trials=["t09"], values=False, walk_trials=False)
    assert err.value.field == "/trials/t09" and "no such trial" in err.value.message
