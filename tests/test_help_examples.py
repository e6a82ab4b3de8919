"""Every example in every verb's --help runs, parsed out of the help text itself.

The examples run in pipeline order in one scratch directory, so the files one
example writes (models.h5, strokes.h5) are the inputs of later ones; the
archives they start from are small synthetic ones made here.  Examples that
need hardware or take minutes are listed in SKIP with the reason (3 of 45).  Verbs that
run on what earlier examples wrote (train hf.h5 after acquire --out hf.h5) use
those files; the examples' repository paths resolve through a link to
datasets_spec/.
"""

from __future__ import annotations

import re
import shlex
import shutil
from pathlib import Path

import click
import numpy as np
import pytest
from click.testing import CliRunner

from conftest import LABEL_NAMES, synthetic_labels, synthetic_measurements
from contactlab.archive import create_archive
from contactlab.cli import main

REPO = Path(__file__).resolve().parents[1]
ORDER = ["acquire", "import", "validate", "info", "segment", "train", "label", "estimate",
         "recognize", "watch", "report", "reproduce", "graph"]
SKIP = {
    "--source netft": "needs a Net F/T sensor on the network",
    "--source phantom": "needs a PHANToM and its HD library",
    "reproduce --all": "runs every experiment for minutes: 'make reproduce'",
}


def help_examples(command: click.Command, path: list[str]) -> list[str]:
    """The example command lines of ``contactlab PATH --help`` (continuations joined)."""
    text = CliRunner().invoke(main, [*path, "--help"], terminal_width=200).output
    lines, out, i = text.splitlines(), [], 0
    while i < len(lines):
        if re.match(r"^\s*Examples?:\s*$", lines[i]):
            i += 1
            while i < len(lines) and lines[i].strip():
                line = lines[i].strip()
                while line.endswith("\\") and i + 1 < len(lines):
                    i += 1
                    line = line[:-1].rstrip() + " " + lines[i].strip()
                out.append(line)
                i += 1
        i += 1
    return out


def _all_examples() -> list[tuple[str, str]]:
    found = []
    for verb in ORDER:
        cmd = main.commands[verb]
        subs = [([verb], cmd)] + ([([verb, n], c) for n, c in cmd.commands.items()]
                                  if isinstance(cmd, click.Group) else [])
        for path, c in subs:
            found += [(" ".join(path), e) for e in help_examples(c, path)]
    return found


EXAMPLES = _all_examples()


def test_every_verb_has_examples_and_they_are_well_formed():
    verbs = {v.split()[0] for v, _ in EXAMPLES}
    assert verbs == set(ORDER) == {n for n, c in main.commands.items() if not c.hidden}
    for _, line in EXAMPLES:
        assert line.startswith("contactlab ") and "  " not in line, line


def _write_runs(path: Path) -> None:
    """Three small labelled trials (ids the examples name) with every measurement."""
    with create_archive(path, title="help examples") as archive:
        for i, tid in enumerate(("t001", "stroke-a-000", "cartesian-004")):
            d = synthetic_measurements(3000, seed=i)
            trial = archive.add_trial(tid, rate_hz=1000.0, controller="position",
                                      environment="plane", seed=i, source="simulator",
                                      calibration=d["calibration"])
            trial.append(**{k: d[k] for k in ("time", "strain", "wrench", "position",
                                              "velocity")})
            labels, segments = synthetic_labels(d["time"])
            trial.set_ground_truth(labels=labels, names=LABEL_NAMES, segments=segments)
            trial.close()


def _write_hf(path: Path, n_trials: int, seed: int) -> None:
    """Labelled 8-gauge runs of the four high-frequency states (7.3) and an action
    channel: a noise level per state, impacts whose log-amplitude decays linearly."""
    rng = np.random.default_rng(seed)
    fs = 1000.0
    plan = [("H0", 1.0, 0.002), ("H1", 1.0, 0.006), ("H3", 0.15, None), ("H2", 1.2, 0.003)]
    names = ["H0", "H1", "H2", "H3"]
    moving = {"H0": 0, "H1": 1, "H3": 1, "H2": 0}       # action codes: rest 0, move 1
    with create_archive(path, title="hf states") as archive:
        for k in range(n_trials):
            parts, labels, actions = [], [], []
            for name, dur, sd in plan:
                m = int(dur * fs)
                if sd is None:
                    sd = 0.2 * np.exp(-np.arange(m) / (0.03 * fs))[:, None] + 0.003
                parts.append(rng.normal(size=(m, 8)) * sd)
                labels.append(np.full(m, names.index(name), np.int16))
                actions.append(np.full(m, moving[name], np.int16))
            s = np.vstack(parts)
            tr = archive.add_trial(f"hf-{k:03d}", rate_hz=fs, controller="position",
                                   environment="free", seed=k, source="simulator",
                                   action_names=["rest", "move"])
            tr.append(time=np.arange(len(s)) / fs, strain=s, action=np.concatenate(actions))
            tr.set_ground_truth(labels=np.concatenate(labels), names=names)
            tr.close()


def _write_csvs(root: Path) -> None:
    rng = np.random.default_rng(0)
    t = np.arange(400) / 200.0
    cols = {"t": t, **{c: rng.normal(size=t.size) for c in ("fx", "fy", "fz", "tx", "ty",
                                                           "tz", "x", "y", "z")}}
    state = np.where(t < 1.0, "free", "contact")
    for name in ("run1.csv", "run2.csv"):
        lines = [",".join([*cols, "state"])]
        lines += [",".join([*(f"{cols[c][k]:.6g}" for c in cols), state[k]])
                  for k in range(t.size)]
        (root / name).write_text("\n".join(lines) + "\n")
    # a spreadsheet export of many locales: semicolons, decimal commas
    lines = [";".join(cols)] + [";".join(f"{cols[c][k]:.6f}".replace(".", ",") for c in cols)
                                for k in range(t.size)]
    (root / "run-eu.csv").write_text("\n".join(lines) + "\n")
    # a robot arm's log: a repeated time stamp, the tool's roll, pitch and yaw
    arm = {c: v.copy() for c, v in cols.items()}
    arm["t"][101] = arm["t"][100]
    arm.update(roll=0.1 + 0 * t, pitch=-1.3 + 0 * t, yaw=0.01 * t)
    lines = [",".join(arm)] + [",".join(f"{arm[c][k]:.6g}" for c in arm) for k in range(t.size)]
    (root / "arm.csv").write_text("\n".join(lines) + "\n")
    (root / "strokes").mkdir()
    for k in range(2):
        s = rng.normal(size=(500, 8))
        (root / "strokes" / f"stroke{k}.csv").write_text(
            ",".join(f"s{j}" for j in range(8)) + "\n"
            + "\n".join(",".join(f"{v:.6g}" for v in row) for row in s) + "\n")
    (root / "columns.json").write_text(
        '{"time": "t", "wrench": ["fx", "fy", "fz", "tx", "ty", "tz"], "labels": "state"}')
    shutil.copy(REPO / "datasets_spec" / "hf-test.toml", root / "my-spec.toml")
    text = (root / "my-spec.toml").read_text()
    (root / "my-spec.toml").write_text(text.replace('name = "hf-test"', 'name = "my-spec"', 1))


def _write_wrist(root: Path) -> None:
    """A wrench-and-position recording of a hand-held tool (free-contact examples)."""
    import pandas as pd

    from contactlab.synthetic.free_contact import free_contact_recording

    rec = free_contact_recording(seed=5, fs=100.0, cycles=3)
    cols = rec.csv_columns()
    cols["state"] = [("free", "contact", "free")[c - 1] for c in cols["state"]]
    pd.DataFrame(cols).to_csv(root / "wrist.csv", index=False)
    r = CliRunner().invoke(main, ["import", str(root / "wrist.csv"), "--out",
                                  str(root / "wrist.h5"), "-q", "--columns",
                                  "time=t;wrench=fx,fy,fz,tx,ty,tz;position=x,y,z;labels=state"])
    assert r.exit_code == 0, r.output


@pytest.fixture(scope="module")
def scratch(tmp_path_factory):
    root = tmp_path_factory.mktemp("examples")
    (root / "datasets_spec").symlink_to(REPO / "datasets_spec")  # the examples' repo paths
    _write_runs(root / "runs.h5")
    _write_hf(root / "train.h5", 4, seed=0)
    _write_hf(root / "test.h5", 2, seed=1)
    _write_csvs(root)
    _write_wrist(root)
    return root


def _reason(line: str) -> str | None:
    return next((why for key, why in SKIP.items() if key in line), None)


@pytest.mark.parametrize("verb,line", EXAMPLES, ids=[e for _, e in EXAMPLES])
def test_help_example_runs(verb, line, scratch, monkeypatch):
    why = _reason(line)
    if why:
        pytest.skip(why)
    monkeypatch.chdir(scratch)
    args = shlex.split(line)[1:]
    expanded = []
    for a in args:     # what a shell does with the import example's glob
        expanded += sorted(str(p.relative_to(scratch)) for p in scratch.glob(a)) \
            if "*" in a and "=" not in a else [a]
    result = CliRunner().invoke(main, expanded)
    assert result.exit_code == 0, f"{line}\n{result.output}"
    if "--json" in args:
        import json
        assert isinstance(json.loads(result.stdout), dict)
