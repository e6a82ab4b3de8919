"""The CLI's shared behaviour: help with examples, exit codes, one-line errors."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest
from click.testing import CliRunner

from contactlab.cli import main
from contactlab.experiments import EXPERIMENTS

VERBS = ["acquire", "validate", "import", "info", "segment", "label", "estimate", "train",
         "recognize", "report", "reproduce", "graph"]


@pytest.mark.parametrize("verb", VERBS)
def test_every_verb_has_help_with_an_example(verb):
    result = CliRunner().invoke(main, [verb, "--help"])
    assert result.exit_code == 0
    assert "Example" in result.output
    assert f"contactlab {verb}" in result.output


@pytest.mark.parametrize("args", [
    ["segment", "x.h5"], ["label", "x.h5", "--models", "x.h5"], ["estimate", "x.h5"],
    ["train", "x.h5", "--labels", "truth", "--out", "m.h5"], ["validate", "x.h5"],
    ["info", "x.h5"], ["report", "x.h5", "--out", "r"], ["graph", "show", "x.toml"],
])
def test_a_missing_input_is_one_line_naming_it(args, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    result = CliRunner().invoke(main, args)
    assert result.exit_code in (1, 2)
    assert len(result.stderr.strip().splitlines()) == 1
    assert args[-1 if args[0] == "graph" else 1] in result.stderr
    assert "Traceback" not in result.stderr


def test_reproduce_list_json_names_every_experiment():
    result = CliRunner().invoke(main, ["reproduce", "--list", "--json"])
    assert result.exit_code == 0
    listed = {e["name"]: e["status"] for e in json.loads(result.stdout)["experiments"]}
    assert set(listed) == set(EXPERIMENTS)
    assert listed["ph-demo"] == "implemented"


@pytest.mark.parametrize("args, fragment", [
    (["reproduce", "no-such-experiment"], "unknown experiment"),
    (["reproduce"], "--all"),
])
def test_reproduce_usage_errors_exit_2_in_one_line(args, fragment):
    result = CliRunner().invoke(main, args)
    assert result.exit_code == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and fragment in lines[0]


def test_an_experiment_not_reproduced_yet_is_a_usage_error(monkeypatch):
    from contactlab.experiments import EXPERIMENTS, Experiment

    monkeypatch.setitem(EXPERIMENTS, "future-task", Experiment(
        "future-task", "A task", "9.9", "Tasks"))
    result = CliRunner().invoke(main, ["reproduce", "future-task"])
    assert result.exit_code == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and "not reproduced yet" in lines[0]


def test_missing_archive_is_a_one_line_data_error_without_traceback(tmp_path):
    missing = tmp_path / "nope.h5"
    proc = subprocess.run([sys.executable, "-m", "contactlab", "report", str(missing)],
                          capture_output=True, text=True)
    assert proc.returncode == 1
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1, proc.stderr
    assert "nope.h5" in lines[0]
    assert "Traceback" not in proc.stderr


def test_debug_shows_the_traceback(tmp_path):
    missing = tmp_path / "nope.h5"
    proc = subprocess.run([sys.executable, "-m", "contactlab", "--debug", "report", str(missing)],
                          capture_output=True, text=True)
    assert proc.returncode != 0
    assert "Traceback" in proc.stderr


@pytest.mark.parametrize("args", [["info"], ["reproduce", "--seed", "x"], ["nosuchverb"],
                                  ["validate", "--nosuchoption", "a.h5"]])
def test_click_usage_errors_are_one_line_with_exit_2(args):
    proc = subprocess.run([sys.executable, "-m", "contactlab", *args], capture_output=True,
                          text=True)
    assert proc.returncode == 2
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and "error" in lines[0], proc.stderr


def test_recognise_is_accepted_as_recognize_and_validate_takes_several(tmp_path):
    from conftest import write_archive

    res = CliRunner().invoke(main, ["recognise", "--help"])
    assert res.exit_code == 0 and "--graph" in res.output
    assert "recognise" not in CliRunner().invoke(main, ["--help"]).output.split("Commands:")[1]
    a, b = tmp_path / "a.h5", tmp_path / "b.h5"
    write_archive(a, trials=("t1",))
    write_archive(b, trials=("t1", "t2"))
    res = CliRunner().invoke(main, ["validate", str(a), str(b)])
    assert res.exit_code == 0
    assert [ln.split(":")[0] for ln in res.stdout.splitlines()] == [str(a), str(b)]
    bad = tmp_path / "bad.h5"
    bad.write_bytes(b"not hdf5")
    res = CliRunner().invoke(main, ["validate", str(a), str(bad), "--json"])
    out = json.loads(res.stdout)
    assert res.exit_code == 1 and out["ok"] is False
    assert [r["ok"] for r in out["archives"]] == [True, False]


def test_reproduce_list_shows_the_readme_table_what_and_headline():
    import re
    from pathlib import Path

    readme = (Path(__file__).resolve().parents[1] / "README.md").read_text()
    table = {}
    for line in readme.splitlines():
        m = re.match(r"^\| `([a-z0-9-]+)` \| [^|]+ \| ([^|]+) \| ([^|]+) \|$", line)
        if m and m.group(1) in EXPERIMENTS:
            table[m.group(1)] = (m.group(2).strip(), m.group(3).strip())
    assert set(table) == set(EXPERIMENTS)
    result = CliRunner().invoke(main, ["reproduce", "--list", "--json"])
    rows = {e["name"]: e for e in json.loads(result.stdout)["experiments"]}
    for name, (what, headline) in table.items():
        assert rows[name]["what"] == what
        if EXPERIMENTS[name].implemented:
            assert rows[name]["headline"] == headline
    text = CliRunner().invoke(main, ["reproduce", "--list"]).stdout
    assert table["ph-demo"][1] in text


def test_counts_read_in_the_right_number():
    from contactlab.cli.common import count

    assert [count(n, "trial") for n in (0, 1, 2)] == ["0 trials", "1 trial", "2 trials"]


def test_a_closed_pipe_stops_quietly():
    """``contactlab reproduce --list | head``: when stdout's reader has gone, the command
    stops without a message, with the status of a process killed by SIGPIPE (141)."""
    proc = subprocess.Popen([sys.executable, "-m", "contactlab", "reproduce", "--list"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    proc.stdout.close()                     # the reader goes away before anything is read
    err = proc.stderr.read().decode()
    assert proc.wait(timeout=120) == 141
    assert err == ""
