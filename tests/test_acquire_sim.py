"""The simulator source and the recording loop: determinism, trial subsets, append,
ground truth in the archive, label functions."""

from __future__ import annotations

import numpy as np
import pytest

from contactlab.acquire.record import record
from contactlab.acquire.sim import (LABEL_FUNCTIONS, SimSource, segments_from_labels, trial_seed)
from contactlab.acquire.spec import load_spec
from contactlab.archive import open_archive, validate_archive
from contactlab.errors import UsageError

SPEC = """
name = "quick"
title = "quick strokes"
thesis = "7.2"
rate_hz = 1000.0
duration_s = 0.4
labels = "texture"
[environment]
kind = "sample_a"
[controller]
kind = "stroke"
command_start_s = 0.1
command_s = 0.2
stroke_length_m = 0.002
[vary]
start_jitter_m = [0.001, 0.003, 0.0]
duration_scale = [0.9, 1.1]
[[group]]
name = "a"
trials = 2
[[group]]
name = "b"
trials = 2
environment = { kind = "sample_b" }
"""


@pytest.fixture
def spec(tmp_path):
    p = tmp_path / "quick.toml"
    p.write_text(SPEC)
    return load_spec(p)


def arrays(path):
    with open_archive(path) as archive:
        return {t.id: (t.strain.copy(), t.position.copy(), t.labels.copy(), t.attrs["seed"])
                for t in archive}


def test_trial_seed_depends_on_seed_and_index():
    assert trial_seed(1, 0) == trial_seed(1, 0)
    assert len({trial_seed(s, k) for s in (1, 2) for k in range(5)}) == 10


def test_same_seed_same_archive_other_seed_differs(spec, tmp_path):
    for name, seed in (("a.h5", 5), ("b.h5", 5), ("c.h5", 6)):
        record(SimSource(spec), out=tmp_path / name, n_trials=2, seed=seed, quiet=True)
    a, b, c = (arrays(tmp_path / n) for n in ("a.h5", "b.h5", "c.h5"))
    for tid in a:
        assert np.array_equal(a[tid][0], b[tid][0]) and a[tid][3] == b[tid][3]
        assert not np.array_equal(a[tid][0], c[tid][0])


def test_fewer_trials_are_the_first_trials_and_append_continues(spec, tmp_path):
    record(SimSource(spec), out=tmp_path / "all.h5", n_trials=4, seed=2, quiet=True)
    record(SimSource(spec), out=tmp_path / "part.h5", n_trials=3, seed=2, quiet=True)
    record(SimSource(spec, first=3), out=tmp_path / "part.h5", n_trials=1, seed=2, append=True,
           quiet=True)
    full, part = arrays(tmp_path / "all.h5"), arrays(tmp_path / "part.h5")
    assert list(full) == list(part) == [f"quick-{k:03d}" for k in range(4)]
    for tid in full:
        assert all(np.array_equal(x, y) for x, y in zip(full[tid][:3], part[tid][:3]))
    assert validate_archive(tmp_path / "part.h5") == []
    with open_archive(tmp_path / "part.h5") as archive:
        assert archive.trial("quick-003").attrs["group"] == "b"
        assert archive.trial("quick-000").attrs["environment"] == "sample_a"


def test_refuses_to_overwrite_and_append_needs_a_file(spec, tmp_path):
    out = tmp_path / "x.h5"
    record(SimSource(spec), out=out, n_trials=1, seed=1, quiet=True)
    before = out.read_bytes()
    with pytest.raises(Exception, match="exists"):
        record(SimSource(spec), out=out, n_trials=1, seed=1, quiet=True)
    assert out.read_bytes() == before
    with pytest.raises(UsageError, match="does not exist"):
        record(SimSource(spec), out=tmp_path / "none.h5", n_trials=1, seed=1, append=True)
    with pytest.raises(UsageError, match="added twice"):
        record(SimSource(spec), out=out, n_trials=1, seed=1, append=True, quiet=True)
    assert out.read_bytes() == before  # a failed append leaves the original untouched
    record(SimSource(spec), out=out, n_trials=1, seed=9, force=True, quiet=True)
    assert arrays(out)["quick-000"][3] == trial_seed(9, 0)


def test_ground_truth_is_stored_and_labels_derive_from_it(spec, tmp_path):
    out = tmp_path / "gt.h5"
    record(SimSource(spec), out=out, n_trials=1, seed=4, quiet=True)
    with open_archive(out) as archive:
        t = archive.trial("quick-000")
        assert set(t.truth_names()) >= {"labels", "segments", "contact", "contact_normals",
                                         "moving", "impact", "impact_intervals", "texture"}
        assert t.dataset_attrs("contact", "ground_truth")["surfaces"] == ["floor"]
        assert t.dataset_attrs("texture", "ground_truth")["names"] == [
            "sanded_aluminium_80", "polished_aluminium"]
        names = t.label_names
        labels, moving, tex = t.labels, t.truth("moving"), t.truth("texture")
        assert np.all((labels == 0) == (~moving & ~t.truth("impact")))
        sliding = moving & ~t.truth("impact") & (tex >= 0)
        assert np.array_equal(np.array(names)[labels[sliding]],
                              np.array(names)[3 + tex[sliding]])
        seg = t.segments
        assert seg["start_s"].iloc[0] == t.time[0]
        assert np.all(np.diff(seg["code"].to_numpy()) != 0)
        np.testing.assert_allclose(t.calibration.shape, (6, 8))


class _Fake:
    def __init__(self, contact, moving, impact, surfaces=("floor", "wall_y")):
        self.contact = np.asarray(contact, bool)
        self.moving = np.asarray(moving, bool)
        self.impact = np.asarray(impact, bool)
        self.surfaces = list(surfaces)
        self.contact_mask = (self.contact.astype(int) << np.arange(self.contact.shape[1])).sum(1)
        self.time = np.arange(len(self.moving)) / 1000.0
        self.texture = np.where(self.contact.any(1), 0, -1)
        self.materials = ["rough_wood"]


def test_label_functions():
    r = _Fake(contact=[[0, 0], [0, 0], [1, 0], [1, 0], [1, 1], [1, 1]],
              moving=[0, 1, 0, 1, 0, 0], impact=[0, 0, 0, 0, 1, 0])
    hf, names = LABEL_FUNCTIONS["hf"](r)
    assert names == ["H0", "H1", "H2", "H3"] and hf.tolist() == [0, 1, 2, -1, 3, 2]
    deg, _ = LABEL_FUNCTIONS["constraint"](r)
    assert deg.tolist() == [0, 0, 1, 1, 2, 2]
    codes, names = LABEL_FUNCTIONS["contacts"](r)
    assert [names[c] for c in codes] == ["free-fixed", "free-moving", "floor-fixed",
                                         "floor-moving", "impact", "floor+wall_y-fixed"]
    tex, names = LABEL_FUNCTIONS["texture"](r)
    assert [names[c] for c in tex] == ["rest", "free-motion", "rest", "rough_wood", "impact",
                                       "rest"]


def test_segments_from_labels():
    t = np.arange(6) / 10.0
    assert segments_from_labels(np.array([0, 0, 1, 1, 1, 0]), t, 10.0) == [
        (0.0, 0.2, 0), (0.2, 0.5, 1), (0.5, 0.6, 0)]


def test_maze_is_refused():
    with pytest.raises(UsageError, match="needs maze geometry"):
        SimSource(load_spec("maze"))


def test_validator_checks_truth_shapes_and_writer_checks_lengths(spec, tmp_path):
    import h5py

    from contactlab.archive import create_archive
    from contactlab.errors import DataError

    out = tmp_path / "v.h5"
    record(SimSource(spec), out=out, n_trials=1, seed=4, quiet=True)
    with h5py.File(out, "r+") as f:
        gt = f["trials/quick-000/ground_truth"]
        data = gt["moving"][:-5]
        del gt["moving"]
        gt["moving"] = data
        gt["texture"][0] = 7
    problems = [str(p) for p in validate_archive(out)]
    assert any("ground_truth/moving" in p for p in problems), problems
    assert any("ground_truth/texture" in p and "unknown label code" in p for p in problems)

    with pytest.raises(DataError, match="ground_truth/impact: 3 rows, but time has 4"):
        with create_archive(tmp_path / "w.h5") as archive:
            with archive.add_trial("t", rate_hz=1000.0) as trial:
                trial.append(time=np.arange(4) / 1000.0, wrench=np.zeros((4, 6)))
                trial.set_truth(impact=np.zeros(3, bool))
    with pytest.raises(DataError, match="one surface name per column"):
        with create_archive(tmp_path / "w.h5") as archive:
            trial = archive.add_trial("t", rate_hz=1000.0)
            trial.set_truth(contact=np.zeros((4, 2), bool), surfaces=["floor"])
    assert not (tmp_path / "w.h5").exists()
