"""train_temporal / label_archive / ModelSet on small synthetic archives whose
classes are AR processes of known coefficients."""

from __future__ import annotations

import h5py
import numpy as np
import pytest
from scipy.signal import lfilter

from contactlab.archive import create_archive, open_archive, write_results
from contactlab.errors import DataError
from contactlab.temporal import ModelSet, TemporalModel, label_archive, train_temporal
from contactlab.temporal.train import collect_blocks

SEPARATED = {"rough": ([1.2, -0.5], 1.0), "smooth": ([0.2, 0.1], 0.6)}
IDENTICAL = {"left": ([0.9, -0.3], 1.0), "right": ([0.9, -0.3], 1.0)}


def write_ar_archive(path, classes, *, trials=4, seg=2000, channels=3, seed=0, truth=True,
                     rest=0, wrench=False):
    """Each trial: one run of every class in turn (``seg`` raw samples at 1 kHz,
    AR(2) per channel with the class's coefficients and noise sd), optionally
    preceded by ``rest`` samples of a short unlabelled-free "rest" class."""
    rng = np.random.default_rng(seed)
    names = list(classes) + (["rest"] if rest else [])
    with create_archive(path, force=True) as arch:
        for t in range(trials):
            parts, codes = [], []
            if rest:
                parts.append(rng.normal(scale=0.01, size=(rest, channels)))
                codes.append(np.full(rest, len(classes)))
            for code, (a, sd) in enumerate(classes.values()):
                e = rng.normal(scale=sd, size=(seg + 100, channels))
                parts.append(lfilter([1.0], np.r_[1.0, -np.asarray(a)], e, axis=0)[100:])
                codes.append(np.full(seg, code))
            y = np.concatenate(parts)
            tr = arch.add_trial(f"t{t}", rate_hz=1000.0, source="simulator")
            if wrench:
                tr.append(time=np.arange(len(y)) / 1000.0, wrench=np.column_stack(
                    [y, rng.normal(size=(len(y), 6 - channels))]))
            else:
                tr.append(time=np.arange(len(y)) / 1000.0, strain=y)
            if truth:
                tr.set_ground_truth(labels=np.concatenate(codes).astype(np.int16), names=names)
            tr.close()
    return path


@pytest.fixture(scope="module")
def separated(tmp_path_factory):
    return write_ar_archive(tmp_path_factory.mktemp("sep") / "sep.h5", SEPARATED)


def test_blocks_never_span_a_label_change(tmp_path):
    path = write_ar_archive(tmp_path / "a.h5", SEPARATED, trials=2, seg=1030, rest=610)
    b = collect_blocks(path, block=50)
    with open_archive(path) as arch:
        for k in range(len(b)):
            tr = arch.trial(b.trial[k])
            inside = (tr.time >= b.start_s[k]) & (tr.time <= b.end_s[k])
            codes = np.unique(tr.labels[inside])
            assert codes.size == 1 and tr.label_names[codes[0]] == b.label[k]
    # 1030 raw samples -> 257 or 258 at 250 Hz: 5 blocks of 50 per run, never 6
    for t in ("t0", "t1"):
        for c in ("rough", "smooth"):
            assert np.count_nonzero((b.trial == t) & (b.label == c)) == 5


def test_separated_classes_label_perfectly_identical_at_chance(separated, tmp_path):
    models = train_temporal(separated)
    assert models.labels == ["rough", "smooth"] and models.signal == "strain"
    assert models.fs == 250.0 and models.channels == [0, 1, 2]
    for loo in (False, "trial", "block"):
        out = label_archive(separated, models=models, loo=loo)
        assert out["accuracy"] >= 0.97, (loo, out["confusion"])
        mat = np.asarray(out["confusion"]["matrix"])
        assert mat.sum() == out["n_blocks"] == 40
    same = write_ar_archive(tmp_path / "same.h5", IDENTICAL, trials=6, seed=3)
    out = label_archive(same, models=train_temporal(same), loo=True)
    n = out["n_blocks"]
    # chance: binomial(n, 1/2); 4 standard deviations
    assert abs(out["accuracy"] - 0.5) < 4 * np.sqrt(0.25 / n), out["accuracy"]


def test_loo_trial_retrains_without_the_left_out_trial(separated):
    """Leaving a trial out changes the scores of its blocks (the models differ)."""
    models = train_temporal(separated)
    plain = label_archive(separated, models=models)
    loo = label_archive(separated, models=models, loo="trial")
    assert plain["trials"].keys() == loo["trials"].keys()
    only = train_temporal(separated, trials=["t1", "t2", "t3"])
    assert not np.array_equal(only.models["rough"].theta_mean, models.models["rough"].theta_mean)
    assert only.models["rough"].n_blocks == 15


def test_save_load_round_trip_is_bit_identical(separated, tmp_path):
    models = train_temporal(separated, order=3, mean=True, block=80)
    out = tmp_path / "m.h5"
    models.save(out)
    back = ModelSet.load(out)
    assert back.same_as(models)
    for k, m in models.models.items():
        for name in ("theta_mean", "theta_cov", "structure_sqrt", "noise_var"):
            a, b = getattr(m, name), getattr(back.models[k], name)
            assert a.dtype == b.dtype and a.tobytes() == b.tobytes()
    assert back.provenance["archive_sha256"] and back.provenance["order"] == 3
    with pytest.raises(DataError, match="exists"):
        models.save(out)
    models.save(out, force=True)


def test_load_reports_file_and_field(separated, tmp_path):
    out = tmp_path / "m.h5"
    train_temporal(separated).save(out)
    with h5py.File(out, "a") as h5:
        del h5["models/1/theta_cov"]
    with pytest.raises(DataError) as err:
        ModelSet.load(out)
    assert str(out) in str(err.value) and "/models/1/theta_cov" in str(err.value)
    with pytest.raises(DataError, match="not a contactlab models file"):
        ModelSet.load(separated)


def test_model_kalman_filters_with_the_prior(separated):
    models = train_temporal(separated)
    m = models.models["rough"]
    kf = m.kalman(structure="fixed")
    with open_archive(separated) as arch:
        from contactlab.segmentation import conditioned_signal
        y, _, _ = conditioned_signal(arch.trial("t0"), "strain")
    psi, target = m.ar_model.design(y[:100])
    res = kf.filter(psi, target)
    assert res.loglik.shape == (98, 3) and np.isfinite(res.loglik).all()
    np.testing.assert_allclose(kf.theta0, m.theta_mean)


def test_segment_stage_labels_by_majority(separated, tmp_path):
    path = tmp_path / "seg.h5"
    path.write_bytes(separated.read_bytes())
    with open_archive(path) as arch:
        ids = arch.trial_ids
        change = {t: arch.trial(t).time[np.flatnonzero(np.diff(arch.trial(t).labels))[0] + 1]
                  for t in ids}
    for t in ids:    # the true change 0.1 s late, and a spurious boundary
        write_results(path, t, "segment",
                      datasets={"boundaries_s": np.array([0.7, change[t] + 0.1])})
    models = train_temporal(path, labels="segment")
    assert models.provenance["labels"] == "segment"
    assert models.labels == ["rough", "smooth"]
    out = label_archive(path, models=models)
    assert out["labels_source"] == "segment" and out["accuracy"] >= 0.9


@pytest.mark.parametrize("kwargs, match", [
    ({"classes": ["rough", "gravel"]}, "unknown label 'gravel'"),
    ({"classes": ["rough", "rest"]}, "empty class 'rest'"),
    ({"block": 4}, "shorter than AR\\(2\\) needs"),
    ({"block": 4, "mean": True}, "with a mean needs"),
    ({"labels": "segment"}, "no such results stage"),
    ({"trials": ["t9"]}, "no such trial"),
])
def test_bad_training_inputs(tmp_path, kwargs, match):
    path = write_ar_archive(tmp_path / "r.h5", SEPARATED, trials=2, seg=1200, rest=300)
    with pytest.raises(DataError, match=match) as err:
        train_temporal(path, **kwargs)
    assert str(path) in str(err.value)


def test_too_few_blocks_and_no_labels(tmp_path):
    path = write_ar_archive(tmp_path / "few.h5", SEPARATED, trials=1, seg=1000)
    with pytest.raises(DataError, match="needs at least 3"):
        train_temporal(path, classes=["rough", "smooth"], block=100)   # 2 blocks per class
    skipped = train_temporal(path, block=60)     # 4 blocks: enough; 250/60 -> 4
    assert skipped.labels == ["rough", "smooth"]
    with pytest.raises(DataError, match="no class has enough blocks"):
        train_temporal(path, block=100)
    bare = write_ar_archive(tmp_path / "bare.h5", SEPARATED, trials=1, truth=False)
    with pytest.raises(DataError, match="no ground-truth labels"):
        train_temporal(bare)


def test_default_classes_skip_short_ones(tmp_path):
    path = write_ar_archive(tmp_path / "r.h5", SEPARATED, trials=2, seg=1200, rest=300)
    models = train_temporal(path)
    assert models.labels == ["rough", "smooth"] and models.provenance["skipped"] == {"rest": 0}


def test_wrench_only_archive_and_unlabelled_trials(tmp_path):
    path = write_ar_archive(tmp_path / "w.h5", SEPARATED, wrench=True)
    models = train_temporal(path, signal="wrench")
    assert models.channels == list(range(6))
    out = label_archive(path, models=models, loo=True)
    assert out["accuracy"] >= 0.95 and out["predicted_error"] is not None
    bare = write_ar_archive(tmp_path / "bare.h5", SEPARATED, truth=False, wrench=True, trials=1)
    res = label_archive(bare, models=models)
    assert res["accuracy"] is None and res["n_blocks"] == 0
    assert len(res["trials"]["t0"]["predicted"]) == 4000 // 4 // 100
    assert isinstance(models.models["rough"], TemporalModel)
