"""Training from numpy arrays gives the models training from an archive gives: a graph
(:func:`contactlab.fit_graph` beside :func:`contactlab.train_graph`) and temporal models
(:func:`contactlab.fit_temporal` beside :func:`contactlab.train_temporal`).  The archive
routes are readers in front of the same fits, so the models files hold the same numbers."""

import h5py
import numpy as np
import pytest
from test_free_contact import _archive
from test_recognize import recognition_files

from contactlab import fit_graph, load_graph, train_graph
from contactlab.archive import open_archive
from contactlab.errors import DataError
from contactlab.signals import relabel, trial_signals, truth_codes, window_of


def _datasets(path):
    """Every dataset of a models file (provenance attributes aside)."""
    out = {}
    with h5py.File(path, "r") as f:
        f.visititems(lambda name, obj: out.__setitem__(name, obj[()])
                     if isinstance(obj, h5py.Dataset) else None)
    return out


def _from_archive(path, graph, signals, label_map=None, reduce="mean"):
    """The recordings of ``path`` as arrays: conditioned signals and label codes per
    signal, as a notebook user would pass them."""
    recs, labels = [], None
    with open_archive(path) as arch:
        for tid in arch.trial_ids:
            trial = relabel(arch.trial(tid), label_map)
            labels = [n for n in trial.label_names if n is not None]
            data, index, fs = trial_signals(trial, signals, reduce=reduce)
            codes = {s: truth_codes(trial, index, labels, window=window_of(s, trial.rate_hz))
                     for s in signals}
            recs.append((data, codes))
    return recs, labels, fs


def _same_files(a, b):
    da, db = _datasets(a), _datasets(b)
    assert sorted(da) == sorted(db) and da
    for k in da:
        assert np.array_equal(da[k], db[k], equal_nan=True), k


def test_temporal_and_impact_models_from_arrays_equal_the_archive_route(tmp_path):
    files = recognition_files(tmp_path)
    graph = load_graph(files["graph"])
    kw = dict(order=1, mean=True, block=100, reduce="mean")
    recs, labels, fs = _from_archive(files["train"], graph, ["hf"])
    fit_graph(graph, recs, fs=fs, labels=labels, **kw).save(tmp_path / "arrays.h5")
    _same_files(files["models"], tmp_path / "arrays.h5")


def test_constraint_and_velocity_models_from_arrays_equal_the_archive_route(tmp_path):
    train = _archive(tmp_path, "rec", 11, 200.0)
    label_map = {"1": "free", "2": "contact", "3": "free"}
    graph = load_graph("free-contact")
    train_graph(train, graph, label_map=label_map).save(tmp_path / "archive.h5")
    signals = sorted({m.signal for m in graph.models.values()})
    recs, labels, fs = _from_archive(train, graph, signals, label_map)
    fit_graph(graph, recs, fs=fs, labels=labels).save(tmp_path / "arrays.h5")
    _same_files(tmp_path / "archive.h5", tmp_path / "arrays.h5")


def test_a_label_the_arrays_lack_is_a_one_line_error():
    graph = load_graph("free-contact")
    y = np.zeros((50, 3))
    with pytest.raises(DataError) as err:
        fit_graph(graph, [({"contact-compensated": np.zeros((50, 6)), "velocity": y,
                            "position": y, "wrench": np.zeros((50, 6))},
                           np.zeros(50, np.int64))], fs=100.0, labels=["free"])
    assert "no label 'contact'" in str(err.value)


def test_temporal_models_from_arrays_equal_the_archive_route(tmp_path):
    from conftest import write_archive

    from contactlab import fit_temporal, train_temporal
    from contactlab.temporal.blocks import load_signal

    path = tmp_path / "a.h5"
    write_archive(path, trials=[f"t{i}" for i in range(3)], n=6000)
    kw = dict(order=2, mean=True, block=100)
    train_temporal(path, **kw).save(tmp_path / "archive.h5")
    recs = []
    with open_archive(path) as arch:
        for tid in arch.trial_ids:
            trial = arch.trial(tid)
            sig = load_signal(trial, "strain")
            recs.append((sig.y, truth_codes(trial, sig.index)))
            labels, fs = list(trial.label_names), sig.fs
    fit_temporal(recs, labels=labels, fs=fs, signal="strain", **kw).save(tmp_path / "arrays.h5")
    _same_files(tmp_path / "archive.h5", tmp_path / "arrays.h5")


def test_arrays_missing_a_signal_or_with_wrong_codes_are_one_line_errors():
    graph = load_graph("free-contact")
    y = {"contact-compensated": np.zeros((50, 6)), "velocity": np.zeros((50, 3))}
    with pytest.raises(ValueError, match="recording 0 lacks signal 'velocity'"):
        fit_graph(graph, [({"contact-compensated": y["contact-compensated"]},
                           np.zeros(50, np.int64))], fs=100.0, labels=["free", "contact"])
    with pytest.raises(ValueError, match="one index into labels"):
        fit_graph(graph, [(y, np.full(50, 2))], fs=100.0, labels=["free", "contact"])


def test_temporal_codes_outside_the_labels_are_a_one_line_error():
    from contactlab import fit_temporal

    y = np.random.default_rng(0).normal(size=1000)
    with pytest.raises(ValueError, match="one index into labels"):
        fit_temporal([(y, np.full(1000, 3))], labels=["a", "b"], fs=1000.0)
