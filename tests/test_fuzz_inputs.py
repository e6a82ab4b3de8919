"""Property-based fuzzing of every reader of user files (hypothesis).

Archives, CSV files, feature graphs and models files are broken at random from
valid ones; whatever happens must be a success or a DataError naming the file:
never another exception. A success must be usable: an archive that passes the
up-front check reads completely, an imported archive validates, a loaded
models file has a known signal and a positive rate.

`make test` runs a few hundred cases (the ``ci`` profile, derandomised so a
run is repeatable); `make fuzz` runs many more with fresh random draws
(``HYPOTHESIS_PROFILE=fuzz``).
"""

from __future__ import annotations

import copy
import os
import tomllib

import h5py
import numpy as np
import pytest
from conftest import write_archive
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from contactlab.archive import import_csv, open_archive, validate_archive
from contactlab.archive.validate import check_archive
from contactlab.errors import DataError, UsageError
from contactlab.observer.graph import load_graph, parse_graph
from contactlab.observer.training import GraphModels
from contactlab.temporal import ModelSet, TemporalModel

settings.register_profile("ci", max_examples=60, deadline=None, derandomize=True,
                          database=None, print_blob=True,
                          suppress_health_check=[HealthCheck.too_slow,
                                                 HealthCheck.function_scoped_fixture])
settings.register_profile("fuzz", max_examples=1500, deadline=None, database=None,
                          print_blob=True,
                          suppress_health_check=[HealthCheck.too_slow,
                                                 HealthCheck.function_scoped_fixture])
settings.load_profile(os.environ.get("HYPOTHESIS_PROFILE", "ci"))

GRAPH = "datasets_spec/graphs/hf-context-free.toml"


def assert_names_file(err: DataError, path) -> None:
    assert err.file is not None and os.path.basename(str(path)) in err.file, err
    assert "\n" not in str(err), err


# -- values ---------------------------------------------------------------------------

SCALARS = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True), st.integers(-2**63, 2**63 - 1),
    st.booleans(), st.text(max_size=8), st.just(0.0), st.just(-1.0), st.just(1e300))
ATTR_VALUES = st.one_of(
    SCALARS, st.lists(st.floats(allow_nan=True), max_size=4).map(np.array),
    st.lists(st.text(max_size=4), min_size=1, max_size=4))
DTYPES = st.sampled_from(["<f8", "<f4", "<i2", "<i8", "|u1", "<c16", "|S4", "|b1"])


@st.composite
def arrays(draw):
    dtype = np.dtype(draw(DTYPES))
    shape = tuple(draw(st.lists(st.integers(0, 70), min_size=0, max_size=3)))
    if dtype.kind == "S":
        return np.full(shape, b"ab", dtype=dtype)
    values = draw(st.sampled_from([0.0, 1.0, -3.0, np.nan, np.inf, 1e30]))
    with np.errstate(invalid="ignore", over="ignore"):
        arr = np.full(shape, values).astype(dtype) if dtype.kind in "fc" else \
            np.full(shape, 0 if not np.isfinite(values) else values).astype(dtype)
    if arr.size and dtype.kind == "f" and draw(st.booleans()):
        arr.flat[:] = np.cumsum(np.full(arr.size, 0.001))
    return arr


# -- archives -------------------------------------------------------------------------

@pytest.fixture(scope="module")
def archive_bytes(tmp_path_factory):
    path = tmp_path_factory.mktemp("fuzz") / "seed.h5"
    write_archive(path, trials=("t01", "t02"), n=64, chunks=2)
    with h5py.File(path, "a") as f:  # one results stage, as a stage writes it
        g = f.create_group("trials/t01/results/segment")
        g.create_dataset("boundaries_s", data=np.array([0.01, 0.03]))
        g.attrs.update({"created": "2025-01-01T00:00:00Z", "software_version": "0",
                        "parameters": "{}"})
    return path, _names(path)


def _names(path) -> list[str]:
    with h5py.File(path, "r") as f:
        names = []
        f.visit(names.append)
    return sorted(names)


@st.composite
def archive_mutations(draw, names):
    """A list of (operation, HDF5 path, value) edits."""
    ops = []
    for _ in range(draw(st.integers(1, 3))):
        op = draw(st.sampled_from(["attr", "del_attr", "replace", "delete", "soft_link",
                                   "external_link", "group", "resize", "bytes"]))
        target = draw(st.sampled_from(names + ["", "trials/t01"]))
        if op == "attr":
            name = draw(st.sampled_from(["rate_hz", "complete", "units", "names", "columns",
                                         "calibration", "format", "format_version",
                                         "parameters", "seed", "surfaces"]))
            ops.append((op, target, (name, draw(ATTR_VALUES))))
        elif op == "del_attr":
            ops.append((op, target, draw(st.sampled_from(["rate_hz", "units", "names",
                                                          "columns", "format"]))))
        elif op == "replace":
            ops.append((op, target, draw(arrays())))
        elif op == "resize":
            ops.append((op, target, draw(st.sampled_from([0, 1, 2, 10**12]))))
        elif op == "bytes":  # overwrite a few bytes somewhere in the file
            ops.append((op, target, (draw(st.integers(0, 2**20)),
                                     draw(st.binary(min_size=1, max_size=8)))))
        else:
            ops.append((op, target, draw(st.sampled_from(["/nowhere", "/trials/t02"]))))
    return ops


def _apply(path, ops) -> None:
    raw_edits = []
    with h5py.File(path, "r+") as f:
        for op, target, value in ops:
            try:
                obj = f[target] if target else f
                if op == "attr":
                    obj.attrs[value[0]] = value[1]
                elif op == "del_attr":
                    if value in obj.attrs:
                        del obj.attrs[value]
                elif op == "bytes":
                    raw_edits.append(value)
                elif not target:
                    continue
                elif op in ("replace", "delete", "soft_link", "external_link", "group"):
                    attrs = dict(obj.attrs)
                    del f[target]
                    if op == "replace":
                        f.create_dataset(target, data=value)
                    elif op == "soft_link":
                        f[target] = h5py.SoftLink(value)
                    elif op == "external_link":
                        f[target] = h5py.ExternalLink("elsewhere.h5", value)
                    elif op == "group":
                        f.create_group(target)
                    if op in ("replace", "group"):
                        for k, v in attrs.items():
                            f[target].attrs[k] = v
                elif op == "resize" and isinstance(obj, h5py.Dataset) and obj.chunks:
                    obj.resize(value, axis=0)
            except (KeyError, TypeError, ValueError, OSError, RuntimeError):
                continue  # an edit h5py itself refuses is no test case
    if raw_edits:
        data = bytearray(path.read_bytes())
        for offset, chunk in raw_edits:
            offset %= max(len(data) - len(chunk), 1)
            data[offset:offset + len(chunk)] = chunk
        path.write_bytes(bytes(data))


def _read_everything(path) -> None:
    with open_archive(path) as archive:
        for trial in archive:
            _ = (trial.rate_hz, trial.n_samples, trial.duration_s, trial.channels(),
                 trial.labels, trial.label_names, trial.segments, trial.truth_names(),
                 trial.calibration)
            for name in ("strain", "wrench", "position", "velocity", "action", "command"):
                getattr(trial, name)
            for stage in trial.result_stages():
                trial.results(stage)


@given(data=st.data())
def test_archive_check_and_reader(archive_bytes, tmp_path_factory, data):
    seed, names = archive_bytes
    ops = data.draw(archive_mutations(names))
    path = tmp_path_factory.mktemp("case") / "fuzz.h5"
    path.write_bytes(seed.read_bytes())
    _apply(path, ops)
    problems = validate_archive(path)  # never raises
    try:
        check_archive(path)
    except DataError as err:
        assert_names_file(err, path)
        assert problems
        return
    assert problems == []
    try:
        _read_everything(path)
    except DataError as err:  # e.g. a chunk corrupted behind an intact header
        assert_names_file(err, path)


# -- CSV import -------------------------------------------------------------------------

CELLS = st.one_of(st.floats(allow_nan=True, allow_infinity=True).map(repr),
                  st.integers(-10**6, 10**6).map(str), st.just(""),
                  st.text(alphabet="abc ,\"\n-+e.", max_size=5), st.just("nan"))


@st.composite
def csv_texts(draw):
    columns = draw(st.lists(st.sampled_from(["t", "x", "y", "z", "lab", "s0", "s1", "q"]),
                            min_size=1, max_size=7))
    rows = draw(st.lists(st.lists(CELLS, min_size=len(columns), max_size=len(columns)),
                         max_size=8))
    if draw(st.booleans()):  # mostly well-formed numbers, increasing time
        rows = [[f"{i / 100:.2f}"] + [str(draw(st.integers(-3, 5))) for _ in columns[1:]]
                for i in range(draw(st.integers(0, 12)))]
    lines = [",".join(columns)] + [",".join(r) for r in rows]
    return "\n".join(lines) + draw(st.sampled_from(["", "\n", "\n\n"]))


@given(text=csv_texts(), columns=st.sampled_from([
    "time=t;position=x,y,z", "time=t;position=x,y,z;labels=lab", "strain=s*",
    "time=t;strain=s0,s1;labels=lab"]), rate=st.sampled_from([None, 100.0]))
def test_csv_import(tmp_path_factory, text, columns, rate):
    folder = tmp_path_factory.mktemp("csv")
    path = folder / "run.csv"
    path.write_text(text, encoding="utf-8")
    out = folder / "out.h5"
    try:
        import_csv([path], out=out, columns=_map(columns), rate_hz=rate, quiet=True)
    except DataError as err:
        assert_names_file(err, path)
        assert not out.exists()
        return
    except UsageError as err:  # only for what the command line asked: no rate, no time
        assert "rate" in str(err), err
        return
    assert validate_archive(out) == [], validate_archive(out)


def _map(text):
    from contactlab.archive import parse_column_map

    return parse_column_map(text)


# -- feature graphs ----------------------------------------------------------------------

def _paths(doc, prefix=()):
    yield prefix
    if isinstance(doc, dict):
        for k, v in doc.items():
            yield from _paths(v, prefix + (k,))
    elif isinstance(doc, list):
        for i, v in enumerate(doc):
            yield from _paths(v, prefix + (i,))


GRAPH_VALUES = st.one_of(SCALARS, st.lists(SCALARS, max_size=3),
                         st.dictionaries(st.text(max_size=5), SCALARS, max_size=3),
                         st.sampled_from(["H0", "H1", "H0 -> H1", "uniform", "hf",
                                          "telepathy", "temporal", "impact", -0.5, 2.0]))


@given(data=st.data())
def test_graph_documents(data):
    with open(GRAPH, "rb") as f:
        doc = tomllib.load(f)
    for _ in range(data.draw(st.integers(1, 3))):
        paths = [p for p in _paths(doc) if p]
        where = data.draw(st.sampled_from(paths))
        parent = doc
        for key in where[:-1]:
            parent = parent[key]
        if data.draw(st.booleans()) and isinstance(parent, dict):
            del parent[where[-1]]
        else:
            parent[where[-1]] = data.draw(GRAPH_VALUES)
    try:
        parse_graph(copy.deepcopy(doc), source="mutated.toml")
    except DataError as err:
        assert_names_file(err, "mutated.toml")


@given(raw=st.one_of(st.binary(max_size=300), st.text(max_size=300).map(str.encode)))
def test_graph_files_of_any_bytes(tmp_path_factory, raw):
    path = tmp_path_factory.mktemp("graph") / "any.toml"
    path.write_bytes(raw)
    try:
        load_graph(path)
    except DataError as err:
        assert_names_file(err, path)


# -- models files -----------------------------------------------------------------------

@pytest.fixture(scope="module")
def models_bytes(tmp_path_factory):
    path = tmp_path_factory.mktemp("models") / "seed.h5"
    eye = np.tile(np.eye(2), (3, 1, 1))
    models = {label: TemporalModel(label=label, order=1, mean=True, n_blocks=5, block=50,
                                   theta_mean=np.zeros((3, 2)), theta_cov=eye,
                                   structure_sqrt=eye, noise_var=np.ones(3))
              for label in ("H0", "H1")}
    ModelSet(models=models, signal="hf", fs=250.0, provenance={}, channels=[0, 1, 2]).save(path)
    return path, _names(path)


@given(data=st.data())
def test_models_files(models_bytes, tmp_path_factory, data):
    seed, names = models_bytes
    ops = []
    for _ in range(data.draw(st.integers(1, 3))):
        target = data.draw(st.sampled_from(names + [""]))
        kind = data.draw(st.sampled_from(["attr", "replace", "delete", "bytes"]))
        if kind == "attr":
            name = data.draw(st.sampled_from(["signal", "fs", "labels", "channels", "order",
                                              "mean", "label", "block", "n_blocks",
                                              "provenance", "format_version", "reduce"]))
            ops.append(("attr", target, (name, data.draw(ATTR_VALUES))))
        elif kind == "replace":
            ops.append(("replace", target, data.draw(arrays())))
        elif kind == "bytes":
            ops.append(("bytes", target, (data.draw(st.integers(0, 2**16)),
                                          data.draw(st.binary(min_size=1, max_size=8)))))
        else:
            ops.append(("delete", target, None))
    path = tmp_path_factory.mktemp("m") / "models.h5"
    path.write_bytes(seed.read_bytes())
    _apply(path, ops)
    try:
        models = GraphModels.load(path)
    except DataError as err:
        assert_names_file(err, path)
        return
    assert models.signal in ("hf", "strain", "wrench") and models.fs > 0
    assert np.isfinite(models.fs)


def test_fuzz_helpers_break_what_they_claim(archive_bytes, tmp_path):
    """The mutations reach the checks: a replaced time base is reported."""
    seed, _ = archive_bytes
    path = tmp_path / "a.h5"
    path.write_bytes(seed.read_bytes())
    _apply(path, [("replace", "trials/t01/measurements/time", np.zeros(3))])
    with pytest.raises(DataError, match="measurements/time"):
        check_archive(path)


def test_a_models_file_with_a_damaged_root_object_is_a_one_line_error(models_bytes, tmp_path):
    """Zeroed bytes in the root group's header make h5py raise KeyError on its attributes
    (found by ``make fuzz``): a DataError naming the file, like any other damage."""
    seed, _ = models_bytes
    path = tmp_path / "models.h5"
    path.write_bytes(seed.read_bytes())
    _apply(path, [("bytes", "", (108, b"\x00" * 5))])
    with pytest.raises(DataError) as err:
        GraphModels.load(path)
    assert_names_file(err.value, path)
