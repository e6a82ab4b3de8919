"""contactlab watch: live conditioning equals the batch one, the live run decides what
recognize decides on the recording it wrote, and the sources' faults are survived."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pandas as pd
import pytest

from conftest import synthetic_measurements
from contactlab.live.conditioner import LiveConditioner
from contactlab.signals import trial_signals

REPO = Path(__file__).resolve().parents[1]
CLI = [sys.executable, "-m", "contactlab"]
WRIST_COLUMNS = "time=t;wrench=fx,fy,fz,tx,ty,tz;position=x,y,z"


def _run(*args, cwd, input=None, timeout=300):
    env = {**os.environ, "PYTHONWARNINGS": "ignore"}
    return subprocess.run([*CLI, *map(str, args)], cwd=cwd, input=input, capture_output=True,
                          text=True, timeout=timeout, env=env)


def _lines(stdout: str) -> list[dict]:
    return [json.loads(line) for line in stdout.splitlines() if line.strip()]


@pytest.mark.parametrize("signals,reduce,velocity", [
    (("hf",), "mean", True), (("hf", "velocity"), "none", False),
    (("contact", "velocity"), "none", True), (("contact", "velocity"), "none", False),
    (("strain", "position"), "none", True), (("phase",), "none", False),
    (("velocity",), "none", False)])
@pytest.mark.parametrize("rate", [1000.0, 500.0, 200.0])
def test_live_conditioning_equals_batch_for_any_split(signals, reduce, velocity, rate):
    d = synthetic_measurements(3001, rate_hz=rate, seed=3)
    d["strain"] = np.round(d["strain"] * 2000) / 2000             # quantised, as recorded
    trial = SimpleNamespace(id="t", rate_hz=rate, time=d["time"], strain=d["strain"],
                            wrench=d["wrench"], position=d["position"],
                            velocity=d["velocity"] if velocity else None, labels=None,
                            label_names=None, action=None, command=None)
    want, index, _ = trial_signals(trial, signals, reduce=reduce)
    raw = {k: d[k] for k in ("time", "strain", "wrench", "position")}
    if velocity:
        raw["velocity"] = d["velocity"]
    rng = np.random.default_rng(len(signals))
    for cuts in (np.sort(rng.integers(0, 3001, 200)), np.arange(1, 3001), np.array([])):
        lc = LiveConditioner(signals, rate_hz=rate, fields=[k for k in raw if k != "time"],
                             reduce=reduce)
        bounds = np.r_[0, cuts, 3001].astype(int)
        outs = [lc.update({k: v[a:b] for k, v in raw.items()})
                for a, b in zip(bounds[:-1], bounds[1:])] + [lc.finish()]
        got_index = np.concatenate([o[1] for o in outs])
        assert np.array_equal(got_index, index)
        for s in signals:
            got = np.concatenate([o[0][s] for o in outs if len(o[1])])
            if s == "hf":   # the log floor from the first rows: the same step, to rounding
                np.testing.assert_allclose(got, want[s], rtol=1e-13, atol=0)
            else:           # bit for bit
                assert np.array_equal(got, want[s]), s
        times = np.concatenate([o[2] for o in outs])
        assert np.array_equal(times, d["time"][index])


def test_a_source_lacking_a_signal_is_refused_in_one_line():
    from contactlab.errors import UsageError

    with pytest.raises(UsageError, match="no position"):
        LiveConditioner(("contact", "velocity"), rate_hz=1000.0, fields=["wrench"],
                        source="--source netft:h")


@pytest.fixture(scope="module")
def hf(tmp_path_factory):
    root = tmp_path_factory.mktemp("watch-hf")
    for args in (["acquire", "--spec", "hf-train", "--out", "train.h5", "--seed", "1", "-q"],
                 ["train", "train.h5", "--graph", "hf-context", "--out", "m.h5", "-q"]):
        r = _run(*args, cwd=root)
        assert r.returncode == 0, r.stderr
    return root


def test_watch_sim_decides_what_recognize_decides_on_its_recording(hf):
    r = _run("watch", "--source", "sim:hf-test", "--trials", "2", "--no-realtime",
             "--chunk", "13", "--graph", "hf-context", "--models", "m.h5", "--record",
             "rec.h5", "--probs-every", "0.5", cwd=hf)
    assert r.returncode == 0, r.stderr
    lines = _lines(r.stdout)
    paths = {e["trial"]: e for e in lines if e["event"] == "path"}
    assert set(paths) == {"hf-test-000", "hf-test-001"}
    changes = [e for e in lines if e["event"] == "change"]
    assert changes and all(e["latency_ms"] >= 0 and 0 <= e["prob"] <= 1 and
                           e["change_time"] <= e["time"] for e in changes)
    assert any(e["node"] == "H3" for e in changes)             # the impact, seen live
    probs = [e for e in lines if e["event"] == "probs"]
    assert len(probs) >= 2 * 7 and all(abs(sum(e["p"].values()) - 1) < 1e-9 for e in probs)
    assert lines[-1]["event"] == "summary" and lines[-1]["samples"] == 2 * 873
    r2 = _run("recognize", "rec.h5", "--graph", "hf-context", "--models", "m.h5",
              "--no-write", "--json", cwd=hf)
    assert r2.returncode == 0, r2.stderr
    offline = json.loads(r2.stdout)["trials"]
    for tid, e in paths.items():
        assert e["path"] == offline[tid]["merged_path"]
    # the results watch wrote are the ones recognize writes, sample for sample
    import h5py
    r3 = _run("recognize", "rec.h5", "--graph", "hf-context", "--models", "m.h5", "-q",
              cwd=hf)
    assert r3.returncode == 0, r3.stderr
    with h5py.File(hf / "rec.h5") as f:
        g = f["trials/hf-test-000/results/recognize"]
        assert g["map_node"].shape == (873,) and g.attrs["merged_path"]


@pytest.fixture(scope="module")
def wrist(tmp_path_factory):
    from contactlab.synthetic.free_contact import free_contact_recording

    root = tmp_path_factory.mktemp("watch-wrist")
    for name, seed in (("train.csv", 5), ("live.csv", 6)):
        rec = free_contact_recording(seed=seed, fs=200.0, cycles=3)
        cols = rec.csv_columns()
        cols["state"] = [("free", "contact", "free")[c - 1] for c in cols["state"]]
        pd.DataFrame(cols).to_csv(root / name, index=False)
    for args in (["import", "train.csv", "--out", "train.h5", "-q", "--columns",
                  WRIST_COLUMNS + ";labels=state"],
                 ["train", "train.h5", "--graph", "free-contact", "--out", "fc.h5", "-q"]):
        r = _run(*args, cwd=root)
        assert r.returncode == 0, r.stderr
    return root


def test_piped_csv_with_a_malformed_line_equals_recognize(wrist):
    text = (wrist / "live.csv").read_text().splitlines()
    text.insert(300, "1.0,oops,2")                    # a malformed line
    text.insert(500, text[499])                       # a repeated time stamp
    r = _run("watch", "--source", "-", "--graph", "free-contact", "--models", "fc.h5",
             "--columns", WRIST_COLUMNS, "--record", "live.h5", cwd=wrist,
             input="\n".join(text) + "\n")
    assert r.returncode == 0, r.stderr
    err = r.stderr.strip().splitlines()
    assert len(err) == 2 and "line 301: malformed" in err[0] and "time does not" in err[1]
    lines = _lines(r.stdout)
    path = next(e for e in lines if e["event"] == "path")
    nodes = [n for n, _ in path["path"]]
    assert nodes[0] == "free" and nodes.count("contact") >= 2    # three touches
    r2 = _run("recognize", "live.h5", "--graph", "free-contact", "--models", "fc.h5",
              "--no-write", "--json", cwd=wrist)
    assert r2.returncode == 0, r2.stderr
    assert json.loads(r2.stdout)["trials"]["stdin"]["merged_path"] == path["path"]


def test_netft_alone_is_refused_for_a_graph_reading_position(wrist):
    r = _run("watch", "--source", "netft:127.0.0.1:9", "--graph", "free-contact",
             "--models", "fc.h5", cwd=wrist)
    assert r.returncode == 2
    assert len(r.stderr.strip().splitlines()) == 1 and "no position" in r.stderr


WRENCH_GRAPH = """name = "wrench-levels"
title = "free or pressing, from the wrench alone"
edges = ["* -> *"]
initial = "uniform"
[models.F]
kind = "temporal"
trained = "free"
signal = "wrench"
[models.C]
kind = "temporal"
trained = "contact"
signal = "wrench"
[[nodes]]
name = "free"
models = "F"
[[nodes]]
name = "contact"
models = "C"
"""


def test_netft_fake_stalls_reconnects_and_keeps_the_recording(wrist):
    sys.path.insert(0, str(REPO / "tests"))
    from fake_netft import FakeNetFT

    (wrist / "wrench.toml").write_text(WRENCH_GRAPH)
    r = _run("train", "train.h5", "--graph", "wrench.toml", "--out", "wm.h5", "-q",
             "--force", cwd=wrist)
    assert r.returncode == 0, r.stderr
    rng = np.random.default_rng(0)
    counts = (rng.normal(size=(600, 6)) * 20000).astype(int)
    counts[300:, 2] += 2_000_000                        # a press: 2 N more on z
    script = [(k + 1, k + 1, 0, counts[k]) for k in range(600)]
    with FakeNetFT(script, pace_hz=2000) as fake:
        r = _run("watch", "--source", f"netft:127.0.0.1:{fake.port}", "--graph",
                 "wrench.toml", "--models", "wm.h5", "--trials", "2", "--rate", "1000",
                 "--record", "netft.h5", cwd=wrist, timeout=60)
    assert r.returncode == 0, r.stderr
    lines = _lines(r.stdout)
    assert "stopped after 600" in r.stderr and "reconnecting" in r.stderr
    assert lines[-1]["event"] == "summary" and lines[-1]["faults"] >= 1
    first = next(e for e in lines if e["event"] == "path")
    assert first["samples"] == 600 // 4 and first["complete"] is False
    import h5py
    with h5py.File(wrist / "netft.h5") as f:       # the recording up to the stall is kept
        assert len(f["trials/netft01/measurements/time"]) == 600
        assert "recognize" in f["trials/netft01/results"]
    r2 = _run("recognize", "netft.h5", "--trial", "netft01", "--graph", "wrench.toml",
              "--models", "wm.h5", "--no-write", "--json", cwd=wrist)
    assert json.loads(r2.stdout)["trials"]["netft01"]["merged_path"] == first["path"]


def test_live_friction_compensation_uses_the_first_second_noise_level():
    """contact-compensated live: the contact stream of the batch form with 8.29's filter
    at the velocity noise level of the recording's first second (the batch form measures
    it on the whole recording), in any split into chunks."""
    from types import SimpleNamespace

    from contactlab.live.conditioner import COMPENSATION_WARMUP_S, LiveConditioner
    from contactlab.signals import compensate_friction, trial_signals, velocity_noise_level
    from contactlab.synthetic.free_contact import free_contact_recording

    rec = free_contact_recording(seed=3, fs=100.0, cycles=3)
    t, n = rec.times, len(rec.times)
    wrench = np.c_[rec.force, np.zeros((n, 3))]
    trial = SimpleNamespace(id="x", rate_hz=100.0, time=t, strain=None, wrench=wrench,
                            position=rec.position, velocity=None, labels=None,
                            label_names=None, action=None, command=None)
    batch, _, fs = trial_signals(trial, ("contact", "velocity"))
    level = velocity_noise_level(batch["velocity"][:int(round(COMPENSATION_WARMUP_S * fs))])
    want = batch["contact"].copy()
    want[:, 3:] = compensate_friction(want[:, 3:], batch["velocity"], level=level)
    rng = np.random.default_rng(1)
    lc = LiveConditioner(("contact-compensated",), rate_hz=100.0, fields=["wrench", "position"])
    parts, a = [], 0
    while a < n:
        b = a + int(rng.integers(1, 80))
        parts.append(lc.update({"time": t[a:b], "wrench": wrench[a:b],
                                 "position": rec.position[a:b]})[0])
        a = b
    parts.append(lc.finish()[0])
    assert all(set(p) == {"contact-compensated"} for p in parts)
    got = np.concatenate([p["contact-compensated"] for p in parts
                          if len(p["contact-compensated"])])
    np.testing.assert_array_equal(got, want)
