"""contactlab acquire: exit codes, one JSON object, overwrite/append rules, and an
interrupted acquisition (a real SIGTERM / SIGINT to a child process) keeping its
finished trials."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time

import h5py
import numpy as np
import pytest

from contactlab.archive import open_archive, validate_archive
from conftest import one_json_object, run_cli

QUICK = """
name = "quick"
title = "quick guarded moves"
thesis = "9.1.1"
rate_hz = 1000.0
duration_s = {duration}
labels = "contacts"
[environment]
kind = "plane"
[controller]
kind = "position"
moves = [{{ displacement_m = [0.0, 0.0, -0.015], duration_s = 0.2, start_s = 0.0 }}]
[[group]]
name = "g"
trials = {trials}
"""


run = run_cli


@pytest.fixture
def quick(tmp_path):
    p = tmp_path / "quick.toml"
    p.write_text(QUICK.format(duration=0.3, trials=3))
    return p


def test_json_is_one_object_and_archive_validates(quick, tmp_path):
    out = tmp_path / "q.h5"
    res = run("acquire", "--spec", quick, "--out", out, "--trials", 2, "--seed", 4, "--json")
    assert res.exit_code == 0, res.output
    obj = one_json_object(res.stdout)
    assert obj == {"file": str(out), "trials_written": 2, "trial_ids": ["quick-000", "quick-001"],
                   "seed": 4, "source": "sim", "spec": "quick"}
    assert validate_archive(out) == []


def test_default_trial_count_is_the_specs(quick, tmp_path):
    res = run("acquire", "--spec", quick, "--out", tmp_path / "q.h5", "--quiet")
    assert res.exit_code == 0, res.output
    assert "3 trials written" in res.stdout


def test_refuses_overwrite_then_force_then_append(quick, tmp_path):
    out = tmp_path / "q.h5"
    assert run("acquire", "--spec", quick, "--out", out, "--trials", 1, "-q").exit_code == 0
    before = out.read_bytes()
    res = run("acquire", "--spec", quick, "--out", out, "--trials", 1, "-q")
    assert res.exit_code == 1 and "--force" in res.stderr and len(res.stderr.splitlines()) == 1
    assert out.read_bytes() == before
    assert run("acquire", "--spec", quick, "--out", out, "--trials", 1, "--force", "-q"
               ).exit_code == 0
    res = run("acquire", "--spec", quick, "--out", out, "--trials", 2, "--append", "--json")
    assert res.exit_code == 0, res.output
    assert one_json_object(res.stdout)["trial_ids"] == ["quick-001", "quick-002"]
    with open_archive(out) as archive:
        assert archive.trial_ids == ["quick-000", "quick-001", "quick-002"]
    assert validate_archive(out) == []


@pytest.mark.parametrize("args, code, text", [
    (["--spec", "nope", "--out", "m.h5"], 2, "unknown dataset spec"),
    (["--out", "m.h5"], 2, "needs --spec"),
    (["--spec", "stroke-a"], 2, "--out"),
    (["--spec", "stroke-a", "--out", "m.h5", "--trials", "0"], 2, "--trials"),
    (["--source", "netft", "--out", "m.h5", "--duration", "1"], 2, "--host"),
    (["--source", "phantom", "--out", "m.h5"], 2, "--duration"),
    (["--spec", "stroke-a", "--out", "m.h5", "--append"], 2, "does not exist"),
])
def test_usage_errors_are_one_line(tmp_path, monkeypatch, args, code, text):
    monkeypatch.chdir(tmp_path)
    res = run("acquire", *args)
    assert res.exit_code == code, res.output
    assert text in res.stderr and len(res.stderr.strip().splitlines()) == 1
    assert not (tmp_path / "m.h5").exists()


def test_bad_spec_file_is_a_data_error(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text(QUICK.format(duration=-1, trials=1))
    res = run("acquire", "--spec", bad, "--out", tmp_path / "b.h5")
    assert res.exit_code == 1
    assert f"{bad}: duration_s: must be positive" in res.stderr


def test_list_specs_json():
    res = run("acquire", "--list-specs", "--json")
    assert res.exit_code == 0
    names = {s["name"] for s in one_json_object(res.stdout)["specs"]}
    assert {"stroke-a", "hf-train", "maze"} <= names


def test_help_has_examples():
    res = run("acquire", "--help")
    assert res.exit_code == 0 and "contactlab acquire --spec stroke-a" in res.stdout


@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGINT])
def test_interrupted_acquisition_keeps_finished_trials(tmp_path, sig):
    spec = tmp_path / "slow.toml"
    spec.write_text(QUICK.format(duration=20.0, trials=40))  # ~0.5 s per trial, 40 trials
    out = tmp_path / "slow.h5"
    env = dict(os.environ, PYTHONUNBUFFERED="1")
    proc = subprocess.Popen([sys.executable, "-m", "contactlab", "acquire", "--spec", str(spec),
                             "--out", str(out), "--seed", "3"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)
    deadline = time.monotonic() + 60
    seen = []
    try:
        for line in proc.stderr:  # the progress marker: one line per finished trial
            seen.append(line)
            if "written (1/40)" in line:
                break
            assert time.monotonic() < deadline, "".join(seen)
        else:
            pytest.fail("child ended before finishing a trial: " + "".join(seen))
        proc.send_signal(sig)
        _, err = proc.communicate(timeout=30)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    assert proc.returncode == 128 + sig, err  # 143 for SIGTERM, 130 for SIGINT
    assert err.strip().splitlines()[-1] == (
        f"contactlab: {'terminated' if sig == signal.SIGTERM else 'interrupted'} "
        f"({signal.Signals(sig).name})"), err
    assert "internal error" not in err and "Exception ignored" not in err, err
    assert validate_archive(out) == []
    with open_archive(out) as archive:
        ids = archive.trial_ids
        assert 1 <= len(ids) < 40
        assert ids == [f"quick-{k:03d}" for k in range(len(ids))]
        assert all(t.n_samples == 20000 and t.attrs["complete"] for t in archive)
    assert not [p for p in tmp_path.iterdir() if p.name.endswith(".tmp")]


def test_netft_source_records_from_the_fake_sensor(tmp_path):
    from fake_netft import FakeNetFT

    script = [(500 + i, 10 * i, 0, (1000 * i, 0, 2_000_000, 0, 0, 0)) for i in range(400)
              if i != 100]  # one packet lost
    out = tmp_path / "ft.h5"
    with FakeNetFT(script) as fake:
        res = run("acquire", "--source", "netft", "--host", "127.0.0.1", "--port", fake.port,
                  "--duration", 0.2, "--out", out, "--json")
    assert res.exit_code == 0, res.output
    obj = one_json_object(res.stdout)
    assert obj["source"] == "netft" and obj["trials_written"] == 1 and obj["spec"] is None
    assert validate_archive(out) == []
    with open_archive(out) as archive:
        (trial,) = list(archive)
        assert trial.attrs["source"] == "netft" and trial.n_samples > 100
        assert trial.truth_names() == []
        assert trial.attrs["dropped_packets"] == 1
        with h5py.File(out, "r") as f:  # the RDT bookkeeping is kept per sample
            seq = f[f"/trials/{trial.id}/measurements/rdt_sequence"][()]
        assert len(seq) == trial.n_samples and np.all(np.diff(seq) >= 1)
        assert np.count_nonzero(np.diff(seq) == 2) == 1  # the lost packet's gap
