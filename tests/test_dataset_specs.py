"""Dataset specs: every bundled spec loads, simulates a short trial and validates;
bad specs give one-line errors naming the file and the key."""

from __future__ import annotations

import re

import pytest

from contactlab.acquire.sim import SimSource
from contactlab.acquire.spec import list_specs, load_spec, spec_dir
from contactlab.acquire.record import record
from contactlab.archive import open_archive, validate_archive
from contactlab.errors import DataError, UsageError

#: The thesis's trial counts (EXPERIMENTS.md / thesis sections in the spec comments).
THESIS_COUNTS = {"stroke-a": 8, "stroke-b": 8, "hf-train": 15, "hf-test": 12, "cartesian": 16,
                 "guarded-move": 10, "guarded-move-actions": 20, "impact-spectrogram": 1,
                 "maze": 21}

GOOD = """
name = "tiny"
title = "t"
thesis = "7.2"
rate_hz = 1000.0
duration_s = 0.2
labels = "hf"
[environment]
kind = "plane"
[controller]
kind = "position"
moves = [{ displacement_m = [0.0, 0.0, -0.015], duration_s = 0.1, start_s = 0.0 }]
[[group]]
name = "g"
trials = 2
"""


def test_bundled_specs_are_all_there():
    names = set(list_specs())
    assert set(THESIS_COUNTS) | {"guarded-move-multi", "maze"} <= names


@pytest.mark.parametrize("name", sorted(THESIS_COUNTS))
def test_trial_counts_match_the_thesis(name):
    spec = load_spec(name)
    assert spec.n_trials == THESIS_COUNTS[name] == spec.thesis_trials


def test_group_structure_follows_the_thesis():
    assert [g.trials for g in load_spec("hf-train").groups] == [5, 5, 5]
    assert [g.move_duration_s for g in load_spec("hf-test").groups] == [(0.5, 1.0, 2.0)] * 4
    assert [g.trials for g in load_spec("guarded-move").groups] == [3, 3, 4]
    assert [g.name for g in load_spec("cartesian").groups] == ["free", "plane", "line", "corner"]
    assert load_spec("impact-spectrogram").rate_hz == 2700.0
    maze = load_spec("maze")
    assert [g.trials for g in maze.groups] == [20, 1] and maze.labels == "maze"
    assert all(g.goal_region_m is not None and g.start_m is not None for g in maze.groups)
    assert maze.action_names[1] == "action-1" and len(maze.action_names) == 9   # 8 commands


def as_acquired(name, tmp_path):
    """A bundled spec as ``contactlab acquire`` runs it: a spec still carrying a ``status``
    line (the maze, until the lead enables it) is loaded from a copy without it."""
    spec = load_spec(name)
    if spec.ready:
        return spec
    p = tmp_path / f"{name}.toml"
    lines = spec.path.read_text().splitlines()
    p.write_text("\n".join(line for line in lines
                           if not line.startswith("status =") and "test_acquire_cli" not in line))
    spec = load_spec(p)
    assert spec.ready
    return spec


def test_every_value_line_carries_a_comment_or_is_documented():
    # every spec file names thesis sections in its comments
    for path in spec_dir().glob("*.toml"):
        text = path.read_text()
        assert re.search(r"# .*\b[0-9]\.[0-9]", text), path


@pytest.mark.parametrize("name", [n for n in sorted(THESIS_COUNTS) + ["guarded-move-multi"]])
def test_every_spec_simulates_and_validates(name, tmp_path):
    spec = as_acquired(name, tmp_path)
    # one short trial of every group
    short = spec.__class__(**{**spec.__dict__, "groups": tuple(
        g.__class__(**{**g.__dict__, "duration_s": min(g.duration_s, 0.6)}) for g in spec.groups)})
    firsts = []
    k = 0
    for g in short.groups:
        firsts.append(k)
        k += g.trials
    out = tmp_path / f"{name}.h5"
    for i, k in enumerate(firsts):
        record(SimSource(short, first=k), out=out, n_trials=1, seed=3, append=i > 0, quiet=True)
    assert validate_archive(out) == []
    with open_archive(out) as archive:
        assert len(archive) == len(spec.groups)
        trial = archive.trial(f"{name}-000")
        n = trial.n_samples
        assert trial.labels is not None and len(trial.labels) == n
        assert trial.truth("contact").shape[0] == n and trial.truth("contact").dtype == bool
        assert trial.truth("contact_normals").shape[1:] == (trial.truth("contact").shape[1], 3)
        assert trial.truth("texture").shape == (n,)
        assert trial.truth("impact_intervals").shape[1] == 2
        assert trial.rate_hz == spec.rate_hz


def write(tmp_path, text, name="tiny.toml"):
    p = tmp_path / name
    p.write_text(text)
    return p


@pytest.mark.parametrize("edit, key", [
    (lambda s: s.replace('labels = "hf"', 'labels = "nope"'), "labels"),
    (lambda s: s.replace("rate_hz = 1000.0", "rate_hz = -1.0"), "rate_hz"),
    (lambda s: s.replace("rate_hz = 1000.0", 'rate_hz = "fast"'), "rate_hz"),
    (lambda s: s.replace('kind = "plane"', 'kind = "moon"'), "group[0].environment.kind"),
    (lambda s: s.replace('kind = "plane"', 'kind = "plane"\ncolour = 3'),
     "group[0].environment.colour"),
    (lambda s: s.replace('kind = "position"', 'kind = "telepathy"'), "group[0].controller.kind"),
    (lambda s: s.replace("trials = 2", "trials = 0"), "group[0].trials"),
    (lambda s: s.replace("displacement_m = [0.0, 0.0, -0.015]", "displacement_m = [0.0]"),
     "group[0].controller.moves[0].displacement_m"),
    (lambda s: "bogus = 1\n" + s, "bogus"),
    (lambda s: s.replace('name = "g"\n', ""), "group[0].name"),
    (lambda s: s + "goal_region_m = [[0.0, 0.0], [-1.0, 1.0]]\n", "group[0].goal_region_m"),
    (lambda s: s + "goal_region_m = [0.0, 1.0]\n", "group[0].goal_region_m"),
    (lambda s: s + "vary = { force_angle_deg = 95.0 }\n", "group[0].vary.force_angle_deg"),
    (lambda s: s + 'vary = { force_angle_deg = "a bit" }\n', "group[0].vary.force_angle_deg"),
])
def test_bad_specs_are_one_line_errors_naming_file_and_key(tmp_path, edit, key):
    path = write(tmp_path, edit(GOOD))
    with pytest.raises(DataError) as err:
        load_spec(path)
    msg = str(err.value)
    assert "\n" not in msg
    assert msg.startswith(str(path)) and f": {key}: " in msg, msg


def test_not_toml_and_unknown_names(tmp_path):
    with pytest.raises(DataError, match="not valid TOML"):
        load_spec(write(tmp_path, "name = ["))
    with pytest.raises(UsageError, match="unknown dataset spec 'nope'"):
        load_spec("nope")
    assert load_spec(write(tmp_path, GOOD)).n_trials == 2


def test_datasets_experiment_draws_every_ready_spec(tmp_path):
    from contactlab.experiments import EXPERIMENTS

    exp = EXPERIMENTS["datasets"]
    assert exp.implemented and exp.part == "Simulator and acquire"
    summary = exp.run(out_dir=tmp_path, seed=2, quiet=True)
    ready = [n for n in list_specs() if load_spec(n).ready]
    assert summary["valid"] and summary["simulated"] == ready
    assert summary["not_simulated"] == {n: load_spec(n).status for n in list_specs()
                                        if not load_spec(n).ready}
    for name in ready:
        assert (tmp_path / f"{name}-trial.png").exists()
    assert (tmp_path / "index.html").exists() and (tmp_path / "report.pdf").exists()
    assert not list(tmp_path.glob("*.h5"))
