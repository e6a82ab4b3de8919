"""The simulator source and the recording loop: determinism, trial subsets, append,
ground truth in the archive, label functions."""

from __future__ import annotations

import numpy as np
import pytest

from contactlab.acquire.record import record
from contactlab.acquire.sim import (LABEL_FUNCTIONS, MAZE_WALLS, SimSource, maze_corners,
                                    plan_trial, reached_goal, segments_from_labels,
                                    simulate_trial, trial_seed)
from contactlab.acquire.spec import load_spec, spec_dir
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


def test_a_spec_with_a_status_is_refused_naming_it(tmp_path):
    p = tmp_path / "quick.toml"
    p.write_text(SPEC.replace('labels = "texture"', 'labels = "texture"\nstatus = "needs a lathe"'))
    with pytest.raises(UsageError, match="cannot be simulated yet: needs a lathe"):
        SimSource(load_spec(p))


def maze_spec(tmp_path):
    """The bundled maze spec as `contactlab acquire --spec maze` runs it (any ``status``
    line removed, so the test also covers the spec before the lead enables it)."""
    text = (spec_dir() / "maze.toml").read_text()
    p = tmp_path / "maze.toml"
    p.write_text("\n".join(line for line in text.splitlines()
                           if not line.startswith("status =")
                           and "needs maze geometry\" case" not in line) + "\n")
    spec = load_spec(p)
    assert spec.ready
    return spec


def test_maze_trials_travel_from_partition_57_to_5_and_back(tmp_path):
    """9.2: action 1 takes the finger from 57 (the tail's end) to 5 (the right leg's upper
    end) through the neutral crossbar; action 5 brings it back. Trial 0 and the return."""
    spec = maze_spec(tmp_path)
    assert [(g.name, g.trials) for g in spec.groups] == [("action-1-from-57", 20),
                                                         ("action-5-back", 1)]
    expected = {0: ("tail-left+tail-end-fixed", "tail-right-moving", "right-leg-outer-moving",
                    "right-leg-outer+right-leg-top-fixed"),
                20: ("right-leg-outer+right-leg-top-fixed", "right-leg-inner-high-moving",
                     "tail-left-moving", "tail-left+tail-end-fixed")}
    for k, features in expected.items():
        plan, r = simulate_trial(spec, k, seed=5)
        group, _ = spec.group_of(k)
        assert reached_goal(group, r.fingertip_position)
        (xl, yl), (xh, yh) = group.goal_region_m
        x0, y0 = r.fingertip_position[0, :2]
        assert not (xl <= x0 <= xh and yl <= y0 <= yh)        # it did travel
        codes, names = LABEL_FUNCTIONS["maze"](r)
        seq = [names[c] for _, _, c in segments_from_labels(codes, r.time, r.rate_hz)]
        positions = [seq.index(f) for f in features]            # in this order
        assert positions == sorted(positions), seq
        assert seq[-1] == features[-1]                          # resting in the end corner
        # no spurious kick from a grazed convex corner: forces stay at the command's scale
        assert np.abs(r.wrench[1000:, :3]).max() < 3.0
        assert r.fingertip_position[1000:, 2].max() < 0.0101
        assert list(plan.actions) == ([0, 5, 1] if k == 0 else [0, 1, 5])


def test_maze_trials_vary_start_and_force_direction_within_the_declared_ranges(tmp_path):
    spec = maze_spec(tmp_path)
    group = spec.groups[0]
    angles, starts = [], []
    for k in range(6):
        plan = plan_trial(spec, k, seed=1)
        f = np.asarray(plan.controller.forces[-1][1])
        angles.append(np.degrees(np.arctan2(f[1], f[0])))
        assert np.hypot(f[0], f[1]) == pytest.approx(0.2, abs=1e-3) and f[2] == -0.2
        starts.append(plan.start)
    assert np.ptp(angles) > 0.1 and all(45.0 - 1e-6 <= a <= 46.0 + 1e-6 for a in angles)
    d = np.abs(np.array(starts) - np.asarray(group.start_m))
    assert np.all(d[:, :2] <= 0.0015 + 1e-12) and np.all(d[:, 2] == 0) and d.max() > 1e-4
    assert plan_trial(spec, 3, seed=1).start.tolist() == starts[3].tolist()


def test_maze_archive_records_whether_the_goal_was_reached(tmp_path):
    import dataclasses

    spec = maze_spec(tmp_path)
    short = dataclasses.replace(spec, groups=tuple(dataclasses.replace(g, duration_s=0.3)
                                                   for g in spec.groups))
    out = tmp_path / "maze.h5"
    record(SimSource(short), out=out, n_trials=1, seed=2, quiet=True)
    assert validate_archive(out) == []
    with open_archive(out) as archive:
        t = archive.trial("maze-000")
        assert not t.attrs["goal_reached"]           # 0.3 s: still at the start
        assert t.label_names[0] == "impact" and "tail-end+tail-right-fixed" in t.label_names


def test_maze_wall_names_and_corners_match_the_outline():
    from contactlab.sim.environment import maze_outline

    pts = np.asarray(maze_outline())
    assert len(MAZE_WALLS) == len(pts)
    mid = (pts + np.roll(pts, -1, axis=0)) / 2.0
    for name, (x, y) in zip(MAZE_WALLS, mid):
        if name.startswith("left-leg"):
            assert x < -0.010, name
        if name.startswith("right-leg"):
            assert x > 0.010, name
        if name.startswith("tail"):
            assert abs(x) <= 0.010 and y < -0.010, name
        if name.startswith("crossbar"):
            assert abs(y) == pytest.approx(0.010), name
        if name.endswith(("-top", "-high")) and not name.startswith("crossbar"):
            assert y > 0.010, name
    # an H with a tail: 16 walls, 10 inside corners (2 at each leg end, 2 at the tail end)
    corners = [(MAZE_WALLS[a], MAZE_WALLS[b]) for a, b in maze_corners()]
    assert len(corners) == 10 and ("tail-left", "tail-end") in corners
    assert ("crossbar-high", "left-leg-inner-high") not in corners    # a convex corner


def test_maze_labels():
    surfaces = ["floor"] + [f"wall_{i:02d}" for i in range(16)]
    # column j + 1 is wall_j (wall_03 tail-left, wall_04 tail-end, wall_09/10 right leg)
    rows = [[], [0], [0, 4], [0, 4], [4, 5], [0, 10, 11], [12, 14], [0, 4]]
    contact = np.zeros((len(rows), 17), int)
    for i, row in enumerate(rows):
        contact[i, row] = 1
    r = _Fake(contact=contact, moving=[0, 1, 0, 1, 0, 0, 1, 0],
              impact=[0, 0, 0, 0, 0, 0, 0, 1], surfaces=surfaces)
    codes, names = LABEL_FUNCTIONS["maze"](r)
    assert [names[c] for c in codes] == [
        "lifted-fixed", "channel-moving", "tail-left-fixed", "tail-left-moving",
        "tail-left+tail-end-fixed", "right-leg-outer+right-leg-top-fixed", "other-moving",
        "impact"]
    assert len(names) == len(set(names)) == 1 + 2 * (2 + 16 + 10 + 1)


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


def test_force_zeroed_spec_records_the_wrench_less_its_rest_reading(tmp_path):
    # 8.1.1's "calibrated and zeroed" sensor: at rest in free space the recorded force is
    # zero instead of the shell's weight; the strains are the sensor's own
    from contactlab.sim import constants as C
    text = """
name = "rest"
title = "rest"
thesis = "8.1.1"
rate_hz = 1000.0
duration_s = 0.3
labels = "contacts"
{flag}
[environment]
kind = "free_space"
[controller]
kind = "position"
moves = []
[[group]]
name = "a"
trials = 1
"""
    out = {}
    for flag in ("", "force_zeroed = true"):
        p = tmp_path / f"rest{len(flag)}.toml"
        p.write_text(text.format(flag=flag))
        path = tmp_path / f"rest{len(flag)}.h5"
        record(SimSource(load_spec(p)), out=path, n_trials=1, seed=2)
        with open_archive(path) as archive:
            t = archive.trial(archive.trial_ids[0])
            out[bool(flag)] = (t.wrench.copy(), t.strain.copy())
    weight = C.SHELL_MASS * C.GRAVITY
    assert out[False][0][:, 2].mean() == pytest.approx(-weight, rel=0.05)
    assert abs(out[True][0][:, 2].mean()) < 0.02 * weight
    np.testing.assert_allclose(out[True][0][:, :3].mean(axis=0), 0.0, atol=0.02 * weight)
    np.testing.assert_array_equal(out[True][1], out[False][1])


def test_force_zeroed_must_be_a_boolean(tmp_path):
    from contactlab.errors import DataError
    p = tmp_path / "quick.toml"
    p.write_text(SPEC.replace('labels = "texture"', 'labels = "texture"\nforce_zeroed = 1'))
    with pytest.raises(DataError) as err:
        load_spec(p)
    assert "force_zeroed" in str(err.value) and "\n" not in str(err.value)
